"""What MuJoCo's frames and window show: the scene copied with looks only (imports ``mujoco``).

Part of the MuJoCo backend. Frames are drawn from a model of their own, compiled from a copy of
the scene's spec: the ground gets a grid (a checker of :data:`GRID` metre squares with darker
edges, on the plane or draped over a terrain's heightfield) so that motion can be seen, a light
slanting from the side shades a terrain's slopes, the headlight is brighter and the field of
view is every engine's (:data:`~revolve_env.world.camera.FOV_DEG`), so that both engines frame
a camera alike. Each frame copies the physics' positions (``qpos``) into the view's own
``MjData`` and computes its kinematics there. The model the physics steps is never touched:
its compiled bytes (which snapshots compare), its contacts and every number stay what they
were.

:class:`Viewer` is the same picture in MuJoCo's own interactive window
(``mujoco.viewer.launch_passive``), for ``render_mode="human"``; it needs a display.
"""

from __future__ import annotations

import importlib
from typing import Any

import numpy as np
from numpy.typing import NDArray

from revolve_env.world.camera import FOV_DEG
from revolve_env.world.mujoco_gl import mujoco  # its OpenGL backend chosen first

__all__ = ["GRID", "View", "Viewer", "view_model"]

GRID = 0.25
"""Side of a square of the ground's checker. Metres."""
_RGB_LIGHT, _RGB_DARK, _RGB_EDGE = [0.92, 0.92, 0.88], [0.78, 0.78, 0.74], [0.45, 0.45, 0.45]


def view_model(spec: mujoco.MjSpec, width: int, height: int) -> mujoco.MjModel:
    """The model frames are drawn from: ``spec`` (a scene's) copied, with looks added.

    Args:
        spec: The scene's spec (unchanged).
        width: Largest frame width it must draw. Pixels.
        height: Largest frame height. Pixels.
    """
    look = spec.copy()
    texture = look.add_texture()
    texture.name = "revolve_grid"
    texture.type = mujoco.mjtTexture.mjTEXTURE_2D
    texture.builtin = mujoco.mjtBuiltin.mjBUILTIN_CHECKER
    texture.width = texture.height = 512
    texture.rgb1, texture.rgb2 = _RGB_LIGHT, _RGB_DARK
    texture.mark = mujoco.mjtMark.mjMARK_EDGE
    texture.markrgb = _RGB_EDGE
    material = look.add_material()
    material.name = "revolve_grid"
    roles = list(material.textures)
    roles[int(mujoco.mjtTextureRole.mjTEXROLE_RGB)] = texture.name
    material.textures = roles
    material.texuniform = True
    material.texrepeat = [0.5 / GRID, 0.5 / GRID]  # repeats per metre; a repeat is 2 x 2 squares
    material.reflectance = 0.0
    ground = look.geom("ground")
    ground.material = material.name
    ground.rgba = [1.0, 1.0, 1.0, 1.0]
    side = look.worldbody.add_light()
    side.type = mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
    side.pos = [2.0, -2.0, 4.0]
    side.dir = [-0.5, 0.5, -1.0]
    side.diffuse = [0.5, 0.5, 0.5]
    side.castshadow = True
    visual = look.visual
    visual.headlight.ambient = [0.35, 0.35, 0.35]
    visual.headlight.diffuse = [0.5, 0.5, 0.5]
    visual.global_.fovy = FOV_DEG
    visual.global_.offwidth = max(width, visual.global_.offwidth)
    visual.global_.offheight = max(height, visual.global_.offheight)
    model: mujoco.MjModel = look.compile()
    return model


def _camera(target: tuple[float, float, float], distance: float, yaw_deg: float,
            pitch_deg: float) -> mujoco.MjvCamera:
    camera = mujoco.MjvCamera()
    camera.lookat[:] = target
    camera.distance = distance
    camera.azimuth = yaw_deg + 90.0  # (camera.py's convention; azimuth 0 looks along +x)
    camera.elevation = pitch_deg
    return camera


class View:
    """An offscreen renderer of one compiled scene at one frame size.

    Args:
        physics: The model the physics steps (kept to tell when the scene changed).
        spec: Its spec.
        width: Frame width. Pixels.
        height: Frame height. Pixels.

    Raises:
        Exception: MuJoCo could make no OpenGL context (whatever its backend raised).
    """

    def __init__(self, physics: mujoco.MjModel, spec: mujoco.MjSpec, width: int,
                 height: int) -> None:
        self.physics = physics
        self.width, self.height = width, height
        self._model = view_model(spec, width, height)
        self._data = mujoco.MjData(self._model)
        self._renderer = mujoco.Renderer(self._model, height, width)

    def frame(self, qpos: NDArray[np.float64], target: tuple[float, float, float],
              distance: float, yaw_deg: float, pitch_deg: float) -> NDArray[np.uint8]:
        """An RGB frame (height, width, 3) of the scene at positions ``qpos``."""
        self._data.qpos[:] = qpos
        mujoco.mj_kinematics(self._model, self._data)
        self._renderer.update_scene(self._data, _camera(target, distance, yaw_deg, pitch_deg))
        return np.asarray(self._renderer.render(), dtype=np.uint8).copy()

    def close(self) -> None:
        """Release the OpenGL context."""
        self._renderer.close()


class Viewer:
    """MuJoCo's interactive window on a scene, opened at the first :meth:`show`.

    A scene that changed (a birth, a death, a reset) opens a new window on the new model; a
    window the user closed stays closed.
    """

    def __init__(self) -> None:
        self._handle: Any = None
        self._physics: mujoco.MjModel | None = None
        self._model: mujoco.MjModel | None = None
        self._data: mujoco.MjData | None = None
        self._closed_by_user = False

    def show(self, physics: mujoco.MjModel, spec: mujoco.MjSpec, qpos: NDArray[np.float64],
             target: tuple[float, float, float], distance: float) -> None:
        """Draw the scene at positions ``qpos``; a new window looks at ``target`` (metres)."""
        if self._closed_by_user:
            return
        if self._handle is not None and not self._handle.is_running():
            self._closed_by_user = True
            self.close()
            return
        if self._handle is None or physics is not self._physics:
            self.close()
            viewer = importlib.import_module("mujoco.viewer")  # needs GLFW: only here
            self._physics = physics
            self._model = view_model(spec, 1, 1)
            self._data = mujoco.MjData(self._model)
            self._handle = viewer.launch_passive(self._model, self._data)
            self._handle.cam.lookat[:] = target
            self._handle.cam.distance = distance
        assert self._model is not None and self._data is not None
        with self._handle.lock():
            self._data.qpos[:] = qpos
            mujoco.mj_kinematics(self._model, self._data)
        self._handle.sync()

    def close(self) -> None:
        """Close the window, if open."""
        if self._handle is not None:
            self._handle.close()
            self._handle = None
