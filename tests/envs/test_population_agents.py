"""Agents change only through ``step``: births and deaths between two steps, as PettingZoo expects.

A robot added between two steps enters ``agents`` in the next step, which reports it with its
first observation; a robot removed between two steps leaves ``agents`` in the next step, which
reports its death. The loops a user writes first must therefore never miss an observation.
"""

from __future__ import annotations

import numpy as np
from pettingzoo.utils.conversions import parallel_to_aec

from revolve_env.body.examples import gecko, snake, spider
from revolve_env.envs.population import PopulationEnv, population_env


def _policy(env: PopulationEnv, obs: np.ndarray, agent: str) -> np.ndarray:
    """A fixed policy: one action in the agent's space, made from its observation."""
    n = env.action_space(agent).shape[0]
    return np.full(n, np.tanh(float(obs.sum())), dtype=np.float32)


def test_a_policy_over_agents_finds_every_observation_through_births_and_deaths() -> None:
    env = population_env(initial_robots=[{"robot": gecko(), "controlled_by": "agent"}],
                         max_births=10, birth_radius=3.0)
    obs, _ = env.reset(seed=3)
    newborns = []
    for k in range(1, 13):
        if k % 4 == 0:
            newborns.append(env.add_robot(snake(3), controlled_by="agent"))
            assert newborns[-1] not in env.agents  # it enters with the next step's report
        if k == 6:
            env.remove_robot("robot_0")
            assert "robot_0" in env.agents  # until the next step reports its death
        actions = {a: _policy(env, obs[a], a) for a in env.agents}  # no KeyError
        obs, _, term, trunc, infos = env.step(actions)
        assert set(env.agents) == {a for a in obs if not (term[a] or trunc[a])}
        if k % 4 == 0:
            born = newborns[-1]
            assert born in env.agents and infos[born]["age"] == env.config.control_period
            assert env.observation_space(born).contains(obs[born])
        if k == 6:
            assert term["robot_0"] and infos["robot_0"]["death"] == "removed"
    assert env.agents == ["robot_1", "robot_2", "robot_3"]


def test_a_newborn_between_steps_is_simulated_in_the_next_step_as_before() -> None:
    """Where the robot is and what it senses do not depend on when ``agents`` learns of it."""
    env = population_env(initial_robots=[], max_births=4)
    env.reset(seed=0)
    agent = env.add_robot(spider())
    first = env.observe(agent)  # its observation at birth, before any step
    obs, *_ = env.step({})
    assert not np.array_equal(obs[agent], first)  # the step moved it
    twin = population_env(initial_robots=[spider()], max_births=4)
    twin.reset(seed=0)
    twin_obs, *_ = twin.step({})
    np.testing.assert_array_equal(obs[agent], twin_obs[agent])


def test_parallel_to_aec_last_never_misses_a_robot_added_between_steps() -> None:
    env = population_env(initial_robots=[{"robot": gecko(), "controlled_by": "agent"}],
                         max_births=10, birth_radius=3.0, space_mode="uniform")
    aec = parallel_to_aec(env)
    aec.reset(seed=1)
    acted: set[str] = set()
    turns = 0
    for agent in aec.agent_iter(max_iter=60):
        obs, _, terminated, truncated, _ = aec.last()  # no KeyError for a newborn
        if terminated or truncated:
            aec.step(None)
            continue
        acted.add(agent)
        aec.step(np.zeros(aec.action_space(agent).shape, np.float32))
        turns += 1
        if turns in (5, 9):  # between two cycles, as examples/online_world.py adds robots
            env.add_robot(snake(3), controlled_by="agent")
        if turns == 14:
            env.remove_robot("robot_0")
    assert {"robot_1", "robot_2"} <= acted
    assert "robot_0" not in aec.agents
