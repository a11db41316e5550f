"""Where MuJoCo can draw: its OpenGL backend chosen before it loads, and why it cannot render.

MuJoCo reads ``MUJOCO_GL`` once, at its first import, and its default (GLFW) needs a display, so
on a server a frame fails unless the user set ``MUJOCO_GL=egl`` by hand (as Gymnasium's MuJoCo
envs ask). :func:`choose_mujoco_gl` sets it, where there is no display and it is unset, to the
first headless backend whose library loads: EGL, else OSMesa. A ``MUJOCO_GL`` the user set is
never changed; with a display nothing is set (GLFW: windows and frames); where neither library
loads nothing is set either, and the first frame asked for raises :class:`RenderUnavailableError`
with one line naming what to install (:func:`render_problem`), never an import.
:mod:`revolve_env.world.mujoco_gl` calls it before it imports MuJoCo for the package.

The checks are cheap: a display variable and one ``dlopen`` per library (under a millisecond;
``ctypes.util.find_library`` runs ``ldconfig`` and ``gcc``, 125 ms on a loaded machine), no
child process. Nothing here imports MuJoCo.
"""

from __future__ import annotations

import ctypes
import os
import sys
from collections.abc import Callable, Mapping, MutableMapping

__all__ = ["HOW_TO", "RenderUnavailableError", "choose_mujoco_gl", "has_display",
           "offscreen_backend", "render_problem"]

HOW_TO = ("install EGL (Debian/Ubuntu: apt-get install libegl1) or OSMesa (apt-get install "
          "libosmesa6), or set MUJOCO_GL to a backend that works here")
"""What to do where MuJoCo cannot render: one clause of an error line."""

_LIBRARIES: dict[str, tuple[str, ...]] = {
    "egl": ("libEGL.so.1", "libEGL.so"),
    "osmesa": ("libOSMesa.so.8", "libOSMesa.so.6", "libOSMesa.so"),
}
"""The headless backends in the order tried, each with the library names it loads."""
_KNOWN = ("glfw", "egl", "osmesa", "glx", "enable", "enabled", "on", "true", "1",
          "disable", "disabled", "off", "false", "0", "wgl", "cgl")
"""The values of ``MUJOCO_GL`` MuJoCo accepts (on some platform)."""


class RenderUnavailableError(RuntimeError):
    """MuJoCo cannot draw a frame here (no display and no headless OpenGL library)."""


def has_display(environ: Mapping[str, str] | None = None) -> bool:
    """Whether a window can open here (on Linux: ``$DISPLAY`` or ``$WAYLAND_DISPLAY`` set)."""
    env = os.environ if environ is None else environ
    if not sys.platform.startswith("linux"):
        return True
    return bool(env.get("DISPLAY") or env.get("WAYLAND_DISPLAY"))


def _loads(name: str) -> bool:
    try:
        ctypes.CDLL(name)
    except OSError:
        return False
    return True


def offscreen_backend(environ: Mapping[str, str] | None = None,
                      loads: Callable[[str], bool] | None = None) -> str | None:
    """The headless backend that would render here: ``"egl"``, ``"osmesa"`` or None.

    None where neither library loads (``loads(name)``: whether the shared library ``name``
    loads; default: a ``dlopen`` of it), or where ``PYOPENGL_PLATFORM`` names another platform
    (PyOpenGL, which MuJoCo's headless contexts use, would refuse both).
    """
    env = os.environ if environ is None else environ
    loads = _loads if loads is None else loads
    platform = env.get("PYOPENGL_PLATFORM", "").strip().lower()
    for backend, names in _LIBRARIES.items():
        if platform in ("", backend) and any(loads(name) for name in names):
            return backend
    return None


def choose_mujoco_gl(environ: MutableMapping[str, str] | None = None,
                     loads: Callable[[str], bool] | None = None) -> str | None:
    """Set ``MUJOCO_GL`` (in ``environ``, default ``os.environ``) to a headless backend if needed.

    Only on Linux without a display, with ``MUJOCO_GL`` unset and ``mujoco`` not yet imported
    (it would not read it again). :mod:`revolve_env.world.mujoco_gl` calls it before it
    imports ``mujoco``.

    Returns:
        The backend set, or None where nothing was set.
    """
    env = os.environ if environ is None else environ
    if env.get("MUJOCO_GL", "").strip() or has_display(env) or "mujoco" in sys.modules:
        return None
    backend = offscreen_backend(env, loads)
    if backend is not None:
        env["MUJOCO_GL"] = backend
    return backend


def render_problem(environ: Mapping[str, str] | None = None,
                   loads: Callable[[str], bool] | None = None) -> str | None:
    """Why MuJoCo cannot render here, in one line (None: it should; the context may still fail).

    Cheap checks only (no context is made): a ``MUJOCO_GL`` that MuJoCo does not know, or no
    display and no ``MUJOCO_GL`` (no headless library, or ``mujoco`` imported before this
    module could choose one).
    """
    env = os.environ if environ is None else environ
    chosen = env.get("MUJOCO_GL", "").strip().lower()
    if chosen:
        if chosen in _KNOWN:
            return None
        return (f"MuJoCo cannot render here (MUJOCO_GL={chosen} is no backend MuJoCo knows); "
                f"unset it, or {HOW_TO}")
    if has_display(env):
        return None
    if offscreen_backend(env, loads) is not None:
        return ("MuJoCo cannot render here (no display, and mujoco was imported before "
                "revolve_env could choose a headless OpenGL backend); import revolve_env "
                "before mujoco, or set MUJOCO_GL=egl (or osmesa) before starting Python")
    platform = env.get("PYOPENGL_PLATFORM", "").strip()
    why = (f"PYOPENGL_PLATFORM={platform} rules out EGL and OSMesa" if platform
           else "no EGL or OSMesa library loads")
    return f"MuJoCo cannot render here (no display, and {why}); {HOW_TO}"

