"""MuJoCo's OpenGL backend: chosen before MuJoCo loads where there is no display (issue 31).

The choice is pure over an environment mapping and a "does this library load" function, so it
is tested here without touching the process's environment; the end-to-end runs (no
``MUJOCO_GL`` set, MuJoCo rendering through every route) are in
``tests/evolution/cli/test_render_headless.py``.
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable

import pytest

from revolve_env.world import opengl


def _only(*names: str) -> Callable[[str], bool]:
    return lambda name: name in names


EGL, OSMESA = "libEGL.so.1", "libOSMesa.so.8"


def test_egl_is_chosen_first_then_osmesa_where_there_is_no_display(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delitem(sys.modules, "mujoco", raising=False)
    env: dict[str, str] = {}
    assert opengl.choose_mujoco_gl(env, _only(EGL, OSMESA)) == "egl"
    assert env == {"MUJOCO_GL": "egl"}
    env = {}
    assert opengl.choose_mujoco_gl(env, _only(OSMESA)) == "osmesa"
    assert env == {"MUJOCO_GL": "osmesa"}
    env = {"PYOPENGL_PLATFORM": "osmesa"}  # PyOpenGL would refuse EGL
    assert opengl.choose_mujoco_gl(env, _only(EGL, OSMESA)) == "osmesa"


def test_nothing_is_set_with_a_display_a_users_choice_or_no_library(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delitem(sys.modules, "mujoco", raising=False)
    monkeypatch.setattr(sys, "platform", "linux")
    both = _only(EGL, OSMESA)
    for env in ({"DISPLAY": ":0"}, {"WAYLAND_DISPLAY": "wayland-0"}, {"MUJOCO_GL": "osmesa"},
                {"MUJOCO_GL": "glfw"}):
        before = dict(env)
        assert opengl.choose_mujoco_gl(env, both) is None and env == before
    env = {}
    assert opengl.choose_mujoco_gl(env, _only()) is None and env == {}
    env = {"PYOPENGL_PLATFORM": "none-here"}
    assert opengl.choose_mujoco_gl(env, both) is None and "MUJOCO_GL" not in env


def test_nothing_is_set_once_mujoco_is_imported(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "mujoco", sys)  # anything: it is the name that counts
    env: dict[str, str] = {}
    assert opengl.choose_mujoco_gl(env, _only(EGL)) is None and env == {}


def test_render_problem_names_the_fix_in_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sys, "platform", "linux")
    assert opengl.render_problem({"MUJOCO_GL": "egl"}, _only()) is None
    assert opengl.render_problem({"DISPLAY": ":0"}, _only()) is None
    missing = opengl.render_problem({}, _only())
    assert missing is not None and "\n" not in missing
    assert missing.startswith("MuJoCo cannot render here (no display")
    assert "apt-get install libegl1" in missing and "libosmesa6" in missing
    late = opengl.render_problem({}, _only(EGL))  # a library, but MuJoCo loaded before the choice
    assert late is not None and "import revolve_env before mujoco" in late
    bogus = opengl.render_problem({"MUJOCO_GL": "bogus"}, _only(EGL))
    assert bogus is not None and "MUJOCO_GL=bogus" in bogus


def test_the_choice_costs_no_child_process_and_little_time() -> None:
    """Importing the package's MuJoCo starts no process (the probe of old did, per backend)."""
    code = ("import subprocess, time\n"
            "def refuse(*a, **k): raise AssertionError('a child process at import')\n"
            "subprocess.Popen.__init__ = refuse\n"
            "from revolve_env.world import opengl\n"
            "t = time.process_time(); opengl.offscreen_backend({}); "
            "print(time.process_time() - t)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    assert float(done.stdout) < 0.05  # seconds of CPU: a dlopen or two
