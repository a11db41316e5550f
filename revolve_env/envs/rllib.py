"""The population env as an RLlib multi-agent env: one shared policy while robots are born and die.

:class:`PopulationMultiAgentEnv` is RLlib's ``MultiAgentEnv`` over a
:class:`~revolve_env.envs.population.PopulationEnv` in ``space_mode="uniform"``: every agent of
``possible_agents`` (``robot_0 .. robot_<max_births - 1>``) has the same declared spaces from the
start, so RLlib's env runners accept an agent it has never seen (its stock
``ParallelPettingZooEnv`` learns the spaces of the agents present at ``reset`` only, and fails at
the first birth). Needs ray's RLlib (the ``rllib`` extra: ``pip install revolve-env[rllib]``);
``import revolve_env`` does not import this module.

## Agents
The RLlib agents are the robots driven by actions (``controlled_by="agent"``); brain-controlled
robots live and collide in the same world but are not reported (nothing could learn from them).
A robot enters with the step that first reports it (a birth through the population env's
``lifecycle``, or ``add_robot`` on :attr:`PopulationMultiAgentEnv.env` between two steps), and is
reported once more, terminated, in the step of its death (removed or blown up). Observations
are the uniform ones as float32 (Table 1: 10 sensor values, padded; with ``proprioception`` 10
hinge angles and 10 velocities more); actions are uniform, ``Box(-1, 1, (10,))``, entries past the
robot's hinges ignored. Rewards are the task's fitness gain per step
(:mod:`revolve_env.tasks`).

## Episodes
``terminateds["__all__"]`` is True once no robot is left (every one died); with ``max_cycles``
set the step that reaches it truncates every robot and sets ``truncateds["__all__"]``. Infos
are small: ``robot_id``, ``age`` (seconds), ``fitness`` (metres for locomotion), ``death``.

## Config (RLlib's ``env_config``)
The population env's keyword arguments (:func:`~revolve_env.envs.population.population_env`);
``space_mode`` must be ``"uniform"`` (the default here). Without ``initial_robots`` the episode
starts with one of each example robot, every one driven by the policy.

Example::

    from ray.rllib.algorithms.ppo import PPOConfig
    from revolve_env.envs.checks import BirthsAndDeaths
    from revolve_env.envs.rllib import PopulationMultiAgentEnv

    config = (PPOConfig().environment(PopulationMultiAgentEnv, env_config={
                  "lifecycle": BirthsAndDeaths(), "max_cycles": 300, "max_births": 40})
              .multi_agent(policies={"shared"},
                           policy_mapping_fn=lambda agent, episode, **kw: "shared"))
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray
from ray.rllib.env.multi_agent_env import MultiAgentEnv
from ray.rllib.utils.typing import AgentID, MultiAgentDict

from revolve_env.body.examples import EXAMPLES
from revolve_env.envs.population import PopulationEnv

__all__ = ["INFO_KEYS", "PopulationMultiAgentEnv"]

INFO_KEYS = ("robot_id", "age", "fitness", "death")
"""The entries of the population env's infos passed on to RLlib (the rest, e.g. trajectories,
would grow every step of every episode RLlib keeps)."""


def _float32(box: spaces.Box) -> spaces.Box:
    return spaces.Box(box.low.astype(np.float32), box.high.astype(np.float32), dtype=np.float32)


class PopulationMultiAgentEnv(MultiAgentEnv):
    """RLlib's multi-agent env over a population env with births and deaths (see the module doc).

    Args:
        config: The population env's keyword arguments (RLlib's ``env_config``); None: defaults.

    Raises:
        ValueError: ``space_mode`` other than ``"uniform"`` (one shared policy needs one shape).
    """

    def __init__(self, config: Mapping[str, Any] | None = None) -> None:
        kwargs = dict(config or {})
        if kwargs.setdefault("space_mode", "uniform") != "uniform":
            raise ValueError(f"PopulationMultiAgentEnv needs space_mode='uniform' (every agent "
                             f"declared with one shape), got {kwargs['space_mode']!r}")
        kwargs.setdefault("initial_robots", [{"robot": make(), "controlled_by": "agent"}
                                             for make in EXAMPLES.values()])
        self.env = PopulationEnv(**kwargs)
        # Declared for every possible agent before any is born: one shape, one object each.
        obs_space = _float32(self.env.observation_space(self.env.possible_agents[0]))
        act_space = self.env.action_space(self.env.possible_agents[0])
        self.possible_agents: list[AgentID] = list(self.env.possible_agents)
        self.observation_spaces = dict.fromkeys(self.possible_agents, obs_space)
        self.action_spaces = dict.fromkeys(self.possible_agents, act_space)
        self.agents: list[AgentID] = []
        super().__init__()  # type: ignore[no-untyped-call]  # ray leaves it unannotated
        self._steps = 0

    @staticmethod
    def _driven(infos: Mapping[str, Mapping[str, Any]]) -> list[str]:
        return [a for a, info in infos.items() if info["controlled_by"] == "agent"]

    @staticmethod
    def _obs(obs: Mapping[str, NDArray[np.float64]], agents: list[str]) -> MultiAgentDict:
        return {a: obs[a].astype(np.float32) for a in agents}

    @staticmethod
    def _info(info: Mapping[str, Any]) -> dict[str, Any]:
        return {k: info[k] for k in INFO_KEYS}

    # RLlib's MultiAgentEnv returns dicts where gymnasium's Env returns one value: its own
    # signatures, not gymnasium's, are the contract here.
    def reset(self, *, seed: int | None = None,  # type: ignore[override]
              options: dict[str, Any] | None = None) -> tuple[MultiAgentDict, MultiAgentDict]:
        """A new population episode: the driven robots' first observations and infos."""
        obs, infos = self.env.reset(seed=seed, options=options)
        self._steps = 0
        driven = self._driven(infos)
        self.agents = [a for a in driven]  # noqa: C416 - typed as RLlib's AgentIDs
        return self._obs(obs, driven), {a: self._info(infos[a]) for a in driven}

    def step(self, action_dict: MultiAgentDict) -> tuple[  # type: ignore[override]
            MultiAgentDict, MultiAgentDict, MultiAgentDict, MultiAgentDict, MultiAgentDict]:
        """One population step with the driven robots' actions (RLlib's five dicts)."""
        obs, rewards, terms, truncs, infos = self.env.step(
            {str(a): action for a, action in action_dict.items()})
        self._steps += 1
        reported = self._driven(infos)
        self.agents = [a for a in self.env.agents if infos[a]["controlled_by"] == "agent"]
        terminateds: MultiAgentDict = {a: terms[a] for a in reported}
        truncateds: MultiAgentDict = {a: truncs[a] for a in reported}
        cycles = self.env.max_cycles
        truncateds["__all__"] = cycles is not None and self._steps >= cycles
        terminateds["__all__"] = not self.env.agents and not truncateds["__all__"]
        return (self._obs(obs, reported), {a: rewards[a] for a in reported}, terminateds,
                truncateds, {a: self._info(infos[a]) for a in reported})

    def close(self) -> None:
        """Release the population env's world."""
        self.env.close()
