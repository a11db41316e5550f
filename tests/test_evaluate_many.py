"""evaluate_many: robots side by side, each outcome bit for bit the one evaluate gives it alone."""

from __future__ import annotations

import numpy as np
import pytest

from evolution.config import EvolutionConfig
from evolution.random_robot import random_robot
from revolve_env.body.examples import example
from revolve_env.body.robot import Robot
from revolve_env.conditions import EvaluationConditions
from revolve_env.evaluation import EvaluationResult, evaluate, evaluate_many
from revolve_env.world import WorldConfig, build_model

ENGINES = ["mujoco", "pybullet"]
NOISY = EvaluationConditions(heading="random", position_jitter=0.1, sensor_noise=0.05,
                             actuator_noise=0.05)


def _robots(n: int, seed: int) -> list[Robot]:
    rng = np.random.default_rng(seed)
    return [random_robot(rng, EvolutionConfig()) for _ in range(n)]


def _same(a: EvaluationResult, b: EvaluationResult) -> bool:
    return (a.fitness.hex(), a.v.hex(), a.s.hex(), a.blow_up) == \
        (b.fitness.hex(), b.v.hex(), b.s.hex(), b.blow_up) and \
        np.array_equal(a.trajectory, b.trajectory)


@pytest.fixture(params=ENGINES)
def engine(request: pytest.FixtureRequest) -> str:
    if request.param == "mujoco":
        pytest.importorskip("mujoco", reason="the mujoco package is not installed")
    return str(request.param)


def test_side_by_side_is_alone_bit_for_bit_with_sensors_noise_and_blow_ups(engine: str) -> None:
    """Random robots (touch and light sensors on any part) and two examples under noise and a
    random start; a low speed limit blows some up at different times (they leave the batch
    while the others go on)."""
    robots = _robots(8, seed=11) + [example("spider"), example("sensor_crawler")]
    assert any(kind == "light" and s.link > 0 for r in robots
               for kind, s in build_model(r).sensors)  # a light sensor on a moving link
    assert any(kind == "touch" for r in robots for kind, _ in build_model(r).sensors)
    config = WorldConfig(max_linear_speed=0.5)
    seeds = list(range(100, 100 + len(robots)))
    timing = dict(seconds=1.0, insertion=0.5, engine=engine, conditions=NOISY, config=config)
    together = evaluate_many(robots, seeds=seeds, **timing)  # type: ignore[arg-type]
    alone = [evaluate(r, seed=s, **timing)  # type: ignore[arg-type]
             for r, s in zip(robots, seeds, strict=True)]
    assert all(_same(a, b) for a, b in zip(together, alone, strict=True))
    blown = [r.blow_up is not None for r in alone]
    assert any(blown) and not all(blown)


def test_a_robots_outcome_does_not_depend_on_its_batch(engine: str) -> None:
    robots = _robots(6, seed=12)
    timing = dict(seconds=0.5, insertion=0.25, engine=engine,
                  conditions=EvaluationConditions(heading="random"))
    full = evaluate_many(robots, seeds=range(6), **timing)  # type: ignore[arg-type]
    pair = evaluate_many([robots[4], robots[1]], seeds=[4, 1], **timing)  # type: ignore[arg-type]
    one = evaluate_many([robots[1]], seeds=[1], **timing)  # type: ignore[arg-type]
    assert _same(full[4], pair[0]) and _same(full[1], pair[1]) and _same(full[1], one[0])


def test_bad_batches_are_refused_before_any_physics() -> None:
    assert evaluate_many([]) == []
    with pytest.raises(ValueError, match="2 seeds for 1 robots"):
        evaluate_many([example("spider")], seeds=[1, 2])
    with pytest.raises(ValueError, match="seconds"):
        evaluate_many([example("spider")], seconds=0.0)
