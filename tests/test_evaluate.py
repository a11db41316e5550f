"""revolve_env.evaluate: brain-driven, deterministic, same physics and fitness as the env."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from revolve_env.body.examples import example, gecko, spider
from revolve_env.body.robot import Node, PartType, Robot
from revolve_env.body.validate import RobotError
from revolve_env.envs import LocomotionEnv
from revolve_env.envs.episode import run_episode
from revolve_env.evaluation import EvaluationResult, evaluate
from revolve_env.fitness import fitness_terms
from revolve_env.world import WorldConfig


def test_result_holds_fitness_terms_and_trajectory() -> None:
    r = evaluate(gecko(), seconds=1.0, insertion=0.5)
    assert isinstance(r, EvaluationResult)
    assert r.blow_up is None
    assert r.trajectory.shape == (61, 3)  # one row per control period, both ends included
    assert not r.trajectory.flags.writeable
    terms = fitness_terms(r.trajectory[::12])  # poses at 5 Hz, the default: every 12th row
    assert (r.fitness, r.v, r.s) == pytest.approx((terms.fitness, terms.v, terms.s))
    assert r.fitness == pytest.approx(r.v + 5 * r.s)
    assert r.v > 0.01  # the oscillators move it


def test_evaluation_is_deterministic_and_noise_follows_the_seed() -> None:
    a = evaluate(spider(), seconds=0.5, insertion=0.25)
    b = evaluate(spider(), seconds=0.5, insertion=0.25)
    np.testing.assert_array_equal(a.trajectory, b.trajectory)
    noisy = dict(seconds=0.5, insertion=0.25, sensor_noise=0.1, actuator_noise=0.2)
    c = evaluate(spider(), seed=1, **noisy)  # type: ignore[arg-type]
    d = evaluate(spider(), seed=1, **noisy)  # type: ignore[arg-type]
    e = evaluate(spider(), seed=2, **noisy)  # type: ignore[arg-type]
    np.testing.assert_array_equal(c.trajectory, d.trajectory)
    assert not np.array_equal(c.trajectory, e.trajectory)


def test_same_run_as_the_env_driven_by_the_brain() -> None:
    r = evaluate(spider(), seconds=0.5, insertion=0.25)
    env = LocomotionEnv(spider(), insertion_time=0.25, evaluation_time=0.5, controller="brain",
                        reset_noise_scale=0.0)  # evaluate's start: hinges at rest
    xy: list[tuple[float, float]] = []

    def record(step: int, info: dict[str, Any]) -> None:
        if info["evaluating"]:
            xy.append((info["x_position"], info["y_position"]))

    info = run_episode(env, 0, on_step=record)
    env.close()
    np.testing.assert_array_equal(np.array(xy), r.trajectory[:, :2])
    assert info["fitness"] == pytest.approx(r.fitness)


def test_blow_up_gives_zero_fitness_and_a_reason() -> None:
    r = evaluate(spider(), seconds=1.0, insertion=0.0, config=WorldConfig(max_linear_speed=0.05))
    assert r.blow_up is not None and "speed" in r.blow_up
    assert (r.fitness, r.v, r.s) == (0.0, 0.0, 0.0)
    assert len(r.trajectory) < 61


def test_bad_input_raises_before_physics() -> None:
    with pytest.raises(RobotError):
        evaluate(Robot(Node(PartType.CORE, children=((9, Node(PartType.BRICK)),))))
    with pytest.raises(ValueError, match="seconds"):
        evaluate(spider(), seconds=0.0)
    with pytest.raises(ValueError, match="sensor_noise"):
        evaluate(spider(), sensor_noise=-1.0)


@pytest.mark.parametrize("name", ["spider", "gecko", "snake"])
def test_walking_examples_cover_real_distance_on_their_own_controllers(name: str) -> None:
    """Issue 3: the examples run on their own brains; the walkers get somewhere in 12 s."""
    result = evaluate(example(name), seconds=12.0, seed=0)
    assert result.blow_up is None
    assert result.s > 0.5  # metres of straight displacement (measured: 1.4 to 1.6 m)
    assert result.fitness == pytest.approx(result.v + 5.0 * result.s)


@pytest.mark.parametrize("name", ["sensor_crawler", "bar_walker"])
def test_other_examples_move_on_their_own_controllers(name: str) -> None:
    result = evaluate(example(name), seconds=12.0, seed=0)
    assert result.blow_up is None
    assert result.v > 0.1  # the core travels (metres of path)
