"""MuJoCo, imported once its OpenGL backend is chosen: the package imports ``mujoco`` from here.

``from revolve_env.world.mujoco_gl import mujoco`` is how every module of the package that uses
MuJoCo imports it, so that wherever MuJoCo is first imported, :func:`.opengl.choose_mujoco_gl`
has run before it: on a machine without a display, headless rendering (EGL, else OSMesa) works
with no ``MUJOCO_GL`` set. Setting an environment variable on import is a side effect the code
otherwise avoids: here it is the only way, MuJoCo reading the variable when it loads. Child
processes inherit the choice.
"""

from revolve_env.world.opengl import choose_mujoco_gl

__all__ = ["mujoco"]

choose_mujoco_gl()
import mujoco  # noqa: E402  (after the choice: MuJoCo reads MUJOCO_GL here, once)
import mujoco.batch  # noqa: E402  (its batched stepping: mujoco.batch.Batch, for mujoco_batch)
