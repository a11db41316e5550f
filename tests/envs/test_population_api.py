"""PettingZoo's own conformance tests on PopulationEnv, with births and deaths mid-episode."""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from typing import Any

import numpy as np
import pytest
from gymnasium import spaces
from pettingzoo import ParallelEnv
from pettingzoo.test import parallel_api_test

from revolve_env.body.examples import gecko, snake
from revolve_env.envs.checks import check_population_determinism, population_with_births
from revolve_env.envs.population import PopulationEnv, population_env


class BirthsAndDeaths(ParallelEnv):
    """Runs a PopulationEnv through parallel_api_test while robots are born and die.

    Before step ``k`` of each episode: a brain robot is born every 4 steps and an agent robot every
    7; the oldest living robot is removed every 5 steps (its action, sampled by the test before
    the removal, is dropped). Not a PettingZoo wrapper (the API test refuses those); everything
    else is the env's own behaviour.
    """

    def __init__(self, env: PopulationEnv) -> None:
        self.env = env
        self.metadata = env.metadata
        self.possible_agents = env.possible_agents
        self.births = 0
        self.deaths = 0
        self._k = 0

    @property
    def agents(self) -> list[str]:  # type: ignore[override]
        return self.env.agents

    def observation_space(self, agent: str) -> spaces.Space:
        return self.env.observation_space(agent)

    def action_space(self, agent: str) -> spaces.Space:
        return self.env.action_space(agent)

    def reset(self, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        self._k = 0
        return self.env.reset(seed=seed, options=options)

    def step(self, actions: Mapping[str, Any]) -> tuple[dict, dict, dict, dict, dict]:
        self._k += 1
        if self._k % 4 == 0:
            self.env.add_robot(snake(2))
            self.births += 1
        if self._k % 7 == 0:
            self.env.add_robot(snake(3), controlled_by="agent")
            self.births += 1
        if self._k % 5 == 0 and self.env.agents:
            self.env.remove_robot(self.env.agents[0])
            self.deaths += 1
        live = set(self.env.agents)
        return self.env.step({a: act for a, act in actions.items() if a in live})

    def close(self) -> None:
        self.env.close()


def test_parallel_api_with_births_and_deaths() -> None:
    env = population_env(
        initial_robots=[gecko(), {"robot": snake(2), "controlled_by": "agent"}], max_births=200,
        birth_radius=3.0,
    )
    harness = BirthsAndDeaths(env)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # PettingZoo reports dict/agent mismatches as warnings
        parallel_api_test(harness, num_cycles=60)
    assert (harness.births, harness.deaths) == (2 * 23, 2 * 12)  # 2 episodes of 60 steps


def test_parallel_api_on_the_bare_env_with_blow_ups() -> None:
    # Every robot falls faster than 0.1 m/s at birth: all blow up in the first step, then the
    # episode has no agents left (the API test's "all agents done" path).
    from revolve_env.world import WorldConfig

    env = population_env(initial_robots=[snake(2), snake(3)], max_births=2,
                         world_config=WorldConfig(max_linear_speed=0.1))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parallel_api_test(env, num_cycles=5)


def test_the_seed_test_runs_every_step_through_births_and_deaths() -> None:
    """Our seed test (PettingZoo's parallel_seed_test stops after one step): same seed, same
    observations, rewards, terminations, truncations, infos and agents, step by step."""
    def make() -> PopulationEnv:
        return population_with_births(max_cycles=45)

    run = check_population_determinism(make, seed=4, steps=100)
    # max_cycles ended it; births at 10, 20, 30, 40, deaths at 15, 30 and everyone at 45.
    assert (run.steps, run.births) == (45, 4) and run.deaths >= 2 + 4


def test_the_seed_test_fails_on_an_unseeded_birth() -> None:
    """It can fail: a newborn placed by an unseeded generator is somewhere else in each env."""
    rngs = iter([np.random.default_rng(1), np.random.default_rng(2)])

    def make() -> PopulationEnv:
        rng = next(rngs)

        def births(env: PopulationEnv, k: int) -> None:
            if k == 5:
                env.add_robot(snake(2), position=(float(rng.uniform(2, 3)), 0.0))

        return population_env(initial_robots=[gecko()], lifecycle=births)

    with pytest.raises(AssertionError, match=r"step 5: infos differ"):
        check_population_determinism(make, steps=10)


def test_reset_with_the_same_seed_replays_births_and_observations() -> None:
    env = population_env(initial_robots=[gecko(), snake(3)])
    first = env.reset(seed=7)
    rollout = [env.step({}) for _ in range(5)]
    second = env.reset(seed=7)
    again = [env.step({}) for _ in range(5)]
    for a in first[0]:
        np.testing.assert_array_equal(first[1][a]["position"], second[1][a]["position"])
    for x, y in zip(rollout, again, strict=True):
        for agent in x[0]:
            np.testing.assert_array_equal(x[0][agent], y[0][agent])
            assert x[1][agent] == y[1][agent]


def test_reset_options_robots() -> None:
    env = population_env()
    obs, _ = env.reset(seed=0, options={"robots": [
        {"robot": snake(2), "position": (1.0, 1.0), "controlled_by": "agent", "yaw": 0.5}]})
    assert list(obs) == ["robot_0"]
    assert env.agent_info("robot_0")["controlled_by"] == "agent"
    np.testing.assert_allclose(env.agent_info("robot_0")["position"][:2], (1.0, 1.0), atol=1e-9)
    with pytest.raises(ValueError, match="initial robot 0.*keys"):
        env.reset(options={"robots": [{"body": snake(2)}]})
