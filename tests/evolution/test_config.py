"""EvolutionConfig: the issue's defaults and clear errors for bad values."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from evolution.config import MIN_RANDOM_ROBOT_RETRIES, EvolutionConfig
from evolution.random_robot import RandomRobotError, random_robot
from revolve_env.body.validate import Limits


def test_defaults_are_the_papers_table_1() -> None:
    c = EvolutionConfig()
    assert ((c.max_parts, c.min_parts, c.max_inputs, c.max_outputs, c.max_hidden)
            == (30, 3, 10, 10, 10))
    assert (c.initial_parts_mean, c.initial_parts_sd) == (12.0, 5.0)
    assert (c.p_remove_subtree, c.p_duplicate_subtree, c.p_swap_subtree) == (0.05, 0.1, 0.05)
    assert (c.p_remove_hidden_neuron, c.p_remove_connection) == (0.05, 0.05)
    assert c.limits == Limits(max_parts=30, max_inputs=10, max_outputs=10, max_hidden=10)


def test_is_frozen() -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        EvolutionConfig().max_parts = 5  # type: ignore[misc]


@pytest.mark.parametrize("field", [
    "p_remove_subtree", "p_duplicate_subtree", "p_swap_subtree", "p_remove_hidden_neuron",
    "p_remove_connection", "initial_connection_density",
])
@pytest.mark.parametrize("value", [-0.01, 1.01, float("nan")])
def test_bad_probabilities_name_the_field(field: str, value: float) -> None:
    kwargs: dict[str, Any] = {field: value}
    with pytest.raises(ValueError, match=field):
        EvolutionConfig(**kwargs)


@pytest.mark.parametrize("kwargs, field", [
    ({"min_parts": 10, "max_parts": 5}, "min_parts"),
    ({"max_parts": 0}, "max_parts"),
    ({"max_hidden": -1}, "max_hidden"),
    ({"max_inputs": 5}, "max_inputs"),
    ({"initial_parts_sd": -1.0}, "initial_parts_sd"),
    ({"mutation_sigma": -0.1}, "mutation_sigma"),
    ({"mutation_sigma": 1.5}, "mutation_sigma"),
    ({"max_parts": 3.0}, "max_parts"),
    ({"operator_attempts": 0}, "operator_attempts"),
    ({"balance_by_removal": "yes"}, "balance_by_removal"),
])
def test_bad_values_raise_at_construction(kwargs: dict[str, Any], field: str) -> None:
    with pytest.raises(ValueError, match=field):
        EvolutionConfig(**kwargs)


# --- values that cannot run (issue 13, item 3) ---------------------------------------------------
_NUMERIC_FIELDS = [f.name for f in dataclasses.fields(EvolutionConfig)
                   if f.name != "balance_by_removal"]


@pytest.mark.parametrize("field", _NUMERIC_FIELDS)
@pytest.mark.parametrize("value", [True, False])
def test_booleans_are_refused_where_numbers_are_expected(field: str, value: bool) -> None:
    kwargs: dict[str, Any] = {field: value}
    with pytest.raises(ValueError, match=rf"EvolutionConfig\.{field} .*the boolean {value}"):
        EvolutionConfig(**kwargs)


@pytest.mark.parametrize("kwargs, field", [
    ({"initial_parts_sd": 1e308}, "initial_parts_sd"),  # OverflowError in random_robot before
    ({"initial_parts_sd": 1e15}, "initial_parts_sd"),
    ({"initial_parts_mean": 1e300}, "initial_parts_mean"),
    ({"initial_parts_mean": 2.0**53}, "initial_parts_mean"),
    ({"initial_hidden_mean": 1e300}, "initial_hidden_mean"),  # NumPy: "lam value too large"
    ({"max_parts": 2**31}, "max_parts"),
    ({"max_hidden": 10**30}, "max_hidden"),
    ({"operator_attempts": 2**63}, "operator_attempts"),
])
def test_overflowing_values_are_refused(kwargs: dict[str, Any], field: str) -> None:
    with pytest.raises(ValueError, match=rf"EvolutionConfig\.{field}\b"):
        EvolutionConfig(**kwargs)


def test_large_but_runnable_distributions_are_kept_and_run() -> None:
    config = EvolutionConfig(initial_parts_sd=1e12, initial_hidden_mean=1e12)
    robot = random_robot(np.random.default_rng(0), config)
    assert robot.num_parts() in (config.min_parts, config.max_parts)


@pytest.mark.parametrize("retries", [1, 2, MIN_RANDOM_ROBOT_RETRIES - 1])
def test_retry_budgets_too_small_to_grow_a_population_are_refused(retries: int) -> None:
    with pytest.raises(ValueError, match=r"EvolutionConfig\.max_random_robot_retries"):
        EvolutionConfig(max_random_robot_retries=retries, initial_parts_mean=30)
    EvolutionConfig(max_random_robot_retries=MIN_RANDOM_ROBOT_RETRIES, initial_parts_mean=30)


def _any_value(field: str) -> st.SearchStrategy[object]:
    default = getattr(EvolutionConfig(), field)
    junk = st.one_of(st.none(), st.booleans(), st.text(max_size=3),
                     st.floats(allow_nan=True, allow_infinity=True),
                     st.integers(-(2**70), 2**70), st.just(1e308), st.just(-1e308))
    if isinstance(default, bool):
        near: st.SearchStrategy[object] = st.booleans()
    elif isinstance(default, int):
        hi = 40 if field in ("max_parts", "min_parts") else 2 * default + 20
        near = st.integers(0, hi)
    else:
        near = st.floats(0.0, 2.0 * default + 1.0)
    return st.one_of(st.just(default), near, junk)


@st.composite
def _config_kwargs(draw: st.DrawFn) -> dict[str, object]:
    names = draw(st.lists(st.sampled_from([f.name for f in dataclasses.fields(EvolutionConfig)]),
                          max_size=4, unique=True))
    return {n: draw(_any_value(n)) for n in names}


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_config_kwargs(), st.integers(0, 2**32 - 1))
def test_any_accepted_config_grows_a_random_robot(kwargs: dict[str, object], seed: int) -> None:
    """Only ValueError escapes construction; a config that is accepted grows a random robot
    (or, at worst, says why not with the documented RandomRobotError), never an OverflowError
    or another crash. Part counts are kept small so that the run stays quick."""
    try:
        config = EvolutionConfig(**kwargs)  # type: ignore[arg-type]
    except ValueError as exc:
        assert str(exc).startswith("EvolutionConfig.") and "\n" not in str(exc)
        return
    if config.max_parts > 40:
        return
    try:
        robot = random_robot(np.random.default_rng(seed), config)
    except RandomRobotError:
        return
    assert config.min_parts <= robot.num_parts() <= config.max_parts
