"""BlackDeath: a population with births and deaths as a fixed set of slots (no SuperSuit here).

The SuperSuit and stable-baselines3 routes over it are tests/envs/test_supersuit_routes.py.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test
from world_views import hinge_targets

from revolve_env.body.examples import gecko, snake, spider
from revolve_env.envs.black_death import BlackDeath
from revolve_env.envs.checks import BirthsAndDeaths
from revolve_env.envs.population import PopulationEnv, population_env

# Agent-driven robots; a newborn every 5 steps, the oldest robot removed every 7.
LIFE = BirthsAndDeaths(birth_every=5, death_every=7, newborns=((snake(3), "agent"),))
NEVER = 10**6


def _env(lifecycle: BirthsAndDeaths | None = LIFE, **kwargs: Any) -> PopulationEnv:
    args: dict[str, Any] = {"space_mode": "uniform", "max_births": 6, "birth_radius": 3.0,
                            "insertion_time": 0.05, "lifecycle": lifecycle, **kwargs}
    return population_env(initial_robots=[{"robot": gecko(), "controlled_by": "agent"},
                                          {"robot": snake(2), "controlled_by": "agent"}], **args)


def _actions(env: BlackDeath, value: float = 0.5) -> dict[str, np.ndarray]:
    return {a: np.full(env.action_space(a).shape, value, np.float32) for a in env.agents}


def test_every_slot_is_reported_every_step_through_births_and_deaths_inside_steps() -> None:
    # Rewards every control period (the default 5 Hz pose rate rewards every 12th step only).
    env = BlackDeath(_env(task={"name": "locomotion", "pose_rate": "every-period"}))
    assert env.possible_agents == [f"robot_{k}" for k in range(6)]
    obs, infos = env.reset(seed=0)
    assert env.agents == env.possible_agents and set(obs) == set(infos) == set(env.agents)
    assert obs["robot_0"].any() and not obs["robot_2"].any() and infos["robot_2"] == {"agent": None}
    for k in range(1, 11):
        obs, rewards, terms, truncs, infos = env.step(_actions(env))
        for d in (obs, rewards, terms, truncs, infos):
            assert list(d) == env.possible_agents
        assert not any(terms.values()) and not any(truncs.values())
        if k == 5:  # robot_2 is born inside step 5: its slot reports it at once
            assert obs["robot_2"].any() and infos["robot_2"]["agent"] == "robot_2"
        if k == 7:  # robot_0 removed inside step 7: its last report, not an end
            assert infos["robot_0"]["death"] == "removed" and obs["robot_0"].any()
        if k > 7:  # then black: zeros, reward 0, and its action is dropped
            assert not obs["robot_0"].any() and rewards["robot_0"] == 0.0
            assert infos["robot_0"] == {"agent": None}
    assert env.slot_agents[:4] == [None, "robot_1", "robot_2", "robot_3"]  # born in step 10
    assert rewards["robot_1"] != 0.0  # living robots keep their rewards


def test_births_between_steps_take_free_slots_and_deaths_free_them() -> None:
    env = BlackDeath(_env(None), slots=3)
    assert env.possible_agents == ["slot_0", "slot_1", "slot_2"]
    obs, _ = env.reset(seed=0)
    assert env.slot_agents == ["robot_0", "robot_1", None] and not obs["slot_2"].any()
    assert env.observation_space("slot_2") is env.unwrapped.observation_space("robot_0")
    env.add_robot(spider(), controlled_by="agent")  # robot_2, reported by the next step
    obs, *_ = env.step(_actions(env))
    assert env.slot_agents == ["robot_0", "robot_1", "robot_2"] and obs["slot_2"].any()
    env.remove_robot("robot_0")
    env.add_robot(snake(3), controlled_by="agent")  # robot_3: every slot still taken
    obs, _, terms, _, infos = env.step(_actions(env))
    assert infos["slot_0"]["death"] == "removed" and not terms["slot_0"]
    assert env.unslotted == ["robot_3"] and "robot_3" not in env.slot_agents
    env.add_robot(gecko(), controlled_by="agent")  # robot_4 takes robot_0's freed slot
    obs, *_ = env.step(_actions(env))
    assert env.slot_agents == ["robot_4", "robot_1", "robot_2"]
    assert env.unwrapped.agents == ["robot_1", "robot_2", "robot_3", "robot_4"]


def test_the_slot_of_a_robot_drives_it_and_an_empty_slot_drops_its_action() -> None:
    env = BlackDeath(_env(None), slots=3)
    env.reset(seed=0)
    actions = {"slot_0": np.full(10, 0.7, np.float32), "slot_1": np.full(10, -0.3, np.float32),
               "slot_2": np.ones(10, np.float32)}
    env.step(actions)  # slot_2 is empty: its action goes nowhere
    world = env.unwrapped.world
    for handle, value in enumerate((0.7, -0.3)):  # targets of 1 are 45 degrees
        assert np.allclose(hinge_targets(world, handle), value * np.pi / 4)


def test_the_episode_ends_for_every_slot_when_no_robot_is_left_or_at_max_cycles() -> None:
    env = BlackDeath(_env(BirthsAndDeaths(birth_every=NEVER, death_every=2)))
    env.reset(seed=0)
    env.step(_actions(env))
    _, _, terms, truncs, _ = env.step(_actions(env))  # robot_0 removed
    assert env.agents and not any(truncs.values())
    _, _, _, _, _ = env.step(_actions(env))
    _, _, terms, truncs, infos = env.step(_actions(env))  # robot_1 removed: nobody left
    # The last robot's slot ends as the env ends it (a removal: terminated), the rest truncated.
    assert infos["robot_1"]["death"] == "removed" and terms["robot_1"] and not truncs["robot_1"]
    assert all(truncs[a] and not terms[a] for a in env.possible_agents if a != "robot_1")
    assert env.agents == []
    with pytest.raises(RuntimeError, match="call reset"):
        env.step({})
    obs, _ = env.reset(seed=1)  # a new episode, every slot again
    assert env.agents == env.possible_agents and obs["robot_0"].any()

    capped = BlackDeath(_env(None, max_cycles=3), slots=4)
    capped.reset(seed=0)
    for _ in range(3):
        _, _, terms, truncs, _ = capped.step(_actions(capped))
    assert all(truncs.values()) and capped.agents == []


@pytest.mark.parametrize("slots", [None, 3])
def test_pettingzoo_parallel_api_test_passes_with_births_and_deaths(slots: int | None) -> None:
    parallel_api_test(BlackDeath(_env(max_cycles=40), slots=slots), num_cycles=60)


def test_bad_arguments_are_refused_by_name() -> None:
    with pytest.raises(ValueError, match="slots must be"):
        BlackDeath(_env(), slots=0)
    with pytest.raises(ValueError, match="space_mode='uniform'"):
        BlackDeath(_env(space_mode="exact"), slots=2)
    with pytest.raises(KeyError, match="slot_9"):
        BlackDeath(_env(), slots=2).observation_space("slot_9")
