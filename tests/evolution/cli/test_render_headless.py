"""Rendering MuJoCo frames without a display (issue 20).

``revolve show --engine mujoco`` and ``watch --record`` of a MuJoCo run pick an offscreen OpenGL
backend that works here (EGL, then OSMesa) before MuJoCo loads, or stop with one line saying
what to install or set: exit 2, never a traceback. The commands run in child processes, as a
user runs them: MuJoCo reads ``MUJOCO_GL`` once, when it is first imported.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import MutableMapping
from pathlib import Path

import pytest

from evolution.cli import main
from revolve_env.envs import offscreen

pytest.importorskip("mujoco")

ROOT = Path(__file__).resolve().parents[3]


def _headless(**extra: str) -> dict[str, str]:
    """This environment without a display or a chosen backend (plus ``extra``)."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("DISPLAY", "WAYLAND_DISPLAY", "MUJOCO_GL", "PYOPENGL_PLATFORM")}
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
    return {**env, **extra}


def _show(tmp_path: Path, env: MutableMapping[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "evolution.cli", "show", "spider", "--engine", "mujoco",
         "--seconds", "0.5", "--insertion", "0", "--fps", "8", "--out", str(tmp_path / "s.gif")],
        cwd=ROOT, env=dict(env), capture_output=True, text=True, timeout=300, check=False)


def test_without_any_backend_show_says_what_to_install_on_one_line(tmp_path: Path) -> None:
    # PYOPENGL_PLATFORM naming no platform makes both EGL and OSMesa fail to load.
    done = _show(tmp_path, _headless(PYOPENGL_PLATFORM="none-here"))
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in done.stderr, done.stderr
    assert lines[0].startswith("revolve show: error: MuJoCo cannot render here")
    assert "apt install libegl1" in lines[0] and "MUJOCO_GL" in lines[0]
    assert not (tmp_path / "s.gif").exists()


def test_a_backend_the_user_set_that_does_not_work_is_named(tmp_path: Path) -> None:
    done = _show(tmp_path, _headless(MUJOCO_GL="bogus"))
    assert done.returncode == 2, done.stderr
    assert len(done.stderr.strip().splitlines()) == 1
    assert "MUJOCO_GL=bogus" in done.stderr


def test_choose_tries_egl_then_osmesa_and_sets_the_first_that_works(
        monkeypatch: pytest.MonkeyPatch) -> None:
    tried: list[str] = []

    def probe(backend: str, timeout: float = 0.0) -> str | None:
        tried.append(backend)
        return None if backend == "osmesa" else f"no {backend}"

    monkeypatch.setattr(offscreen, "probe_mujoco_gl", probe)
    monkeypatch.delitem(sys.modules, "mujoco", raising=False)
    env: dict[str, str] = {}
    assert offscreen.choose_mujoco_gl(env) == "osmesa"
    assert tried == ["egl", "osmesa"] and env == {"MUJOCO_GL": "osmesa"}


def test_the_cli_refuses_before_anything_is_simulated(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    import revolve_env.envs.recording

    def never(*args: object, **kwargs: object) -> None:
        raise AssertionError("simulated although nothing can render")

    monkeypatch.setattr(offscreen, "probe_mujoco_gl", lambda backend, timeout=0.0: "no GL")
    monkeypatch.setattr(revolve_env.envs.recording, "record_robot", never)
    monkeypatch.delitem(sys.modules, "mujoco", raising=False)
    for name in ("DISPLAY", "WAYLAND_DISPLAY", "MUJOCO_GL"):
        monkeypatch.delenv(name, raising=False)
    assert main(["show", "spider", "--engine", "mujoco", "--out", str(tmp_path / "s.gif")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "MuJoCo cannot render here" in err[0]


def _a_backend_works() -> bool:
    return any(offscreen.probe_mujoco_gl(b) is None for b in ("egl", "osmesa"))


def test_show_renders_mujoco_frames_without_a_display(tmp_path: Path) -> None:
    if not _a_backend_works():
        pytest.skip("no offscreen OpenGL here (EGL or OSMesa)")
    done = _show(tmp_path, _headless())
    assert done.returncode == 0, done.stderr
    from PIL import Image

    with Image.open(tmp_path / "s.gif") as gif:
        assert gif.n_frames == 4  # 30 control periods: frames at 8, 16, 24 and the last
