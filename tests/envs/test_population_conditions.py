"""PopulationEnv under evaluation conditions: newborns' heading and jitter, sensor and actuator
noise from a generator of their own, and exact snapshots with the noise on (MuJoCo)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from world_views import hinge_targets

from revolve_env import EvaluationConditions
from revolve_env.body.examples import EXAMPLES
from revolve_env.conditions import DEFAULT_RESET_NOISE_SCALE
from revolve_env.envs.population import ONLINE_CONDITIONS, PopulationEnv

NOISE = EvaluationConditions(heading="random", sensor_noise=0.1, actuator_noise=0.1)


def _env(conditions: EvaluationConditions | None = None, **kw: Any) -> PopulationEnv:
    if conditions is not None:
        kw["conditions"] = conditions
    return PopulationEnv(max_births=12, initial_robots=[], insertion_time=0.1, maturity_age=0.3,
                         fitness_window=0.5, birth_radius=1.0, **kw)


def _play(env: PopulationEnv, seed: int, steps: int = 12) -> list[Any]:
    """Births by the placement rule (brain and agent robots), steps; what every step gave."""
    env.reset(seed=seed)
    born = [env.add_robot(EXAMPLES["spider"]()),
            env.add_robot(EXAMPLES["gecko"](), controlled_by="agent"),
            env.add_robot(EXAMPLES["snake"]())]
    out: list[Any] = [{a: env.agent_info(a)["birth_position"] for a in born},
                      {a: env._roster.member(a, "test").yaw for a in born},
                      {a: env.observe(a) for a in born}]
    for _ in range(steps):
        obs, rewards, *_ = env.step({"robot_1": np.full(6, 0.5, dtype=np.float32)})
        out.append((obs, rewards))
    out.append(env.positions())
    return out


def _equal(a: list[Any], b: list[Any]) -> bool:
    def same(x: Any, y: Any) -> bool:
        if isinstance(x, dict):
            return list(x) == list(y) and all(same(x[k], y[k]) for k in x)
        if isinstance(x, (list, tuple)):
            return len(x) == len(y) and all(same(p, q) for p, q in zip(x, y, strict=True))
        if isinstance(x, np.ndarray):
            return bool(np.array_equal(x, y))
        return bool(x == y)
    return same(a, b)


def test_the_default_is_a_random_heading_without_noise_and_the_hinges_start_noise() -> None:
    env = _env()
    assert EvaluationConditions(heading="random") == ONLINE_CONDITIONS
    shaken = EvaluationConditions(heading="random", reset_noise_scale=DEFAULT_RESET_NOISE_SCALE)
    assert env.conditions == shaken
    assert _equal(_play(env, 3), _play(_env(shaken), 3))
    assert _env(ONLINE_CONDITIONS).conditions is ONLINE_CONDITIONS  # given: kept as it is
    with pytest.raises(TypeError, match="conditions must be an EvaluationConditions"):
        _env({"heading": "random"})  # type: ignore[arg-type]


def test_a_fixed_heading_turns_every_newborn_without_a_yaw() -> None:
    env = _env(EvaluationConditions(heading=1.25))
    env.reset(seed=0)
    a = env.add_robot(EXAMPLES["spider"]())
    b = env.add_robot(EXAMPLES["gecko"](), yaw=0.5)  # an explicit yaw wins
    assert (env._roster.member(a, "test").yaw, env._roster.member(b, "test").yaw) == (1.25, 0.5)
    headings = set(_play(_env(), 0)[1].values())
    assert len(headings) == 3 and all(0 <= h < 2 * math.pi for h in headings)


def test_jitter_moves_births_at_a_given_position_only() -> None:
    jitter = EvaluationConditions(heading="random", position_jitter=0.3)
    env = _env(jitter)
    env.reset(seed=5)
    given = env.add_robot(EXAMPLES["spider"](), (2.0, 1.0))
    x, y = env.agent_info(given)["birth_position"]
    assert 0 < math.hypot(x - 2.0, y - 1.0) <= 0.3
    # Placement-rule births are already random in the birth disc: the same as without jitter.
    plain, jittered = _play(_env(ONLINE_CONDITIONS), 9), _play(_env(jitter), 9)
    assert _equal(plain, jittered)


def test_a_jittered_birth_that_overlaps_is_refused_and_changes_nothing() -> None:
    env = _env(EvaluationConditions(heading="random", position_jitter=0.01))
    env.reset(seed=2)
    env.add_robot(EXAMPLES["spider"](), (0.0, 0.0))
    state = env.np_random.bit_generator.state
    with pytest.raises(ValueError, match="overlaps robot_0"):
        env.add_robot(EXAMPLES["gecko"](), (0.05, 0.0))
    assert env.np_random.bit_generator.state == state and env.robot_ids == [0]


def test_noise_is_reproducible_changes_the_run_and_never_the_births() -> None:
    quiet, noisy, again, other = (_play(_env(ONLINE_CONDITIONS), 4), _play(_env(NOISE), 4),
                                  _play(_env(NOISE), 4), _play(_env(NOISE), 5))
    assert _equal(noisy, again)
    assert not _equal(noisy, other)
    assert _equal(noisy[:2], quiet[:2])  # same birth positions and headings: own generator
    assert not _equal(noisy[2:], quiet[2:])  # noisy observations and gaits


def test_sensor_noise_reaches_what_brains_read_and_agents_observe() -> None:
    env = _env(EvaluationConditions(heading="random", sensor_noise=0.2))
    env.reset(seed=1)
    agent = env.add_robot(EXAMPLES["sensor_crawler"](), (0.0, 0.0), controlled_by="agent")
    m = env._roster.member(agent, "test")
    truth = env.world.read_sensors(m.handle)
    seen = env.observe(agent)
    assert not np.array_equal(seen, truth)
    brain_reads = env._roster.living.obs_of(env._roster.agents.index(agent))
    np.testing.assert_array_equal(seen, brain_reads)  # the brain's inputs: the same noisy values
    # Touch and light values stay in [0, 1]; only the IMU is unbounded.
    low, high = m.sensor_low, m.sensor_high
    assert np.all(seen >= low) and np.all(seen <= high)
    env.step({agent: np.zeros(env.action_space(agent).shape, dtype=np.float32)})
    assert np.all(env.observe(agent) >= low) and np.all(env.observe(agent) <= high)


def test_actuator_noise_reaches_the_targets_of_agents_and_brains() -> None:
    env = _env(EvaluationConditions(heading="random", actuator_noise=0.3))
    env.reset(seed=1)
    driven = env.add_robot(EXAMPLES["spider"](), (0.0, 0.0), controlled_by="agent")
    brain = env.add_robot(EXAMPLES["spider"](), (1.0, 0.0))
    env.step({driven: np.zeros(8, dtype=np.float32)})
    for agent in (driven, brain):
        targets = hinge_targets(env.world, env._roster.member(agent, "test").handle)
        assert np.count_nonzero(targets) == len(targets)
        assert np.all(np.abs(targets) <= 1.0)  # the world clips
    quiet = _env()
    quiet.reset(seed=1)
    q = quiet.add_robot(EXAMPLES["spider"](), (0.0, 0.0), controlled_by="agent")
    quiet.step({q: np.zeros(8, dtype=np.float32)})
    assert not np.any(hinge_targets(quiet.world, quiet._roster.member(q, "test").handle))


def test_snapshots_carry_the_noise_generator_exactly() -> None:
    pytest.importorskip("mujoco", reason="the mujoco package is not installed")
    env = _env(NOISE, engine="mujoco")
    env.reset(seed=7)
    for name in ("spider", "gecko", "snake"):
        env.add_robot(EXAMPLES[name]())
    for _ in range(10):
        env.step({})
    snap = env.snapshot()
    assert snap["noise_rng"] is not None
    twin = _env(NOISE, engine="mujoco")
    twin.restore(snap)
    for _ in range(15):
        a, b = env.step({}), twin.step({})
        assert _equal(list(a), list(b))
    # A snapshot from before the noise generator existed still restores (noise off then).
    del snap["noise_rng"]
    _env(NOISE, engine="mujoco").restore(snap)
    env.close()
    twin.close()
