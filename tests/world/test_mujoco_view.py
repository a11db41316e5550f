"""What MuJoCo's frames and window show (issue 31): a grid on the ground, looks only.

Frames are drawn from a copy of the scene with a checker on the ground and a side light; the
model the physics steps is never touched, so rendering moves no number (checked bit for bit).
MuJoCo's own window (``render_mode="human"``) opens where there is a display and says in one
line why not where there is none.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from world_robots import spider

from revolve_env import example
from revolve_env.world import World, WorldConfig
from revolve_env.world.opengl import render_problem

pytest.importorskip("mujoco", reason="the 'mujoco' package is not installed")

MJ = WorldConfig(engine="mujoco")
needs_gl = pytest.mark.skipif(render_problem() is not None, reason="MuJoCo cannot render here")


def _walk(world: World, steps: int, render: bool) -> list[np.ndarray]:
    world.add_robot(spider())
    poses = []
    for k in range(steps):
        world.set_all_targets(np.full(world.targets.shape, np.sin(0.3 * k)))
        world.step(1)
        if render:
            world.render(64, 48)
        poses.append(world.states.core_pos.copy())
    return poses


@needs_gl
def test_rendering_changes_no_number_and_not_the_compiled_model() -> None:
    with World(MJ) as quiet, World(MJ) as drawn:
        plain = _walk(quiet, 40, render=False)
        shown = _walk(drawn, 40, render=True)
        assert all(np.array_equal(a, b) for a, b in zip(plain, shown, strict=True))
        backend: Any = drawn.backend
        assert backend._model.ntex == 0 and backend._model.nmat == 0  # the looks: frames only
        assert backend._model_digest() == quiet.backend._model_digest()  # type: ignore[attr-defined]


def _grid_rows(frame: np.ndarray) -> int:
    low = frame[frame.shape[0] // 2:].astype(int)
    grey = np.ptp(low, axis=2) < 12
    green = low[..., 1]
    step = np.abs(green[:, 2:] - green[:, :-2]) > 15  # over two pixels: edges are smoothed
    return int(np.sum((step & grey[:, 2:] & grey[:, :-2]).any(axis=1)))


@needs_gl
@pytest.mark.parametrize("terrain", ["flat", "rugged"])
def test_frames_show_a_grid_on_the_ground(terrain: str) -> None:
    with World(MJ.with_terrain(terrain)) as world:
        world.add_robot(example("spider"))
        frame = world.render(240, 180)
    assert frame.shape == (180, 240, 3)
    assert _grid_rows(frame) > 30  # of 90 rows of ground: checker edges across most


def test_mujocos_window_says_in_one_line_why_not_without_a_display(
        monkeypatch: pytest.MonkeyPatch) -> None:
    for name in ("DISPLAY", "WAYLAND_DISPLAY"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    with pytest.raises(RuntimeError, match=r"^cannot open MuJoCo's window: no display"):
        World(MJ, gui=True)


class _FakeHandle:
    """Stands for the window ``mujoco.viewer.launch_passive`` opens (no display here)."""

    def __init__(self, model: Any, data: Any) -> None:
        import mujoco

        self.model, self.data, self.syncs, self.open = model, data, 0, True
        self.cam = mujoco.MjvCamera()
        self.poses: list[np.ndarray] = []

    def is_running(self) -> bool:
        return self.open

    def lock(self) -> Any:
        import contextlib

        return contextlib.nullcontext()

    def sync(self) -> None:
        self.syncs += 1
        self.poses.append(self.data.qpos.copy())  # as drawn

    def close(self) -> None:
        self.open = False


def test_human_mode_draws_every_step_in_mujocos_window(monkeypatch: pytest.MonkeyPatch) -> None:
    import mujoco.viewer

    import revolve_env.envs.locomotion as locomotion

    windows: list[_FakeHandle] = []

    def launch(model: Any, data: Any) -> _FakeHandle:
        windows.append(_FakeHandle(model, data))
        return windows[-1]

    monkeypatch.setattr(mujoco.viewer, "launch_passive", launch)
    monkeypatch.setenv("DISPLAY", ":99")
    env = locomotion.LocomotionEnv("spider", render_mode="human", engine="mujoco",
                                   insertion_time=0.0, evaluation_time=0.2)
    env.reset(seed=0)
    for _ in range(5):
        env.step(env.action_space.sample())
    assert env.render() is None
    assert len(windows) == 1 and windows[0].syncs == 7  # reset, 5 steps, render
    assert windows[0].model.ntex == 1  # the grid's
    world: Any = env._world
    assert np.array_equal(windows[0].poses[-1], world.backend._data.qpos)
    env.reset(seed=1)  # a new scene: a window on it
    assert len(windows) == 2 and not windows[0].open
    windows[1].open = False  # the user closes it: nothing is drawn any more, nothing fails
    env.step(env.action_space.sample())
    assert windows[1].syncs == 1
    env.close()
