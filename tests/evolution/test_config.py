"""EvolutionConfig: the issue's defaults and clear errors for bad values."""

from __future__ import annotations

import dataclasses

import pytest

from evolution.config import EvolutionConfig
from revolve_env.body.validate import Limits


def test_defaults_are_the_papers_table_1() -> None:
    c = EvolutionConfig()
    assert (c.max_parts, c.min_parts, c.max_inputs, c.max_outputs, c.max_hidden) == (30, 3, 10, 10, 10)
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
    with pytest.raises(ValueError, match=field):
        EvolutionConfig(**{field: value})


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
def test_bad_values_raise_at_construction(kwargs: dict, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        EvolutionConfig(**kwargs)
