"""PopulationEnv snapshots: on MuJoCo, snapshot -> restore in a new env -> step gives exactly what
stepping on gives (observations, rewards, fitness windows, trajectories, births)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from revolve_env.body.examples import EXAMPLES
from revolve_env.envs.population import PopulationEnv
from revolve_env.fitness import SlidingWindowFitness
from revolve_env.status import agent_name
from revolve_env.world.backend import SnapshotMismatchError

pytest.importorskip("mujoco", reason="the mujoco package is not installed")


def _env() -> PopulationEnv:
    return PopulationEnv(max_births=12, initial_robots=[], insertion_time=0.1, maturity_age=0.3,
                         fitness_window=0.5, birth_radius=0.6, engine="mujoco")


def _same(a: Any, b: Any, where: str = "") -> None:
    if isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b), where
        for k in a:
            _same(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, (list, tuple)) and not isinstance(a, str):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _same(x, y, f"{where}[{i}]")
    elif isinstance(a, np.ndarray):
        np.testing.assert_array_equal(a, b, err_msg=where)
    else:
        assert a == b or (a != a and b != b), where  # NaN equals NaN here


def _play(env: PopulationEnv, steps: int, seed: int) -> list[Any]:
    """Steps with actions for the agent-driven robots, a birth and a death along the way."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(steps):
        if k == steps // 3:
            env.add_robot(EXAMPLES["gecko"]())
        if k == steps // 2 and len(env.agents) > 2:
            env.remove_robot(env.agents[1])
        alive = {agent_name(r) for r in env.robot_ids}  # robots removed since the last step
        actions = {a: rng.uniform(-1, 1, env.action_space(a).shape).astype(np.float32)
                   for a in env.agents if a in alive and env.agent_info(a)["controlled_by"] ==
                   "agent"}
        out.append(env.step(actions))
    out.append({a: env.agent_info(a) for a in env.agents})
    out.append(env.np_random.uniform())
    return out


def test_snapshot_restore_step_equals_stepping_on() -> None:
    env = _env()
    env.reset(seed=7)
    for name in ("spider", "snake", "sensor_crawler", "bar_walker"):
        env.add_robot(EXAMPLES[name]())
    env.add_robot(EXAMPLES["spider"](), controlled_by="agent")
    env.action_space("robot_10")  # handed out before its birth: it will be padded
    _play(env, 40, 1)
    env.remove_robot(env.agents[0])  # reported by the next step: part of the snapshot
    snap = env.snapshot()
    twin = _env()
    twin.restore(snap)
    assert twin.agents == env.agents and twin.births == env.births and twin.time == env.time
    _same(_play(twin, 50, 2), _play(env, 50, 2))
    assert twin.observation_space("robot_10") is twin.observation_space("robot_10")
    env.close()
    twin.close()


def test_a_damaged_snapshot_is_refused() -> None:
    env = _env()
    env.reset(seed=1)
    env.add_robot(EXAMPLES["spider"]())
    env.step({})
    snap = env.snapshot()
    del snap["members"][0]["fitness"]
    with pytest.raises(SnapshotMismatchError, match="damaged"):
        _env().restore(snap)
    env.close()


def test_a_fitness_window_goes_on_exactly_after_a_snapshot() -> None:
    rng = np.random.default_rng(0)
    a = SlidingWindowFitness(0.5, capacity=4)
    for k in range(200):
        a.add(k / 60, rng.uniform(-1, 1, 2) * 600)  # a long path: the running sum is rebased
    b = SlidingWindowFitness.from_snapshot(a.snapshot())
    for k in range(200, 300):
        p = rng.uniform(-1, 1, 2)
        a.add(k / 60, p)
        b.add(k / 60, p)
        assert a.terms() == b.terms()
