"""Rendering MuJoCo frames without a display and without ``MUJOCO_GL`` (issues 20 and 31).

Every route a user takes renders MuJoCo frames on a server with nothing set: ``gym.make(...,
engine="mujoco", render_mode="rgb_array")`` and Gymnasium's ``check_env`` on it, ``revolve show``
of an example or of a stored MuJoCo run (``--db``), and ``revolve watch --record`` of a stored
MuJoCo online run. The package chooses a headless backend (EGL, else OSMesa) before MuJoCo is
first imported, wherever that happens (:mod:`revolve_env.world.mujoco_gl`); where none exists it
says in one line what to install: exit 2, never a traceback. The commands run in child
processes, as a user runs them: MuJoCo reads ``MUJOCO_GL`` once, when it is first imported.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pytest
from experiment_fakes import small, tiny_run

from evolution import experiments
from evolution.cli import main
from evolution.evaluation import LocalEvaluator
from evolution.experiments import DB_NAME, Store
from revolve_env.body.robot import PartType
from revolve_env.body.serialize import from_json
from revolve_env.world import opengl

pytest.importorskip("mujoco")

ROOT = Path(__file__).resolve().parents[3]


def _headless(**extra: str) -> dict[str, str]:
    """This environment without a display or a chosen backend (plus ``extra``)."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("DISPLAY", "WAYLAND_DISPLAY", "MUJOCO_GL", "PYOPENGL_PLATFORM")}
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
    return {**env, **extra}


def _run(args: list[str], env: Mapping[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, *args], cwd=ROOT, env=dict(env), capture_output=True,
                          text=True, timeout=600, check=False)


def _show(tmp_path: Path, env: Mapping[str, str]) -> subprocess.CompletedProcess[str]:
    return _run(["-m", "evolution.cli", "show", "spider", "--engine", "mujoco", "--seconds",
                 "0.5", "--insertion", "0", "--fps", "8", "--out", str(tmp_path / "s.gif")], env)


def _frames(path: Path) -> list[np.ndarray]:
    from PIL import Image, ImageSequence

    with Image.open(path) as video:
        return [np.asarray(f.convert("RGB")) for f in ImageSequence.Iterator(video)]


def _grid_rows(frame: np.ndarray) -> int:
    """Rows of the lower half where the ground's grey changes sharply (checker edges).

    A plain floor shades smoothly (0-3 such rows of 180 at 480 x 360 before the grid, 166
    with it); the grid's squares differ by 30 levels. Counted on grey pixels only (the robot is
    coloured).
    """
    low = frame[frame.shape[0] // 2:].astype(int)
    grey = np.ptp(low, axis=2) < 12
    green = low[..., 1]
    step = np.abs(green[:, 2:] - green[:, :-2]) > 15  # over two pixels: edges are smoothed
    return int(np.sum((step & grey[:, 2:] & grey[:, :-2]).any(axis=1)))


def _a_backend_works() -> bool:
    return opengl.offscreen_backend(_headless()) is not None


needs_gl = pytest.mark.skipif(not _a_backend_works(),
                              reason="no offscreen OpenGL here (EGL or OSMesa)")


def test_without_any_backend_show_says_what_to_install_on_one_line(tmp_path: Path) -> None:
    # PYOPENGL_PLATFORM naming no platform makes both EGL and OSMesa unusable.
    done = _show(tmp_path, _headless(PYOPENGL_PLATFORM="none-here"))
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in done.stderr, done.stderr
    assert lines[0].startswith("revolve show: error: MuJoCo cannot render here")
    assert "apt-get install libegl1" in lines[0] and "MUJOCO_GL" in lines[0]
    assert not (tmp_path / "s.gif").exists()


def test_without_any_backend_gym_make_imports_and_the_frame_says_why(tmp_path: Path) -> None:
    code = ("import gymnasium as gym, revolve_env\n"
            "env = gym.make('revolve_env/Locomotion-v1', engine='mujoco', "
            "render_mode='rgb_array')\n"
            "env.reset(seed=0)\n"
            "try:\n    env.render()\nexcept RuntimeError as e:\n    print(e)\n")
    done = _run(["-c", code], _headless(PYOPENGL_PLATFORM="none-here"))
    assert done.returncode == 0, done.stderr
    lines = done.stdout.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("MuJoCo cannot render here (no display")
    assert "apt-get install libegl1" in lines[0]


def test_a_backend_the_user_set_that_does_not_work_is_named(tmp_path: Path) -> None:
    done = _show(tmp_path, _headless(MUJOCO_GL="bogus"))
    assert done.returncode == 2, done.stderr
    assert len(done.stderr.strip().splitlines()) == 1
    assert "MUJOCO_GL=bogus" in done.stderr


def test_the_cli_refuses_before_anything_is_simulated(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    import revolve_env.envs.recording

    def never(*args: object, **kwargs: object) -> None:
        raise AssertionError("simulated although nothing can render")

    monkeypatch.setattr(opengl, "_loads", lambda name: False)
    monkeypatch.setattr(revolve_env.envs.recording, "record_robot", never)
    monkeypatch.setattr(sys, "platform", "linux")
    for name in ("DISPLAY", "WAYLAND_DISPLAY", "MUJOCO_GL"):
        monkeypatch.delenv(name, raising=False)
    assert main(["show", "spider", "--engine", "mujoco", "--out", str(tmp_path / "s.gif")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "MuJoCo cannot render here" in err[0]
    assert "--engine pybullet" in err[0]


@needs_gl
def test_gym_make_renders_mujoco_frames_with_the_grid_and_passes_check_env(
        tmp_path: Path) -> None:
    # check_env also makes the env with render_mode="human": no window here, it says so.
    code = ("import sys, warnings, numpy as np, gymnasium as gym, revolve_env\n"
            "warnings.filterwarnings('ignore', \"render_mode='human' without a window\")\n"
            "from gymnasium.utils.env_checker import check_env\n"
            "from PIL import Image\n"
            "env = gym.make('revolve_env/Locomotion-v1', engine='mujoco', "
            "render_mode='rgb_array')\n"
            "check_env(env.unwrapped)\n"
            "env.reset(seed=0)\n"
            "for _ in range(30):\n    env.step(env.action_space.sample())\n"
            "frame = env.render()\n"
            "Image.fromarray(frame).save(sys.argv[1])\n"
            "import os; print(os.environ['MUJOCO_GL'])\n")
    png = tmp_path / "frame.png"
    done = _run(["-W", "error", "-c", code, str(png)], _headless())
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() in ("egl", "osmesa")  # chosen by the package, nothing set
    frame = _frames(png)[0]
    assert frame.shape == (360, 480, 3)
    assert frame.std() > 10  # not blank
    robot = (frame[..., 2].astype(int) - frame[..., 0] > 60)  # the spider's blue parts
    assert robot.sum() > 200
    assert _grid_rows(frame) > 60  # the grid's edges cross most rows of the floor


@needs_gl
def test_show_renders_mujoco_frames_without_a_display(tmp_path: Path) -> None:
    done = _show(tmp_path, _headless())
    assert done.returncode == 0, done.stderr
    frames = _frames(tmp_path / "s.gif")
    assert len(frames) == 4  # 30 control periods: frames at 8, 16, 24 and the last
    assert _grid_rows(frames[-1]) > 60


@pytest.mark.slow
@needs_gl
def test_show_db_and_watch_of_stored_mujoco_runs_render_without_a_display(
        tmp_path: Path) -> None:
    serial = LocalEvaluator(1)
    for name in ("scenario1", "scenario3"):  # shipped-size robots offline: most have hinges
        config = tiny_run(name, births=8, world={"engine": "mujoco"})
        experiments.run(config if name == "scenario1" else small(config), tmp_path / name,
                        evaluator=serial)
    with Store.open(tmp_path / "scenario1" / DB_NAME) as store:  # a robot that can move
        robot_id = next(r.robot_id for r in store.robots(0) if any(
            n.type == PartType.ACTIVE_HINGE for _, n in from_json(r.genome).walk()))
    env = _headless()
    shown = _run(["-m", "evolution.cli", "show", "--db", str(tmp_path / "scenario1"), "--robot",
                  str(robot_id),
                  "--seconds", "0.5", "--insertion", "0", "--fps", "8", "--out",
                  str(tmp_path / "best.gif")], env)
    assert shown.returncode == 0, shown.stderr
    assert "(the same)" in shown.stdout or "differ" in shown.stdout
    assert _grid_rows(_frames(tmp_path / "best.gif")[-1]) > 60
    watched = _run(["-m", "evolution.cli", "watch", str(tmp_path / "scenario3"), "--seconds",
                    "3", "--fps", "2", "--record", str(tmp_path / "world.gif")], env)
    assert watched.returncode == 0, watched.stderr
    frames = _frames(tmp_path / "world.gif")
    assert len(frames) == 6 and all(f.std() > 10 for f in frames)
