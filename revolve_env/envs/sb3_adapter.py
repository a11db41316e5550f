"""One shared policy for a changing population: the population env as a stable-baselines3 VecEnv.

:class:`PopulationVecEnv` exposes a :class:`~revolve_env.envs.population.PopulationEnv` in
``space_mode="uniform"`` (every agent has the same spaces, padded, with masks) as an SB3
``VecEnv`` of a fixed number of *slots*. Each slot holds at most one living agent-controlled
robot; SB3 sees each slot as one environment, so any SB3 on-policy algorithm (PPO, A2C) trains
one policy with parameter sharing over every body, while robots are born and die inside the
population env's steps (``lifecycle=``).

## Slots
* At ``reset`` and whenever a robot with ``controlled_by="agent"`` is reported for the first
  time (a birth, between steps or inside a step through ``lifecycle``), it takes the free slot of
  lowest index. Brain-controlled robots live in the world but take no slot. A newborn that finds
  every slot taken is not driven by the policy (the env keeps its targets at 0) and is counted in
  :attr:`PopulationVecEnv.unslotted`.
* A slot's observation is the agent's uniform observation (float32), followed, with
  ``include_masks=True``, by its observation and action masks as 0/1 values, so that the shared
  policy knows which body it drives. A slot's action is the agent's uniform action; entries past
  the robot's hinges are set to 0 before they reach the env.
* An empty slot (no robot yet, or its robot died) observes zeros, earns reward 0 and its action
  is dropped: an absorbing state of value 0.

## Episodes (what SB3 sees per slot)
* A slot's episode is one robot's life in that slot. When its robot dies (removed, blown up, or
  truncated at ``max_cycles``) the slot reports ``done=True`` with the robot's last observation in
  ``infos[i]["terminal_observation"]`` and ``infos[i]["episode"] = {"r": life's return,
  "l": steps, "t": wall seconds}`` (what SB3's ``Monitor`` writes, so ``ep_info_buffer`` and the
  logger's ``rollout/ep_rew_mean`` work). A removal and the ``max_cycles`` truncation are not the
  robot's doing: they set ``infos[i]["TimeLimit.truncated"] = True``, so SB3 bootstraps the value
  there; a blow-up is a true termination.
* When a newborn takes an empty slot, the slot's stretch of emptiness ends with ``done=True``
  (no ``"episode"`` entry) and the returned observation is the newborn's first one. The reward
  of the step of birth is not credited to any slot (the policy did not act for it; it is 0
  during insertion anyway); from the next step on every reward of the robot is its slot's.
* ``infos[i]["agent"]`` names the slot's robot (None when empty) after the step.
* When no robot is alive any more (every one died, or ``max_cycles`` truncated them all) the
  population env is reset (with the seed given to :meth:`PopulationVecEnv.seed`, then that
  seed + 1, + 2, ...; unseeded before any ``seed`` call) and the initial robots take their slots.

Only on-policy use is supported (PPO, A2C): slots change occupant between steps, which is what
SB3's auto-resetting ``VecEnv`` contract allows. Wrap with ``VecNormalize`` as usual. Needs
stable-baselines3 (the ``learn`` or ``test`` extra); ``import revolve_env`` does not import this
module. Example: ``examples/multi_agent_shared_policy.py``.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray
from stable_baselines3.common.vec_env import VecEnv
from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices, VecEnvObs, VecEnvStepReturn

from revolve_env.envs.population import PopulationEnv

__all__ = ["PopulationVecEnv"]


class PopulationVecEnv(VecEnv):
    """A uniform-space :class:`PopulationEnv` as an SB3 ``VecEnv`` of ``n_slots`` slots.

    See the module docstring for how robots take slots and what SB3 sees at births and deaths.

    Args:
        env: A population env with ``space_mode="uniform"`` (not yet reset; the adapter resets
            it). Births and deaths come from its ``lifecycle`` or from calls between steps.
        n_slots: Number of slots (SB3's ``num_envs``): the most agent-controlled robots driven
            at once.
        reset_options: Passed to ``env.reset(options=...)`` (e.g. ``{"robots": [...]}`` with
            ``controlled_by="agent"`` entries).
        include_masks: Append the observation and action masks to each slot's observation.

    Attributes:
        slot_agents: The agent in each slot (None: empty), as of the last step or reset.
        unslotted: Newborn agent-controlled robots that found no free slot.
        resets: Times the population env was reset.
    """

    def __init__(self, env: PopulationEnv, n_slots: int,
                 reset_options: dict[str, Any] | None = None, include_masks: bool = True) -> None:
        if not isinstance(env, PopulationEnv):
            raise TypeError(f"env must be a PopulationEnv, got {type(env).__name__}")
        if env.space_mode != "uniform":
            raise ValueError("PopulationVecEnv needs space_mode='uniform' (one shape for every "
                             f"agent), got space_mode={env.space_mode!r}")
        if not (isinstance(n_slots, int) and n_slots >= 1):
            raise ValueError(f"n_slots must be an integer >= 1, got {n_slots!r}")
        self.env = env
        self.reset_options = reset_options
        self.include_masks = bool(include_masks)
        agent0 = env.possible_agents[0]
        env_obs: spaces.Box = env.observation_space(agent0)
        env_act: spaces.Box = env.action_space(agent0)
        self._n_obs = int(env_obs.shape[0])
        self._n_act = int(env_act.shape[0])
        low = env_obs.low.astype(np.float32)
        high = env_obs.high.astype(np.float32)
        if self.include_masks:
            n_masks = self._n_obs + self._n_act
            low = np.concatenate((low, np.zeros(n_masks, np.float32)))
            high = np.concatenate((high, np.ones(n_masks, np.float32)))
        observation_space = spaces.Box(low, high, dtype=np.float32)
        self._size = len(low)
        action_space = spaces.Box(-1.0, 1.0, (self._n_act,), dtype=np.float32)
        super().__init__(n_slots, observation_space, action_space)
        self.slot_agents: list[str | None] = [None] * n_slots
        self.unslotted: list[str] = []
        self.resets = 0
        self._actions: NDArray[np.float32] = np.zeros((n_slots, self._n_act), np.float32)
        self._returns = np.zeros(n_slots)
        self._lengths = np.zeros(n_slots, dtype=np.int64)
        self._born_at = np.zeros(n_slots)
        self._known: set[str] = set()  # agents ever seen this episode (slotted or not)
        self._next_seed: int | None = None

    # -- observations -----------------------------------------------------------------------------
    def _slot_obs(self, agent: str | None, obs: NDArray[np.float64] | None) -> NDArray[np.float32]:
        size = self._size
        if agent is None or obs is None:
            return np.zeros(size, np.float32)
        out = np.empty(size, np.float32)
        out[: self._n_obs] = obs
        if self.include_masks:
            out[self._n_obs: 2 * self._n_obs] = self.env.observation_mask(agent)
            out[2 * self._n_obs:] = self.env.action_mask(agent)
        return out

    def _take_slots(self, observations: dict[str, NDArray[np.float64]],
                    infos: dict[str, dict[str, Any]]) -> list[int]:
        """Give free slots to agent-controlled robots seen for the first time; their slots."""
        taken: list[int] = []
        for agent in observations:
            if agent in self._known:
                continue
            self._known.add(agent)
            info = infos.get(agent, {})
            if info.get("controlled_by") != "agent" or info.get("death") is not None:
                continue
            if None not in self.slot_agents:
                self.unslotted.append(agent)
                continue
            i = self.slot_agents.index(None)
            self.slot_agents[i] = agent
            self._returns[i] = 0.0
            self._lengths[i] = 0
            self._born_at[i] = time.perf_counter()
            taken.append(i)
        return taken

    def _reset_population(self) -> NDArray[np.float32]:
        seed = self._next_seed  # None: unseeded; else seed, seed + 1, ... for later resets
        self._next_seed = None if seed is None else seed + 1
        observations, infos = self.env.reset(seed=seed, options=self.reset_options)
        self.resets += 1
        self.slot_agents = [None] * self.num_envs
        self._known = set()
        self._take_slots(observations, infos)
        return np.stack([self._slot_obs(a, observations.get(a) if a is not None else None)
                         for a in self.slot_agents])

    # -- the VecEnv interface -----------------------------------------------------------------
    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        """Seed the next reset of the population env (the slots share one world)."""
        seeds: Sequence[int | None] = super().seed(seed)
        self._next_seed = seeds[0]
        return seeds

    def reset(self) -> VecEnvObs:
        """Reset the population env; the initial agent-controlled robots take the first slots."""
        return self._reset_population()

    def step_async(self, actions: NDArray[np.float32]) -> None:
        """Remember the slots' actions (shape ``(n_slots, n_act)``) for :meth:`step_wait`."""
        a = np.asarray(actions, dtype=np.float32)
        if a.shape != (self.num_envs, self._n_act):
            raise ValueError(f"actions must have shape {(self.num_envs, self._n_act)} (one uniform "
                             f"action per slot), got {a.shape}")
        self._actions = a

    def step_wait(self) -> VecEnvStepReturn:
        """Step the population env once with every slotted robot's action."""
        env = self.env
        alive = set(env.agents)
        actions: dict[str, NDArray[np.float32]] = {}
        for i, agent in enumerate(self.slot_agents):
            if agent is not None and agent in alive:
                actions[agent] = np.where(env.action_mask(agent), self._actions[i], 0.0).astype(
                    np.float32)
        observations, rewards, terminations, truncations, infos = env.step(actions)

        n = self.num_envs
        obs = np.zeros((n, self._size), np.float32)
        rew = np.zeros(n, np.float32)
        dones = np.zeros(n, dtype=bool)
        slot_infos: list[dict[str, Any]] = [{} for _ in range(n)]
        for i, agent in enumerate(self.slot_agents):
            if agent is None:
                continue
            if agent not in observations:  # removed by the caller and already reported: gone
                self.slot_agents[i] = None
                dones[i] = True
                slot_infos[i]["TimeLimit.truncated"] = True
                slot_infos[i]["terminal_observation"] = np.zeros_like(obs[i])
                continue
            r = float(rewards[agent])
            rew[i] = r
            self._returns[i] += r
            self._lengths[i] += 1
            last = self._slot_obs(agent, observations[agent])
            obs[i] = last
            if terminations[agent] or truncations[agent]:
                death = infos[agent].get("death")
                dones[i] = True
                slot_infos[i]["terminal_observation"] = last
                slot_infos[i]["TimeLimit.truncated"] = bool(
                    truncations[agent] or death == "removed")
                slot_infos[i]["episode"] = {"r": float(self._returns[i]),
                                            "l": int(self._lengths[i]),
                                            "t": round(time.perf_counter() - self._born_at[i], 6)}
                slot_infos[i]["death"] = death
                obs[i] = 0.0
                self.slot_agents[i] = None

        if not env.agents:  # nobody is alive: a new population episode
            fresh = self._reset_population()
            for i in range(n):
                obs[i] = fresh[i]
                if self.slot_agents[i] is not None and not dones[i]:
                    dones[i] = True  # an empty stretch ends
                    slot_infos[i]["terminal_observation"] = np.zeros_like(obs[i])
                    slot_infos[i]["TimeLimit.truncated"] = False
        else:
            for i in self._take_slots(observations, infos):
                agent = self.slot_agents[i]
                assert agent is not None
                obs[i] = self._slot_obs(agent, observations[agent])
                if not dones[i]:  # an empty stretch ends where the newborn starts
                    dones[i] = True
                    slot_infos[i]["terminal_observation"] = np.zeros_like(obs[i])
                    slot_infos[i]["TimeLimit.truncated"] = False
        for i, agent in enumerate(self.slot_agents):
            slot_infos[i]["agent"] = agent
        return obs, rew, dones, slot_infos

    def close(self) -> None:
        """Close the population env."""
        self.env.close()

    def _indices(self, indices: VecEnvIndices) -> list[int]:
        if indices is None:
            return list(range(self.num_envs))
        if isinstance(indices, int):
            return [indices]
        return list(indices)

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """The population env's attribute, once per slot (the slots share one env)."""
        return [getattr(self.env, attr_name) for _ in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Set an attribute of the population env (shared by every slot)."""
        setattr(self.env, attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None,
                   **method_kwargs: Any) -> list[Any]:
        """Call a method of the population env once (its result repeated per slot)."""
        result = getattr(self.env, method_name)(*method_args, **method_kwargs)
        return [result for _ in self._indices(indices)]

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper[Any, Any, Any, Any]],
                       indices: VecEnvIndices = None) -> list[bool]:
        """False for every slot: the population env is not a Gymnasium env to wrap."""
        return [False for _ in self._indices(indices)]

