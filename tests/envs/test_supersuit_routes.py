"""SuperSuit's routes that assume a fixed set of agents, tried with births (docs/rl_routes.md).

What these tests prove, so that the README's table of routes stays true:

* ``black_death_v3`` copies ``agents`` at ``reset`` and indexes the actions by the env's agents:
  the first newborn's action is a ``KeyError`` in SuperSuit, and a newborn's death is never
  reported (its dones cover reset's agents only). Without births it works (deaths only).
* ``pettingzoo_env_to_vec_env_v1`` (+ ``concat_vec_envs_v1``) needs an observation of every
  possible agent at every step; unborn agents have none, with or without ``black_death_v3``.
  The vec-env route for a population with births is the project's ``PopulationVecEnv``
  (tests/envs/test_sb3_adapter.py), a fixed number of slots that robots take and leave.
"""

from __future__ import annotations

import numpy as np
import pytest

ss = pytest.importorskip("supersuit", reason="needs supersuit (the test extra)")

from revolve_env.body.examples import gecko, snake  # noqa: E402
from revolve_env.envs.checks import BirthsAndDeaths  # noqa: E402
from revolve_env.envs.population import PopulationEnv, population_env  # noqa: E402

# A gecko and a snake driven by actions; a newborn every 5 steps, a death every 7.
LIFE = BirthsAndDeaths(birth_every=5, death_every=7, newborns=((snake(3), "agent"),))


def _env(lifecycle: BirthsAndDeaths | None = LIFE, max_births: int = 6) -> PopulationEnv:
    return population_env(initial_robots=[{"robot": gecko(), "controlled_by": "agent"},
                                          {"robot": snake(2), "controlled_by": "agent"}],
                          space_mode="uniform", max_births=max_births, birth_radius=3.0,
                          lifecycle=lifecycle)


def _actions(env: object, agents: list[str]) -> dict[str, np.ndarray]:
    return {a: np.zeros(env.action_space(a).shape, np.float32)  # type: ignore[attr-defined]
            for a in agents}


def test_black_death_works_for_deaths_without_births() -> None:
    wrapped = ss.black_death_v3(_env(BirthsAndDeaths(birth_every=10**6, death_every=7)))
    obs, _ = wrapped.reset(seed=0)
    for _ in range(10):
        obs, rewards, _, _, _ = wrapped.step(_actions(wrapped, wrapped.agents))
    # robot_0 was removed at step 7: it stays, black (zeros, reward 0).
    assert set(obs) == {"robot_0", "robot_1"} and not obs["robot_0"].any()
    assert rewards["robot_0"] == 0.0


def test_black_death_fails_at_the_first_birth() -> None:
    wrapped = ss.black_death_v3(_env())
    wrapped.reset(seed=0)
    for _ in range(5):  # robot_2 is born in step 5
        obs, *_ = wrapped.step(_actions(wrapped, wrapped.agents))
    assert "robot_2" in obs and "robot_2" not in wrapped.agents  # SuperSuit's copy from reset
    with pytest.raises(KeyError, match="robot_2"):
        wrapped.step(_actions(wrapped, wrapped.agents))


def test_the_vec_env_route_needs_every_possible_agent_alive() -> None:
    for env in (_env(), ss.black_death_v3(_env())):
        with pytest.raises(AssertionError, match="agent death"):
            ss.pettingzoo_env_to_vec_env_v1(env).reset(seed=0)


def test_the_vec_env_route_works_with_black_death_when_every_robot_is_born_at_reset() -> None:
    """No births (``max_births`` = the robots of reset): deaths are black, SB3 sees 2 envs."""
    env = ss.black_death_v3(_env(BirthsAndDeaths(birth_every=10**6, death_every=7), 2))
    vec = ss.concat_vec_envs_v1(ss.pettingzoo_env_to_vec_env_v1(env), 1, num_cpus=0,
                                base_class="stable_baselines3")
    obs = vec.reset()
    assert obs.shape == (2, 10)
    for _ in range(10):
        obs, rewards, _, _ = vec.step(np.zeros((2, 10), np.float32))
    assert not obs[0].any() and rewards[0] == 0.0  # robot_0, removed at step 7, is black
    vec.close()
