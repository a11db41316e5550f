"""One id per robot: the PettingZoo agent name is derived from it and parsed back in one place."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from revolve_env.status import agent_name, robot_id


@given(st.integers(min_value=0, max_value=10**12))
def test_an_agent_name_is_its_robot_id_and_back(k: int) -> None:
    assert agent_name(k) == f"robot_{k}"
    assert robot_id(agent_name(k)) == k


@pytest.mark.parametrize("name", ["robot_", "robot_01", "robot_-1", "robot_1.0", "Robot_1",
                                  "robot_١", "spider", "", "robot_ 1"])
def test_what_is_not_an_agent_name_is_refused_naming_it(name: str) -> None:
    with pytest.raises(KeyError, match="unknown agent"):
        robot_id(name)
