"""Offscreen OpenGL for MuJoCo's renderer: pick one that works here, before MuJoCo loads.

MuJoCo reads ``MUJOCO_GL`` once, when ``mujoco`` is first imported, and its default (GLFW) needs
a display; a failed context creation can abort the whole process. So a program that renders
MuJoCo frames calls :func:`choose_mujoco_gl` first, before anything imports ``mujoco``: it keeps
a ``MUJOCO_GL`` the user set (if it works), else tries GLFW where there is a display, then EGL,
then OSMesa, each in a child process (a failure there cannot abort the caller), and sets
``MUJOCO_GL`` to the first that renders a frame. Where none does it raises
:class:`OffscreenGLError`, one line saying what to install or set.

Nothing happens on import: the choice is the caller's (the ``revolve`` command line makes it
for ``show`` and ``watch --record`` on MuJoCo).
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import MutableMapping

__all__ = ["OffscreenGLError", "choose_mujoco_gl", "probe_mujoco_gl"]

PROBE_TIMEOUT = 60.0
"""Longest wait for one backend's probe (importing MuJoCo and rendering one frame). Seconds."""

_PROBE = """
import mujoco
model = mujoco.MjModel.from_xml_string("<mujoco><worldbody><geom size='1'/></worldbody></mujoco>")
renderer = mujoco.Renderer(model, 8, 8)
renderer.update_scene(mujoco.MjData(model))
renderer.render()
renderer.close()
"""

HOW_TO = ("install EGL (Debian/Ubuntu: apt install libegl1) or OSMesa (apt install libosmesa6), "
          "or set MUJOCO_GL to a backend that works here, or use --engine pybullet")
"""What to do when no backend works."""


class OffscreenGLError(RuntimeError):
    """No OpenGL backend can render MuJoCo frames here."""


def probe_mujoco_gl(backend: str, timeout: float = PROBE_TIMEOUT) -> str | None:
    """Whether MuJoCo renders a frame with ``MUJOCO_GL=backend``, tried in a child process.

    Returns:
        ``None`` if it does, else the last line the child printed (why not).
    """
    env = dict(os.environ, MUJOCO_GL=backend)
    try:
        done = subprocess.run([sys.executable, "-c", _PROBE], env=env, capture_output=True,
                              text=True, timeout=timeout, check=False)
    except subprocess.TimeoutExpired:
        return f"no frame within {timeout:g} s"
    if done.returncode == 0:
        return None
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    return lines[-1].strip() if lines else f"exit status {done.returncode}"


def choose_mujoco_gl(environ: MutableMapping[str, str] | None = None) -> str:
    """Set ``MUJOCO_GL`` (in ``environ``, default ``os.environ``) to a backend that renders.

    Call it before ``mujoco`` is imported in this process.

    Returns:
        The backend in use (``"glfw"``, ``"egl"``, ``"osmesa"``, or the user's choice).

    Raises:
        OffscreenGLError: ``mujoco`` is already imported with a backend that cannot work here,
            the user's ``MUJOCO_GL`` does not render, or no backend does (one line: what to
            install or set).
    """
    env = os.environ if environ is None else environ
    display = not sys.platform.startswith("linux") or bool(
        env.get("DISPLAY") or env.get("WAYLAND_DISPLAY"))
    chosen = env.get("MUJOCO_GL", "").strip().lower()
    if "mujoco" in sys.modules:  # MuJoCo has read MUJOCO_GL already: nothing to change
        if chosen in ("", "glfw") and not display:
            raise OffscreenGLError("MuJoCo was imported before an offscreen OpenGL backend was "
                                   "chosen and there is no display; set MUJOCO_GL=egl (or "
                                   "osmesa) before starting Python")
        return chosen or "glfw"
    if chosen:
        why = probe_mujoco_gl(chosen)
        if why is not None:
            raise OffscreenGLError(f"MuJoCo cannot render with MUJOCO_GL={chosen} here ({why}); "
                                   f"unset it or {HOW_TO}")
        return chosen
    tried = []
    for backend in (["glfw"] if display else []) + ["egl", "osmesa"]:
        why = probe_mujoco_gl(backend)
        if why is None:
            env["MUJOCO_GL"] = backend
            return backend
        tried.append(f"{backend}: {why}")
    raise OffscreenGLError(f"MuJoCo cannot render here ({'; '.join(tried)}); {HOW_TO}")
