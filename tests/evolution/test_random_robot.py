"""Random robots: always valid within the limits, reproducible, serialisable, buildable."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evolution.config import EvolutionConfig
from evolution.random_robot import (
    RandomRobotError,
    random_robot,
    random_robot_with_report,
    robot_counts,
)
from revolve_env.body.robot import Layer
from revolve_env.body.serialize import from_json, to_json
from revolve_env.body.validate import validate

CONFIG = EvolutionConfig()
SEEDS = st.integers(0, 2**32 - 1)


@settings(max_examples=40, deadline=None)
@given(SEEDS)
def test_every_random_robot_is_valid_within_limits_and_survives_json(seed: int) -> None:
    result = random_robot_with_report(np.random.default_rng(seed), CONFIG)
    robot = result.robot
    validate(robot, CONFIG.limits)  # limits and physical constructibility
    c = robot_counts(robot)
    assert c.parts == result.target_parts
    assert CONFIG.min_parts <= c.parts <= CONFIG.max_parts
    assert c.inputs <= CONFIG.max_inputs and c.outputs <= CONFIG.max_outputs
    assert c.hidden <= CONFIG.max_hidden
    assert 0 <= result.retries < CONFIG.max_random_robot_retries
    assert from_json(to_json(robot), CONFIG.limits) == robot
    # One lineage colour per random robot.
    assert len({n.color for _, n in robot.walk()}) == 1


@settings(max_examples=10, deadline=None)
@given(SEEDS)
def test_same_seed_same_robot(seed: int) -> None:
    a = random_robot(np.random.default_rng(seed), CONFIG)
    b = random_robot(np.random.default_rng(seed), CONFIG)
    assert a == b


def test_sizes_follow_the_configured_normal() -> None:
    rng = np.random.default_rng(0)
    sizes = np.array([random_robot(rng, CONFIG).num_parts() for _ in range(60)])
    # N(12, 5) clipped to [3, 30]: the mean stays close to 12.
    assert 10.0 < sizes.mean() < 14.0  # about 3 standard errors
    assert sizes.min() >= 3 and sizes.max() <= 30


def test_fixed_size_and_tight_io_limits_are_respected() -> None:
    config = EvolutionConfig(initial_parts_mean=8, initial_parts_sd=0, max_inputs=7,
                             max_outputs=1, max_hidden=0)
    for seed in range(10):
        robot = random_robot(np.random.default_rng(seed), config)
        c = robot_counts(robot)
        assert c.parts == 8 and c.inputs <= 7 and c.outputs <= 1 and c.hidden == 0
        assert not robot.neurons_of(Layer.HIDDEN)


def test_impossible_request_raises_a_clear_error() -> None:
    # 30 parts, and an attempt ends at its first discarded (overlapping) placement: with this
    # seed all 10 attempts (the fewest a config allows) hit an overlap before reaching 30 parts.
    config = EvolutionConfig(min_parts=30, initial_parts_mean=30, initial_parts_sd=0,
                             max_placement_attempts=1, max_random_robot_retries=10)
    with pytest.raises(RandomRobotError, match="10 attempts"):
        random_robot(np.random.default_rng(1137), config)
