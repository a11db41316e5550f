"""Black death for a population whose robots are born and die: a fixed set of slots.

SuperSuit's ``black_death_v3`` copies ``agents`` at ``reset``; the first robot born later is a
``KeyError`` inside SuperSuit. :class:`BlackDeath` instead gives every step the same agents, its
*slots*, fixed for the env's lifetime, so that SuperSuit's vec-env route
(``pettingzoo_env_to_vec_env_v1`` + ``concat_vec_envs_v1``, into stable-baselines3) and its
per-agent wrappers (pad, normalize, clip) work over a changing population::

    env = BlackDeath(population_env(space_mode="uniform", max_births=40, lifecycle=...), slots=8)
    vec = ss.concat_vec_envs_v1(ss.pettingzoo_env_to_vec_env_v1(env), 1,
                                base_class="stable_baselines3")

## Slots
* ``slots=None``: the slots are the env's ``possible_agents`` (``robot_0 .. robot_<max_births -
  1>``); robot ``robot_k`` lives in slot ``robot_k``. One slot per possible robot: keep
  ``max_births`` small (SuperSuit makes one vector entry per slot).
* ``slots=n``: ``slot_0 .. slot_<n - 1>``. A robot takes the free slot of lowest index when a
  step (or ``reset``) first reports it: a birth between steps (``env.add_robot``, reported by the
  next step) or inside a step (``lifecycle=``) alike. When it dies its slot is free again, for the
  next newborn. A newborn that finds every slot taken is not seen nor driven (it keeps the
  targets it has, 0 at birth; its brain drives a brain-controlled robot) and is counted in
  :attr:`BlackDeath.unslotted`. Every slot has the spaces of the env's first possible agent, so
  the population env needs ``space_mode="uniform"``.

## What a step reports, per slot (every slot, every step)
* A slot whose robot is alive: the robot's observation, reward, termination, truncation and info
  (``info["agent"]`` names the robot).
* A slot with no robot (not yet born, dead, or free): zeros for its observation, reward 0,
  ``terminated = truncated = False``, ``info = {"agent": None}``. Its action is dropped.
* A robot's death is black, not reported as an end: in its last step the slot reports its last
  observation and reward with ``terminated = truncated = False`` and the env's
  ``info["death"]`` (``"removed"``, ``"blow_up"``); from the next step on the slot is empty.
  SuperSuit's convention: the agents stay the same until the episode ends.
* The episode ends when no robot is left (every one died) or at the env's ``max_cycles``: every
  slot then reports ``truncated = True``, except one whose robot the env reports terminated in
  that step (removed, blown up): ``terminated = True``; ``agents`` is empty until ``reset``.

Actions for slots are passed to their robots; an action for an empty slot, or for a slot name
not of :attr:`BlackDeath.possible_agents`, is dropped (SuperSuit's vec env sends one for every
slot). Attributes not defined here (``add_robot``, ``remove_robot``, ``positions``, ...) are the
env's (PettingZoo's wrapper rule), so births between steps are ``wrapped.add_robot(...)``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray
from pettingzoo import ParallelEnv
from pettingzoo.utils.wrappers import BaseParallelWrapper

__all__ = ["BlackDeath"]

Dicts = tuple[dict[str, Any], dict[str, float], dict[str, bool], dict[str, bool],
              dict[str, dict[str, Any]]]


# pettingzoo ships no type information (no py.typed), so mypy sees the wrapper as Any.
class BlackDeath(BaseParallelWrapper):  # type: ignore[misc]
    """A parallel env with births and deaths as a fixed set of always-present slots.

    See the module doc for the slots and what a step reports.

    Args:
        env: A PettingZoo parallel env whose agents are born and die, e.g.
            :class:`~revolve_env.envs.population.PopulationEnv`. Its observation spaces must be
            ``Box`` (the black observation is zeros of that shape).
        slots: None: one slot per possible agent, named as the agent; an int >= 1: that many
            slots, ``slot_0 ...``, taken by robots as they are born.

    Attributes:
        possible_agents: The slots.
        agents: Every slot while the episode runs; empty once it has ended.
        slot_agents: The env's agent in each slot (None: empty), as of the last step or reset.
        unslotted: Newborns that found every slot taken (``slots=n`` only), since ``reset``.

    Raises:
        ValueError: ``slots`` is not None nor an int >= 1, or ``slots=n`` over a population env
            that is not in ``space_mode="uniform"``, or over agents whose spaces differ.
        TypeError: an observation space that is not a ``Box``.
    """

    def __init__(self, env: ParallelEnv[str, Any, Any], slots: int | None = None) -> None:
        super().__init__(env)
        if slots is not None and not (isinstance(slots, int) and not isinstance(slots, bool)
                                      and slots >= 1):
            raise ValueError(f"slots must be None or an integer >= 1, got {slots!r}")
        if slots is not None and getattr(env.unwrapped, "space_mode", "uniform") != "uniform":
            raise ValueError("BlackDeath(slots=n) needs one space for every robot: make the "
                             "population env with space_mode='uniform'")
        self._named = slots is None
        names = list(env.possible_agents)
        self.possible_agents: list[str] = (names if slots is None
                                           else [f"slot_{i}" for i in range(slots)])
        self.agents: list[str] = []
        self._first = names[0]
        self._index = {name: i for i, name in enumerate(self.possible_agents)}
        self.slot_agents: list[str | None] = [None] * len(self.possible_agents)
        self.unslotted: list[str] = []
        self._slot_of: dict[str, int] = {}  # a living robot's slot
        self._seen: set[str] = set()  # robots reported since reset (slotted or not)
        self._black: dict[str, NDArray[Any]] = {}

    # -- spaces ----------------------------------------------------------------------------
    def _source(self, slot: str) -> str:
        """The env agent whose spaces a slot has (itself, or the env's first possible agent)."""
        if slot not in self._index:
            raise KeyError(f"{slot!r} is not a slot of this env (slots: {self.possible_agents[0]} "
                           f"... {self.possible_agents[-1]})")
        return slot if self._named else self._first

    def observation_space(self, agent: str) -> spaces.Box:
        """The slot's observation space (the env's, of its robot or of the first possible one)."""
        space = self.env.observation_space(self._source(agent))
        if not isinstance(space, spaces.Box):
            raise TypeError(f"black death needs Box observation spaces, {agent!r} has {space}")
        return space

    def action_space(self, agent: str) -> spaces.Space[Any]:
        """The slot's action space."""
        space: spaces.Space[Any] = self.env.action_space(self._source(agent))
        return space

    def _zeros(self, slot: str) -> NDArray[Any]:
        black = self._black.get(slot)
        if black is None:
            box = self.observation_space(slot)
            black = self._black[slot] = np.zeros_like(box.low)
        return black.copy()

    # -- slots -----------------------------------------------------------------------------
    def _take_slots(self, reported: list[str]) -> None:
        """Give a slot to every robot reported for the first time, in report order."""
        for agent in reported:
            if agent in self._seen:
                continue
            self._seen.add(agent)
            if self._named:
                i = self._index.get(agent)
                if i is None:
                    raise KeyError(f"the env reported {agent!r}, not one of its possible_agents")
            elif None in self.slot_agents:
                i = self.slot_agents.index(None)
                self._check_spaces(agent)
            else:
                self.unslotted.append(agent)
                continue
            self.slot_agents[i] = agent
            self._slot_of[agent] = i

    def _check_spaces(self, agent: str) -> None:
        first = self.possible_agents[0]
        if (self.env.observation_space(agent) != self.observation_space(first)
                or self.env.action_space(agent) != self.action_space(first)):
            raise ValueError(f"{agent!r} has other spaces than the slots: BlackDeath(slots=n) "
                             "needs one space for every agent")

    def _free(self, agent: str) -> None:
        i = self._slot_of.pop(agent, None)
        if i is not None:
            self.slot_agents[i] = None

    # -- PettingZoo API --------------------------------------------------------------------
    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[dict[str, Any], dict[str, dict[str, Any]]]:
        """Reset the env; every slot is an agent, the initial robots in the first slots."""
        observations, infos = self.env.reset(seed=seed, options=options)
        self.slot_agents = [None] * len(self.possible_agents)
        self._slot_of, self._seen, self.unslotted = {}, set(), []
        self._take_slots(list(observations))
        self.agents = list(self.possible_agents)
        obs: dict[str, Any] = {}
        slot_infos: dict[str, dict[str, Any]] = {}
        for slot, agent in zip(self.possible_agents, self.slot_agents, strict=True):
            if agent is None:
                obs[slot], slot_infos[slot] = self._zeros(slot), {"agent": None}
            else:
                obs[slot], slot_infos[slot] = observations[agent], {**infos[agent], "agent": agent}
        return obs, slot_infos

    def step(self, actions: Mapping[str, Any]) -> Dicts:
        """Step the env with the actions of the occupied slots (see the module doc)."""
        if not self.agents:
            raise RuntimeError("the episode has ended (no robot left, or max_cycles): call reset()")
        alive = set(self.env.agents)
        forwarded: dict[str, Any] = {}
        for slot, action in actions.items():
            i = self._index.get(slot)
            agent = None if i is None else self.slot_agents[i]
            if agent is not None and agent in alive:
                forwarded[agent] = action
        observations, rewards, terminations, truncations, infos = self.env.step(forwarded)
        self._take_slots(list(observations))
        ended = not self.env.agents  # nobody alive (or max_cycles): the episode is over
        obs: dict[str, Any] = {}
        rew: dict[str, float] = {}
        term: dict[str, bool] = {}
        trunc: dict[str, bool] = {}
        slot_infos: dict[str, dict[str, Any]] = {}
        gone: list[str] = []
        for slot, agent in zip(self.possible_agents, self.slot_agents, strict=True):
            if agent is None or agent not in observations:
                if agent is not None:  # removed and reported before this step: gone
                    gone.append(agent)
                obs[slot], rew[slot], slot_infos[slot] = self._zeros(slot), 0.0, {"agent": None}
                term[slot], trunc[slot] = False, ended
                continue
            obs[slot], rew[slot] = observations[agent], float(rewards[agent])
            slot_infos[slot] = {**infos[agent], "agent": agent}
            dies = bool(terminations[agent] or truncations[agent])
            term[slot] = ended and bool(terminations[agent])
            trunc[slot] = ended and not term[slot]
            if dies:
                gone.append(agent)
        for agent in gone:
            self._free(agent)
        if ended:
            self.agents = []
        return obs, rew, term, trunc, slot_infos
