"""Evaluation conditions: the object, its draws, and evaluate() / the single-robot env under it."""

from __future__ import annotations

import hashlib
import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from revolve_env import IDEAL, EvaluationConditions, evaluate
from revolve_env.body.examples import example, gecko, spider
from revolve_env.body.robot import PartType
from revolve_env.conditions import RANDOM_HEADING, add_sensor_noise
from revolve_env.envs import LocomotionEnv
from revolve_env.envs.episode import run_episode
from revolve_env.evaluation import start_generator

SHORT: dict[str, Any] = {"seconds": 0.5, "insertion": 0.25}

headings = st.one_of(st.just(RANDOM_HEADING),
                     st.floats(-10.0, 10.0, allow_nan=False, allow_infinity=False))
amounts = st.floats(0.0, 5.0, allow_nan=False, allow_infinity=False)
conditions = st.builds(EvaluationConditions, headings, amounts, amounts, amounts)


# -- the object --------------------------------------------------------------------------------

@pytest.mark.parametrize("field", ["position_jitter", "sensor_noise", "actuator_noise",
                                   "reset_noise_scale"])
@pytest.mark.parametrize("value", [-0.1, math.nan, math.inf, True, "0.1", None])
def test_a_bad_amount_is_refused_naming_the_field(field: str, value: object) -> None:
    with pytest.raises(ValueError, match=f"^{field} must be a finite number >= 0"):
        EvaluationConditions(**{field: value})  # type: ignore[arg-type]


@pytest.mark.parametrize("value", ["north", "Random", math.nan, -math.inf, False, None, [0.0]])
def test_a_bad_heading_is_refused_naming_the_field(value: object) -> None:
    with pytest.raises(ValueError, match="^heading must be a number of radians or 'random'"):
        EvaluationConditions(heading=value)  # type: ignore[arg-type]


def test_unknown_keys_are_refused_and_listed() -> None:
    with pytest.raises(ValueError, match="unknown evaluation condition\\(s\\): yaw; known: "):
        EvaluationConditions.from_dict({"yaw": 1.0})


@given(conditions)
def test_plain_data_round_trip(c: EvaluationConditions) -> None:
    data = c.to_dict()
    assert set(data) == {"heading", "position_jitter", "sensor_noise", "actuator_noise"}
    assert EvaluationConditions.from_dict(data) == c
    assert EvaluationConditions.from_dict({}) == IDEAL
    assert c.random_heading == (c.heading == RANDOM_HEADING)
    assert c.noisy == (c.sensor_noise > 0 or c.actuator_noise > 0)


def test_integers_become_floats_and_ideal_is_the_default() -> None:
    c = EvaluationConditions(heading=1, position_jitter=0, sensor_noise=2, actuator_noise=0)
    assert c.to_dict() == {"heading": 1.0, "position_jitter": 0.0, "sensor_noise": 2.0,
                           "actuator_noise": 0.0}
    assert all(type(v) is float for v in c.to_dict().values())
    assert EvaluationConditions(0.0, 0.0, 0.0, 0.0) == IDEAL
    assert not IDEAL.random_heading and not IDEAL.noisy


# -- the start ---------------------------------------------------------------------------------

@given(st.floats(-10.0, 10.0, allow_nan=False), st.floats(-5.0, 5.0), st.floats(-5.0, 5.0),
       st.integers(0, 2**32))
def test_a_fixed_start_draws_nothing(heading: float, x: float, y: float, seed: int) -> None:
    rng = np.random.default_rng(seed)
    state = rng.bit_generator.state
    start = EvaluationConditions(heading=heading).start(rng, (x, y))
    assert start.position == (x, y) and start.yaw == heading
    assert rng.bit_generator.state == state


@settings(max_examples=200)
@given(st.floats(1e-3, 3.0), st.floats(-5.0, 5.0), st.floats(-5.0, 5.0), st.integers(0, 2**32),
       headings)
def test_the_jitter_stays_within_its_disc(jitter: float, x: float, y: float, seed: int,
                                          heading: float | str) -> None:
    c = EvaluationConditions(heading=heading, position_jitter=jitter)  # type: ignore[arg-type]
    start = c.start(np.random.default_rng(seed), (x, y))
    assert math.hypot(start.position[0] - x, start.position[1] - y) <= jitter * (1 + 1e-12)
    if c.random_heading:
        assert 0.0 <= start.yaw < 2 * math.pi
    else:
        assert start.yaw == heading


def test_the_start_follows_the_generator() -> None:
    c = EvaluationConditions(heading="random", position_jitter=0.5)
    a = c.start(np.random.default_rng(1))
    assert a == c.start(np.random.default_rng(1))
    assert a != c.start(np.random.default_rng(2))
    # Uniform over the disc: half of the draws within radius jitter / sqrt(2).
    rng = np.random.default_rng(0)
    r = [math.hypot(*c.start(rng).position) for _ in range(4000)]
    assert np.mean(np.array(r) < 0.5 / math.sqrt(2)) == pytest.approx(0.5, abs=0.03)


def test_the_hinges_start_noise_is_uniform_within_its_scale_and_draws_nothing_when_off() -> None:
    rng = np.random.default_rng(0)
    before = rng.bit_generator.state
    assert IDEAL.start_joints(rng, 8) is None and rng.bit_generator.state == before
    drawn = EvaluationConditions(reset_noise_scale=0.2).start_joints(rng, 4000)
    assert drawn is not None
    for values in drawn:  # angles (rad), then speeds (rad/s)
        assert values.shape == (4000,) and np.abs(values).max() <= 0.2
        assert np.mean(np.abs(values) < 0.1) == pytest.approx(0.5, abs=0.03)
    with pytest.raises(ValueError, match="^reset_noise_scale must be <= pi/4"):
        EvaluationConditions(reset_noise_scale=1.0)


def test_conditions_without_start_noise_are_written_as_before_it_existed() -> None:
    assert IDEAL.to_dict() == {"heading": 0.0, "position_jitter": 0.0, "sensor_noise": 0.0,
                               "actuator_noise": 0.0}
    shaken = EvaluationConditions(reset_noise_scale=0.1)
    assert shaken.to_dict()["reset_noise_scale"] == 0.1
    assert EvaluationConditions.from_dict(shaken.to_dict()) == shaken


# -- evaluate() under conditions ---------------------------------------------------------------

def test_start_noise_on_the_hinges_changes_evaluate_per_seed_and_the_seed_reproduces_it() -> None:
    shaken = EvaluationConditions(reset_noise_scale=0.1)
    a, b = (evaluate(spider(), seed=s, conditions=shaken, **SHORT) for s in (0, 1))
    again = evaluate(spider(), seed=0, conditions=shaken, **SHORT)
    plain = evaluate(spider(), seed=0, **SHORT)
    assert a.fitness != b.fitness and a.fitness != plain.fitness
    np.testing.assert_array_equal(a.trajectory, again.trajectory)


def test_ideal_conditions_are_bit_identical_to_none() -> None:
    plain = evaluate(spider(), seed=4, **SHORT)
    ideal = evaluate(spider(), seed=4, conditions=IDEAL, **SHORT)
    np.testing.assert_array_equal(plain.trajectory, ideal.trajectory)
    assert (plain.fitness, plain.v, plain.s) == (ideal.fitness, ideal.v, ideal.s)
    # The noise shortcuts are the same conditions too.
    a = evaluate(spider(), seed=4, sensor_noise=0.1, actuator_noise=0.05, **SHORT)
    b = evaluate(spider(), seed=4, **SHORT,
                 conditions=EvaluationConditions(sensor_noise=0.1, actuator_noise=0.05))
    np.testing.assert_array_equal(a.trajectory, b.trajectory)


def test_ideal_conditions_give_the_numbers_recorded_before_conditions_existed() -> None:
    """Recorded with the code of commit e46ad0e (no conditions at all), pybullet: the spider's
    fitness and path over 1 s + 2 s. A change in how IDEAL starts a robot breaks this."""
    # The fitness then sampled the core every control period (the default pose rate is 5 Hz now).
    result = evaluate(spider(), seconds=2.0, insertion=1.0, conditions=IDEAL, engine="pybullet",
                      task={"name": "locomotion", "pose_rate": "every-period"})
    # Recorded on another machine: equal as floating point allows there (a change in how a
    # robot starts moves it by far more); bit for bit, path included, where it rounds the same.
    assert result.fitness == pytest.approx(1.6739806559993258, rel=1e-9)
    if result.fitness == 1.6739806559993258:
        digest = hashlib.sha256(result.trajectory.tobytes()).hexdigest()
        assert digest.startswith("5b12f4e2277c700d")


def test_a_start_heading_turns_the_robot_and_the_seed_reproduces_it() -> None:
    random = EvaluationConditions(heading="random", position_jitter=0.2, sensor_noise=0.05,
                                  actuator_noise=0.05)
    a = evaluate(gecko(), seed=7, conditions=random, **SHORT)
    b = evaluate(gecko(), seed=7, conditions=random, **SHORT)
    c = evaluate(gecko(), seed=8, conditions=random, **SHORT)
    np.testing.assert_array_equal(a.trajectory, b.trajectory)
    assert not np.array_equal(a.trajectory, c.trajectory)
    start = random.start(start_generator(7))
    assert math.hypot(*start.position) <= 0.2
    # The core starts near the drawn position (it settles a little during the insertion).
    assert math.hypot(a.trajectory[0, 0] - start.position[0],
                      a.trajectory[0, 1] - start.position[1]) < 0.1
    turned = evaluate(gecko(), seed=7, conditions=EvaluationConditions(heading=math.pi / 2),
                      **SHORT)
    straight = evaluate(gecko(), seed=7, **SHORT)
    assert not np.array_equal(turned.trajectory, straight.trajectory)


def test_noise_given_both_ways_is_refused() -> None:
    with pytest.raises(ValueError, match="either in conditions or as sensor_noise"):
        evaluate(spider(), conditions=IDEAL, sensor_noise=0.1, **SHORT)
    with pytest.raises(ValueError, match="either in conditions or as sensor_noise"):
        LocomotionEnv(spider(), conditions=IDEAL, actuator_noise=0.1)
    with pytest.raises(TypeError, match="conditions must be an EvaluationConditions"):
        LocomotionEnv(spider(), conditions={"heading": 0.0})  # type: ignore[arg-type]


# -- the single-robot env under conditions ------------------------------------------------------

def _env_path(conditions: EvaluationConditions, seed: int | None,
              env: LocomotionEnv | None = None) -> tuple[np.ndarray, float]:
    env = env or LocomotionEnv(spider(), insertion_time=0.25, evaluation_time=0.5,
                               controller="brain", conditions=conditions)
    xy: list[tuple[float, float]] = []

    def record(step: int, info: dict[str, Any]) -> None:
        if info["evaluating"]:
            xy.append((info["x_position"], info["y_position"]))

    info = run_episode(env, seed, on_step=record)
    return np.array(xy), float(info["fitness"])


@pytest.mark.parametrize("conditions", [
    EvaluationConditions(heading="random", position_jitter=0.3),
    EvaluationConditions(heading=1.0, sensor_noise=0.1, actuator_noise=0.1),
    EvaluationConditions(heading="random", position_jitter=0.1, sensor_noise=0.05,
                         actuator_noise=0.02),
], ids=["start", "noise", "both"])
def test_the_env_and_evaluate_agree_for_the_same_seed(conditions: EvaluationConditions) -> None:
    r = evaluate(spider(), seed=3, conditions=conditions, **SHORT)
    xy, fitness = _env_path(conditions, 3)
    np.testing.assert_array_equal(xy, r.trajectory[:, :2])
    assert fitness == pytest.approx(r.fitness, rel=1e-12)


def test_touch_sensors_stay_in_range_under_noise_offline_as_in_the_envs() -> None:
    """A touch sensor reads 0 off the ground; noise must not push it below 0 in ``evaluate``
    (offline) when the envs (online) clip it: the same robot, seed and noise give the same path
    in ``evaluate`` and in the single-robot env."""
    crawler = example("sensor_crawler")
    assert any(node.type == PartType.TOUCH_SENSOR for _, node in crawler.walk())
    noisy = EvaluationConditions(sensor_noise=0.3)
    r = evaluate(crawler, seed=2, conditions=noisy, **SHORT)
    env = LocomotionEnv(crawler, insertion_time=0.25, evaluation_time=0.5, controller="brain",
                        conditions=noisy)
    xy, fitness = _env_path(noisy, 2, env)
    env.close()
    np.testing.assert_array_equal(xy, r.trajectory[:, :2])
    assert fitness == pytest.approx(r.fitness, rel=1e-12)


def test_add_sensor_noise_clips_and_draws_nothing_when_off() -> None:
    rng = np.random.default_rng(0)
    values = np.array([0.0, 1.0, 5.0])
    low, high = np.array([0.0, 0.0, -np.inf]), np.array([1.0, 1.0, np.inf])
    assert add_sensor_noise(values, 0.0, rng, low, high) is values
    assert rng.bit_generator.state == np.random.default_rng(0).bit_generator.state
    noisy = add_sensor_noise(values, 10.0, rng, low, high)
    assert np.all(noisy[:2] >= 0.0) and np.all(noisy[:2] <= 1.0) and noisy[2] != 5.0


def test_the_env_draws_a_new_start_at_every_unseeded_reset() -> None:
    random = EvaluationConditions(heading="random")
    env = LocomotionEnv(spider(), insertion_time=0.25, evaluation_time=0.5,
                        controller="brain", conditions=random)
    first, _ = _env_path(random, 5, env)
    second, _ = _env_path(random, None, env)  # drawn from np_random: another heading
    again, _ = _env_path(random, 5, env)
    env.close()
    np.testing.assert_array_equal(first, again)
    assert not np.array_equal(first, second)
    assert env.sensor_noise == 0.0 and env.conditions is random
