"""The population env's agent spaces and masks, ``space_mode`` exact or uniform.

Every agent ``robot_<n>`` of the pool has an observation and an action space at any time: its
body's own (exact) or the uniform ones sized by the limits, whose values are padded; masks say
which entries are the robot's. The layout and bounds are documented on
:class:`revolve_env.envs.population.PopulationEnv` (Spaces); values are in the sensors' units,
hinge angles in radians and velocities in radians per second.

A dead agent's exact spaces and masks are released (:meth:`AgentSpaces.release`) once the step
that reported its death is over, so a long episode keeps those of the living robots only; which
agents were born is one byte per agent of the pool, made with it.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from revolve_env.body.validate import Limits
from revolve_env.envs.members import Member
from revolve_env.envs.observations import proprio_bounds, uniform_sensor_bounds
from revolve_env.status import robot_id
from revolve_env.world import WorldConfig

__all__ = ["AgentSpaces", "Masks", "SpaceMode"]

SpaceMode = Literal["exact", "uniform"]
Masks = tuple[NDArray[np.bool_], NDArray[np.bool_]]
"""(observation mask, action mask): True where an entry is the robot's own."""


class AgentSpaces:
    """The spaces and masks of a pool of ``max_births`` agents (the env owns one)."""

    def __init__(self, max_births: int, mode: SpaceMode, proprioception: bool,
                 limits: Limits | None, config: WorldConfig) -> None:
        self.max_births = max_births
        self.mode: SpaceMode = mode
        self.proprioception = proprioception
        self.config = config
        # The uniform layout: sensor block, then (with proprioception) angle and velocity blocks.
        sizes = limits if limits is not None else Limits()
        self.u_inputs, self.u_outputs = sizes.max_inputs, sizes.max_outputs
        u_low, u_high = uniform_sensor_bounds(self.u_inputs)
        if proprioception:
            p_low, p_high = proprio_bounds(self.u_outputs, config)
            u_low, u_high = np.concatenate((u_low, p_low)), np.concatenate((u_high, p_high))
        self.u_low, self.u_high = u_low, u_high
        self.possible_agents: list[str] = [f"robot_{n}" for n in range(max_births)]
        self._possible = frozenset(self.possible_agents)
        # Exact spaces of the robots born in this episode (their body's sizes).
        self.obs_spaces: dict[str, spaces.Box] = {}
        self.act_spaces: dict[str, spaces.Box] = {}
        # Uniform spaces handed out, for the env's lifetime (they fit any body).
        self.uniform_spaces: dict[str, tuple[spaces.Box, spaces.Box]] = {}
        # Masks (observation, action) of the robots born in this episode and not yet released.
        self.masks: dict[str, Masks] = {}
        self.born = bytearray(max_births)  # 1 for every agent born in this episode

    def reset(self) -> None:
        """Forget the episode's exact spaces and masks (the uniform spaces stay)."""
        self.obs_spaces = {}
        self.act_spaces = {}
        self.masks = {}
        self.born = bytearray(self.max_births)

    def release(self, agents: list[str]) -> None:
        """Forget the exact spaces and masks of dead agents whose death was reported.

        Their uniform spaces, if any were handed out, stay for the env's lifetime (a wrapper may
        hold them, and the name returns after a reset).
        """
        for agent in agents:
            self.obs_spaces.pop(agent, None)
            self.act_spaces.pop(agent, None)
            self.masks.pop(agent, None)

    def was_born(self, agent: str) -> bool:
        """Whether ``agent`` was born in this episode, alive or dead (False: not of the pool)."""
        if agent not in self._possible:
            return False
        return bool(self.born[robot_id(agent)])

    def observation_space(self, agent: str) -> spaces.Box:
        """The agent's exact observation space, else its uniform one (KeyError: unknown)."""
        space = self.obs_spaces.get(agent)
        return space if space is not None else self.uniform(agent)[0]

    def action_space(self, agent: str) -> spaces.Box:
        """The agent's exact action space, else its uniform one (KeyError: unknown)."""
        space = self.act_spaces.get(agent)
        return space if space is not None else self.uniform(agent)[1]

    def uniform(self, agent: str) -> tuple[spaces.Box, spaces.Box]:
        """The agent's uniform spaces, made on first request and kept for the env's lifetime.

        KeyError for an agent not of the pool, and for a dead agent whose exact spaces were
        released (it never had uniform ones: handing some out now would change its space).
        """
        pair = self.uniform_spaces.get(agent)
        if pair is None:
            if agent not in self._possible:
                raise KeyError(self.unknown(agent))
            if self.mode == "exact" and self.was_born(agent):
                raise KeyError(f"agent {agent!r} is dead: its spaces were released at the step "
                               "after the one that reported its death")
            pair = (spaces.Box(self.u_low, self.u_high, dtype=np.float64),
                    spaces.Box(-1.0, 1.0, (self.u_outputs,), dtype=np.float32))
            self.uniform_spaces[agent] = pair
        return pair

    def mask(self, agent: str, what: str) -> Masks:
        """The masks of an agent born in this episode (KeyError naming ``what`` otherwise)."""
        try:
            return self.masks[agent]
        except KeyError:
            raise KeyError(f"{what}: {self.unknown(agent)}") from None

    def unknown(self, agent: str) -> str:
        """Why ``agent`` has no masks: released, not yet born, or not one of the pool."""
        if self.was_born(agent):
            return f"agent {agent!r} is dead (its spaces and masks are released)"
        if agent in self._possible:
            return f"agent {agent!r} has not been born in this episode"
        return f"unknown agent {agent!r} (ids are robot_0 .. robot_{self.max_births - 1})"

    def is_padded(self, agent: str) -> bool:
        """Whether a newborn ``agent`` is observed and driven through the uniform spaces.

        A future agent's body is unknown: one whose spaces were handed out before its birth
        keeps the uniform ones (exact mode), as every agent does in uniform mode.
        """
        return self.mode == "uniform" or agent in self.uniform_spaces

    def register(self, agent: str, sensor_low: NDArray[np.float64],
                 sensor_high: NDArray[np.float64], n_outputs: int, padded: bool) -> None:
        """Give a newborn its exact spaces (unless padded) and its read-only masks."""
        self.born[robot_id(agent)] = 1
        low, high = sensor_low, sensor_high
        if padded:
            ones = np.ones(2 * n_outputs) if self.proprioception else None
            obs_mask = self.padded(np.ones(len(low)), n_outputs, ones) > 0
            act_mask = np.arange(self.u_outputs) < n_outputs
        else:
            if self.proprioception:
                p_low, p_high = proprio_bounds(n_outputs, self.config)
                low, high = np.concatenate((low, p_low)), np.concatenate((high, p_high))
            self.obs_spaces[agent] = spaces.Box(low, high, dtype=np.float64)
            self.act_spaces[agent] = spaces.Box(-1.0, 1.0, (n_outputs,), dtype=np.float32)
            obs_mask, act_mask = np.ones(len(low), bool), np.ones(n_outputs, bool)
        obs_mask.flags.writeable = False
        act_mask.flags.writeable = False
        self.masks[agent] = (obs_mask, act_mask)

    def padded(self, sensors: NDArray[np.float64], n_hinges: int,
               proprio: NDArray[np.float64] | None) -> NDArray[np.float64]:
        """Sensor values (and angles then velocities of ``n_hinges``) laid out uniformly.

        The IMU saturates at the uniform bounds (finite, unlike the raw readings).
        """
        out = np.zeros(len(self.u_low))
        k = len(sensors)
        out[:k] = np.minimum(np.maximum(sensors, self.u_low[:k]), self.u_high[:k])
        if proprio is not None:
            u_in, u_out = self.u_inputs, self.u_outputs
            out[u_in:u_in + n_hinges] = proprio[:n_hinges]
            out[u_in + u_out:u_in + u_out + n_hinges] = proprio[n_hinges:]
        return out

    def checked_action(self, member: Member, action: Any) -> NDArray[np.float64]:
        """The action for ``member`` as float64, its shape and values checked (ValueError)."""
        agent = member.agent
        a = np.asarray(action, dtype=np.float64)
        n = member.n_outputs
        shape = (self.u_outputs,) if member.padded else (n,)
        if a.shape != shape:
            layout = (f" (the uniform action space: its first {n} entries drive its {n} "
                      "active hinges, the rest are ignored)" if member.padded else "")
            raise ValueError(f"action for {agent!r} must have shape {shape}{layout}, got "
                             f"{a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"action for {agent!r} contains NaN or infinity: {a}")
        return a

    # -- snapshots -------------------------------------------------------------------------------
    def snapshot(self) -> dict[str, Any]:
        """The masks, exact spaces, uniform agents and births, as plain data."""
        return {
            "masks": {a: (o.copy(), act.copy()) for a, (o, act) in self.masks.items()},
            "spaces": {a: (self.obs_spaces[a].low, self.obs_spaces[a].high,
                           int(self.act_spaces[a].shape[0])) for a in self.obs_spaces},
            "uniform": sorted(self.uniform_spaces),
            "born": bytes(self.born),
        }

    def restore(self, masks: dict[str, Masks],
                exact: dict[str, tuple[NDArray[np.float64], NDArray[np.float64], int]],
                uniform: list[str], born: bytes | None = None) -> None:
        """Take back what :meth:`snapshot` gave (already read into arrays).

        ``born`` None (a snapshot from before it was kept): every agent with masks, as those
        snapshots kept the masks of every robot born.
        """
        if born is None:
            self.born = bytearray(self.max_births)
            for agent in masks:
                n = robot_id(agent)
                if n >= self.max_births:
                    raise ValueError(f"the snapshot's agent {agent!r} is not of the pool")
                self.born[n] = 1
        elif len(born) != self.max_births:
            raise ValueError(f"the snapshot's births are for {len(born)} agents, not "
                             f"max_births={self.max_births}")
        else:
            self.born = bytearray(born)
        for mask in masks.values():
            mask[0].flags.writeable = False
            mask[1].flags.writeable = False
        self.masks = masks
        self.obs_spaces = {a: spaces.Box(low, high, dtype=np.float64)
                           for a, (low, high, _) in exact.items()}
        self.act_spaces = {a: spaces.Box(-1.0, 1.0, (n,), dtype=np.float32)
                           for a, (_, _, n) in exact.items()}
        for agent in uniform:
            self.uniform(agent)
