"""The compiled world step (revolve_env.world.compiled.WorldStep) gives the NumPy path's numbers.

Every control period of a MuJoCo World steps in C++ when the extension is usable; these tests run
the envs twice, once so and once on the NumPy path (``compiled.world_step`` declining), and ask
for the same observations, rewards, terminations and infos to the bit: births and deaths,
touch and light sensors, blow-ups judged by the screen and a physics that turns NaN.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from random_robots import has_sensors, random_robots

from revolve_env import LOCOMOTION_V1_ID
from revolve_env.body.examples import example
from revolve_env.body.robot import Robot
from revolve_env.envs.population import population_env
from revolve_env.world import World, WorldConfig, compiled

pytest.importorskip("mujoco", reason="the mujoco package is not installed")
pytestmark = pytest.mark.skipif(not compiled.available(),
                                reason="the compiled rollout is not built or not exact here")


def _bits(x: Any) -> Any:
    """``x`` with every float and array as its exact bits (for == across runs)."""
    if isinstance(x, dict):
        return {k: _bits(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_bits(v) for v in x]
    if isinstance(x, np.ndarray):
        return (x.dtype.str, x.shape, x.tobytes())
    if isinstance(x, (float, np.floating)):
        return float(x).hex()
    return x


def _both(monkeypatch: pytest.MonkeyPatch, run: Callable[[], list[Any]]) -> tuple[Any, Any]:
    """``run()`` with the compiled step (asserting that it stepped), then on the NumPy path."""
    made: list[bool] = []
    real = compiled.world_step

    def spy(*a: Any, **k: Any) -> Any:
        out = real(*a, **k)
        made.append(out is not None)
        return out

    with monkeypatch.context() as m:
        m.setattr(compiled, "world_step", spy)
        fast = run()
    assert made and all(made)
    with monkeypatch.context() as m:
        m.setattr(compiled, "world_step", lambda *a, **k: None)
        slow = run()
    return fast, slow


def _episodes(robot: Robot, steps: int, **kwargs: Any) -> Iterator[Any]:
    env = gym.make(LOCOMOTION_V1_ID, robot=robot, engine="mujoco", **kwargs)
    rng = np.random.default_rng(1)
    try:
        obs, info = env.reset(seed=4)
        yield obs, info
        for _ in range(steps):
            out = env.step(rng.uniform(-1, 1, env.action_space.shape).astype(np.float32))
            yield out
            if out[2] or out[3]:
                yield env.reset(seed=5)
    finally:
        env.close()


@pytest.mark.parametrize("kwargs", [
    {"controller": "agent"},
    {"controller": "brain", "action": "modulate", "task": "light-following"},
    {"controller": "brain", "world_config": WorldConfig(max_linear_speed=0.4)},
], ids=["agent", "modulate-light", "brain-blow-ups"])
def test_the_locomotion_env_is_the_numpy_path_bit_for_bit(
        monkeypatch: pytest.MonkeyPatch, kwargs: dict[str, Any]) -> None:
    """Locomotion-v1 over 300 steps of short episodes (resets on the way) of a robot with a
    touch sensor and light sensors on its core and on a moving link."""
    robot = random_robots(6, 7)[4]
    has_sensors([robot])
    fast, slow = _both(monkeypatch, lambda: [_bits(o) for o in _episodes(
        robot, 300, insertion_time=0.5, evaluation_time=1.5, **kwargs)])
    assert fast == slow
    if "world_config" in kwargs:  # some episodes blew up, some did not
        ends = [o[2] for o in fast if len(o) == 5]
        assert any(ends) and not all(ends)


def _crowd(steps: int, config: WorldConfig) -> list[Any]:
    """A population env with births and deaths, brains and an agent, sensors of every kind."""
    robots = random_robots(6, 7) + [example("sensor_crawler"), example("spider")]
    env = population_env(initial_robots=[{"robot": r} for r in robots[:4]], max_births=20,
                         world_config=config, insertion_time=0.2)
    rng = np.random.default_rng(2)
    out: list[Any] = [_bits(env.reset(seed=3))]
    born = iter(robots[4:])
    try:
        for t in range(steps):
            if t in (20, 90, 150):
                env.add_robot(next(born), controlled_by="agent" if t == 90 else "brain")
            if t in (60, 170) and env.agents:
                env.remove_robot(env.agents[0])
            actions = {a: rng.uniform(-1, 1, env.action_space(a).shape).astype(np.float32)
                       for a in env.agents}
            out.append(_bits(env.step(actions)))
    finally:
        env.close()
    return out


def test_the_population_env_is_the_numpy_path_bit_for_bit(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """300 steps of a crowd: births, removals, an agent among brains, touch and light."""
    has_sensors(random_robots(6, 7) + [example("sensor_crawler"), example("spider")])
    fast, slow = _both(monkeypatch, lambda: _crowd(300, WorldConfig()))
    assert fast == slow


def test_blow_ups_in_a_crowd_are_the_numpy_path_bit_for_bit(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A low speed limit: the screen fails, some robots die of it, the others go on exactly;
    no period is replayed (a failed screen is no reason to: the state is finite)."""
    from revolve_env.world.mujoco_backend import MujocoBackend

    replays: list[int] = []
    replay = MujocoBackend._replay

    def counted(self: MujocoBackend, *args: Any) -> None:
        replays.append(1)
        replay(self, *args)

    monkeypatch.setattr(MujocoBackend, "_replay", counted)
    fast, slow = _both(monkeypatch, lambda: _crowd(200, WorldConfig(max_linear_speed=0.5)))
    assert fast == slow
    assert not replays
    deaths = [info.get("death") for _, _, _, _, infos in fast[1:] for info in infos.values()]
    assert any(d is not None and d != "removed" for d in deaths)


def test_a_world_whose_physics_turns_nan_is_replayed_as_on_the_numpy_path(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A NaN force on a robot: the backend replays the period and puts what diverged at rest;
    every later period (the screen fails for a diverged robot) is the NumPy path's too."""
    monkeypatch.chdir(tmp_path)  # MuJoCo logs its NaN warning to ./MUJOCO_LOG.TXT

    def run() -> list[Any]:
        with World(WorldConfig()) as world:
            handles = [world.add_robot(r, (1.0 * i, 0.0))
                       for i, r in enumerate([example("gecko"), example("spider")])]
            rng = np.random.default_rng(0)
            out = []
            for t in range(120):
                if t == 30:  # a force that makes the spider's dynamics NaN
                    world.backend._data.xfrc_applied[-1, 0] = np.nan  # type: ignore[attr-defined]
                if t == 31:
                    world.backend._data.xfrc_applied[-1, 0] = 0.0  # type: ignore[attr-defined]
                world.set_all_targets(rng.uniform(-1.0, 1.0, size=world.targets.shape))
                world.step()
                s = world.states
                out.append(_bits([s.core_pos, s.core_rot, s.core_vel, s.core_angvel, s.joint_pos,
                                  s.joint_vel, s.diverged, world.sensor_values(),
                                  [world.blow_up(h) for h in handles]]))
            return out

    fast, slow = _both(monkeypatch, run)
    assert fast == slow
    assert any("non-finite" in (why or "") for why in fast[-1][-1])
    assert any(now[6][2] != b"\x00" * len(now[6][2]) for now in fast)  # put at rest: diverged
