"""The population env's living robots as arrays: one pass over all of them per step.

:class:`Living` holds what changes every step for every living robot, one row per robot in birth
order (the env's ``agents`` and the world's rows): ages, sensor values as the robots read them
(noisy, clipped), observations in each agent's space, core positions, trajectories
(:class:`~revolve_env.envs.trajectories.TrajectoryStore`), the task's windows and fitness
(:class:`~revolve_env.rollout.TaskWindows`: one call scores every window) with its terms, and
the step's rewards. :meth:`Living.sense`
updates them all after the physics with array operations; the index arrays it uses are rebuilt
at every birth and death (:meth:`Living.relayout`). :meth:`Living.statuses` gives every robot's
typed :class:`~revolve_env.status.RobotStatus`. Per-robot Python is left to births, deaths,
snapshots and the five dicts of PettingZoo's API.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from revolve_env.conditions import add_sensor_noise
from revolve_env.envs.agent_spaces import AgentSpaces
from revolve_env.envs.members import Final, LifeClock, Member
from revolve_env.envs.observations import hinge_values
from revolve_env.envs.trajectories import TrajectoryStore
from revolve_env.fitness import Window
from revolve_env.rollout import TaskWindows
from revolve_env.status import Death, RobotStatus
from revolve_env.tasks import Task, own_reward
from revolve_env.world import World
from revolve_env.world.signals import SignalReader, signal_reader

__all__ = ["Final", "Living", "final_status"]


def _ints(values: list[int] | NDArray[np.intp]) -> NDArray[np.intp]:
    return np.asarray(values, dtype=np.intp).reshape(-1)


def final_status(m: Member, clock: LifeClock, death: Death) -> RobotStatus:
    """The last status of a robot that left the world (from its :class:`Final` record)."""
    final = m.final
    assert final is not None
    trajectory = final.trajectory.view()
    trajectory.flags.writeable = False
    age = final.age_steps
    return RobotStatus(m.robot_id, *final.terms, final.position.copy(), age, age * clock.dt,
                       age < clock.insertion_steps, age >= clock.maturity_steps, death,
                       m.blow_up, m.birth_time, m.birth_position, m.born_inside,
                       m.controlled_by, trajectory)


class Living:
    """The per-step state of every living robot (see the module doc). Rows: birth order."""

    def __init__(self, fitness_window: float, trajectory_stride: int, clock: LifeClock,
                 spaces: AgentSpaces, task: Task, trajectory_length: int | None = None) -> None:
        self.fitness_window = fitness_window
        self.stride = trajectory_stride
        self.trajectory_length = trajectory_length  # samples kept per robot (None: all)
        self.clock = clock
        self.spaces = spaces
        self.task = task
        self.members: list[Member] = []
        # TaskError: a pose rate that does not fit the control period
        self.windows = TaskWindows(task, fitness_window, clock.dt, clock.insertion_steps)
        self.signal: SignalReader | None = None  # the task's signal, for the rows now
        self.trajectories = TrajectoryStore(length=self.trajectory_length)
        self.ages = np.zeros(0, dtype=np.int64)  # control periods since birth
        # The task's fitness and the terms of every window (metres), the last step's rewards.
        self.f, self.v, self.s = np.zeros(0), np.zeros(0), np.zeros(0)
        self.rewards = np.zeros(0)
        # A user's own reward is checked at every step, its rewards read or not (the fitness
        # gain, every shipped task's, has the fitness's shape by construction).
        self._own_reward = own_reward(task)
        self.position = np.zeros((0, 3))  # last finite core positions. Metres
        self.obs = np.zeros(0)  # sensor values as the robots read them, flat (world layout)
        self.view = np.zeros(0)  # what the agents observe, flat
        # The compiled push of the windows (None: NumPy's), the same numbers.
        self.kernel: Callable[..., tuple[bool, int, int, bool]] | None = None
        self._layout()

    def __len__(self) -> int:
        return len(self.members)

    # -- births and deaths ---------------------------------------------------------------------
    def add(self, member: Member, obs: NDArray[np.float64], position: NDArray[np.float64],
            world: World) -> None:
        """A newborn (last row), with its first sensor values and core position."""
        self.members.append(member)
        self.ages = np.append(self.ages, 0)
        self.f, self.v, self.s = (np.append(a, 0.0) for a in (self.f, self.v, self.s))
        self.position = np.concatenate((self.position, position.reshape(1, 3)))
        self.obs = np.concatenate((self.obs, obs))
        self.rewards = np.append(self.rewards, 0.0)
        self.windows.add(1)
        self.trajectories.add()
        self.relayout(world)

    def final(self, row: int) -> Final:
        """A robot's last state, kept for its death report (and snapshots until then)."""
        lo, hi = self._obs_offsets[row], self._obs_offsets[row + 1]
        vlo, vhi = self._view_offsets[row], self._view_offsets[row + 1]
        return Final(
            obs=self.obs[lo:hi].copy(), view=self.view[vlo:vhi].copy(),
            position=self.position[row].copy(),
            terms=(float(self.f[row]), float(self.v[row]), float(self.s[row])),
            age_steps=int(self.ages[row]), trajectory=self.trajectories.view(row).copy(),
            trajectory_room=self.trajectories.room(row), fitness=self.windows.ring.snapshot(row))

    def remove(self, row: int, world: World) -> None:
        """Forget a robot (after the world let it go)."""
        keep = np.ones(len(self), dtype=bool)
        keep[row] = False
        entries = np.repeat(keep, np.diff(self._obs_offsets))
        del self.members[row]
        self.ages = self.ages[keep]
        self.f, self.v, self.s = self.f[keep], self.v[keep], self.s[keep]
        self.rewards = self.rewards[keep]
        self.position = self.position[keep]
        self.obs = self.obs[entries]
        self.windows.remove(keep)
        self.trajectories.remove(keep)
        self.relayout(world)

    def clear(self) -> None:
        """No robots (a reset)."""
        self.members = []
        self.windows.clear()
        self.signal = None
        self.trajectories = TrajectoryStore(length=self.trajectory_length)
        self.ages = np.zeros(0, dtype=np.int64)
        self.f, self.v, self.s = np.zeros(0), np.zeros(0), np.zeros(0)
        self.rewards = np.zeros(0)
        self.position = np.zeros((0, 3))
        self.obs = np.zeros(0)
        self.view = np.zeros(0)
        self._layout()

    def relayout(self, world: World) -> None:
        """Index arrays for the rows now, and every view from the sensor values (no physics)."""
        self._layout()
        self.view = self._views(self.obs, world, None)
        self.signal = signal_reader(self.task.signal, [m.robot for m in self.members], world)

    def _layout(self) -> None:
        spaces = self.spaces
        proprio = spaces.proprioception
        n_in = [len(m.sensor_low) for m in self.members]
        n_out = [m.n_outputs for m in self.members]
        self._obs_offsets = np.concatenate(([0], np.cumsum(n_in, dtype=np.intp)))
        self._entry_row = np.repeat(np.arange(len(self)), n_in)
        self._low = np.concatenate([m.sensor_low for m in self.members]) if n_in else np.zeros(0)
        self._high = (np.concatenate([m.sensor_high for m in self.members]) if n_in
                      else np.zeros(0))
        u_in, u_out, u_size = spaces.u_inputs, spaces.u_outputs, len(spaces.u_low)
        sizes, obs_dest, obs_lo, obs_hi, angle_dest, speed_dest = [], [], [], [], [], []
        view = 0
        for m, k, h in zip(self.members, n_in, n_out, strict=True):
            if m.padded:
                obs_dest.append(view + np.arange(k))
                obs_lo.append(spaces.u_low[:k])
                obs_hi.append(spaces.u_high[:k])
                angle_dest.append(view + u_in + np.arange(h))
                speed_dest.append(view + u_in + u_out + np.arange(h))
                size = u_size
            else:
                obs_dest.append(view + np.arange(k))
                obs_lo.append(np.full(k, -np.inf))
                obs_hi.append(np.full(k, np.inf))
                angle_dest.append(view + k + np.arange(h))
                speed_dest.append(view + k + h + np.arange(h))
                size = k + 2 * h if proprio else k
            sizes.append(size)
            view += size
        self._view_offsets = np.concatenate(([0], np.cumsum(sizes, dtype=np.intp)))
        self._view_row = np.repeat(np.arange(len(self)), sizes)
        # Exact spaces without hinge values: the view is the sensor values themselves.
        self._view_is_obs = not proprio and not any(m.padded for m in self.members)
        cat = np.concatenate
        self._obs_dest = _ints(cat(obs_dest)) if obs_dest else _ints([])
        self._obs_lo = cat(obs_lo) if obs_lo else np.zeros(0)
        self._obs_hi = cat(obs_hi) if obs_hi else np.zeros(0)
        self._angle_dest = _ints(cat(angle_dest)) if angle_dest else _ints([])
        self._speed_dest = _ints(cat(speed_dest)) if speed_dest else _ints([])
        self._starts = self._view_offsets[:-1].tolist()
        self._stops = self._view_offsets[1:].tolist()
        self._view_slices = list(map(slice, self._starts, self._stops))
        # What a reader derives from the rows' birth data once per layout (the reports' info
        # templates, :mod:`~revolve_env.envs.reports`); forgotten at every birth and death.
        self.row_cache: list[Any] | None = None

    # -- the step ------------------------------------------------------------------------------
    def _views(self, obs: NDArray[np.float64], world: World,
               blown: NDArray[np.bool_] | None) -> NDArray[np.float64]:
        """Every agent's observation from the sensor values and the world's hinges, flat."""
        if self._view_is_obs:
            view = obs
        else:
            view = np.zeros(int(self._view_offsets[-1]))
            # uniform blocks saturate the IMU at the uniform bounds; exact ones keep the values
            view[self._obs_dest] = np.minimum(np.maximum(obs, self._obs_lo), self._obs_hi)
            if self.spaces.proprioception:
                view[self._angle_dest], view[self._speed_dest] = hinge_values(world)
        if blown is not None:
            view = view.copy() if view is obs else view
            view[blown[self._view_row]] = 0.0
        return view

    def sense(self, world: World, time: float, noise: np.random.Generator, sensor_noise: float,
              blown: NDArray[np.bool_] | None, rewards: bool = True) -> None:
        """After a step: every robot's sensor values, view, position, trajectory and fitness.

        Args:
            world: The world, just stepped.
            time: Simulated time now. Seconds.
            noise: The noise generator (drawn robot after robot, in row order).
            sensor_noise: Standard deviation of the sensor noise (0: none drawn).
            blown: Rows whose simulation blew up in this step (None: none): zero values and
                fitness, last position kept, nothing recorded.
            rewards: Whether to give the step's :attr:`rewards` (False: a caller that reads
                none, :func:`~revolve_env.envs.reports.end_step`; they are stale then, unless
                the task has its own reward: that is given, and its shape checked, always).
        """
        self.ages += 1
        values = world.sensor_values()
        position = world.states.core_pos
        if blown is None:
            obs = add_sensor_noise(values, sensor_noise, noise, self._low, self._high)
            self.position = position
            due = slice(None) if self.stride == 1 else \
                np.flatnonzero(self.ages % self.stride == 0)
            sampling = self.ages >= self.clock.insertion_steps
        else:
            ok = ~blown
            entries = ok[self._entry_row]
            obs = np.zeros(values.shape)
            obs[entries] = add_sensor_noise(values[entries], sensor_noise, noise,
                                            self._low[entries], self._high[entries])
            self.position = np.where(ok[:, None], position, self.position)
            due = np.flatnonzero(ok & (self.ages % self.stride == 0))
            sampling = ok & (self.ages >= self.clock.insertion_steps)
        self.obs = obs
        self.trajectories.append(due, self.position[due])
        previous = self.f
        window: Window | None = None
        if sampling.any():
            signal = None if self.signal is None else self.signal.read(world)
            window = self.windows.push(time, self.position, self.ages, sampling, signal,
                                       self.kernel)
            self.f, self.v, self.s = self.windows.score(window), window.v, window.s
        if blown is not None:
            if self.f is previous:
                self.f = previous.copy()
            self.f[blown] = self.v[blown] = self.s[blown] = 0.0
        if rewards or self._own_reward:
            self.rewards = self._rewards(window, previous)
        self.view = self._views(obs, world, blown)

    @property
    def compiled_ready(self) -> bool:
        """Whether compiled periods can sense these robots (the compiled push, no signal).

        And no trajectories (:meth:`Roster.compiled_periods
        <revolve_env.envs.roster.Roster.compiled_periods>` keeps none).
        """
        return (self.kernel is not None and self.task.signal is None
                and self.trajectories.length == 0)

    def advanced(self, world: World, f: NDArray[np.float64], v: NDArray[np.float64],
                 s: NDArray[np.float64]) -> None:
        """After periods sensed in compiled code (ages and windows written in place there).

        What :meth:`sense` leaves after the last of them, none blown up, without noise:
        ``f``, ``v`` and ``s`` are every robot's task fitness and terms then.
        """
        self.obs = world.sensor_values()
        self.position = world.states.core_pos
        self.f, self.v, self.s = f, v, s
        self.view = self._views(self.obs, world, None)

    def _rewards(self, window: Window | None, previous: NDArray[np.float64]
                 ) -> NDArray[np.float64]:
        """Every robot's reward for the step: the task's, from its fitness after and before."""
        if window is None:
            window = self.windows.ring.current()
        rewards = np.asarray(self.task.reward(window, self.f, previous), dtype=np.float64)
        if rewards.shape != self.f.shape:
            raise ValueError(f"task {self.task.name!r}: reward(...) must give shape "
                             f"{self.f.shape}, got {rewards.shape}")
        return rewards

    def first_sample(self, row: int, time: float, world: World) -> None:
        """A newborn's first fitness sample at its birth (when there is no insertion phase)."""
        sampling = np.zeros(len(self), dtype=bool)
        sampling[row] = True
        signal = None if self.signal is None else self.signal.read(world)
        self.windows.ring.push(time, self.position, sampling, signal)

    # -- reading -------------------------------------------------------------------------------
    def views(self) -> list[NDArray[np.float64]]:
        """Every agent's observation: slices of one fresh copy (the env's stay its own)."""
        return list(map(self.view.copy().__getitem__, self._view_slices))

    def view_spans(self) -> tuple[NDArray[np.float64], NDArray[np.intp], NDArray[np.intp]]:
        """What :meth:`views` slices: a fresh copy of the view, and every agent's start and stop."""
        return self.view.copy(), self._view_offsets[:-1], self._view_offsets[1:]

    def view_of(self, row: int) -> NDArray[np.float64]:
        """One agent's observation (a copy)."""
        return self.view[self._starts[row]:self._stops[row]].copy()

    def obs_of(self, row: int) -> NDArray[np.float64]:
        """One robot's sensor values as its brain reads them (a copy)."""
        return self.obs[self._obs_offsets[row]:self._obs_offsets[row + 1]].copy()

    def statuses(self, deaths: list[Death | None] | None = None) -> list[RobotStatus]:
        """Every living robot's status, in row order (``deaths``: one per row, None: none)."""
        clock, ages = self.clock, self.ages
        members = self.members
        n = len(members)
        return list(map(RobotStatus._make, zip(
            [m.robot_id for m in members], self.f.tolist(), self.v.tolist(), self.s.tolist(),
            list(self.position.copy()), ages.tolist(), (ages * clock.dt).tolist(),
            (ages < clock.insertion_steps).tolist(), (ages >= clock.maturity_steps).tolist(),
            deaths if deaths is not None else [None] * n, [m.blow_up for m in members],
            [m.birth_time for m in members], [m.birth_position for m in members],
            [m.born_inside for m in members], [m.controlled_by for m in members],
            self.trajectories.views(), strict=True)))

    def status(self, row: int) -> RobotStatus:
        """One living robot's status (as :meth:`statuses` gives it)."""
        m, clock, age = self.members[row], self.clock, int(self.ages[row])
        return RobotStatus(m.robot_id, float(self.f[row]), float(self.v[row]),
                           float(self.s[row]), self.position[row].copy(), age, age * clock.dt,
                           age < clock.insertion_steps, age >= clock.maturity_steps, None,
                           m.blow_up, m.birth_time, m.birth_position, m.born_inside,
                           m.controlled_by, self.trajectories.view(row))

    def brain_inputs(self, rows: NDArray[np.intp]) -> NDArray[np.intp]:
        """Entries of :attr:`obs` of the robots in ``rows``, one robot after the other."""
        parts = [np.arange(self._obs_offsets[r], self._obs_offsets[r + 1]) for r in rows.tolist()]
        return _ints(np.concatenate(parts)) if parts else _ints([])

    # -- snapshots -----------------------------------------------------------------------------
    def restore(self, members: list[Member], rows: list[dict[str, Any]], world: World) -> None:
        """Rows back from member snapshots (``population_snapshot.member_snapshot``)."""
        self.clear()
        self.members = list(members)
        k = len(members)
        self.ages = np.array([int(e["age_steps"]) for e in rows], dtype=np.int64)
        terms = np.array([[float(x) for x in e["terms"]] for e in rows]).reshape(k, 3)
        self.f, self.v, self.s = (terms[:, i].copy() for i in range(3))
        self.rewards = np.zeros(k)
        self.position = np.array([e["position"] for e in rows], dtype=np.float64).reshape(k, 3)
        self.obs = (np.concatenate([np.asarray(e["obs"], dtype=np.float64) for e in rows])
                    if rows else np.zeros(0))
        self.windows.add(k)
        self.windows.ring.restore([e["fitness"] for e in rows])
        for e in rows:
            trajectory = np.asarray(e["trajectory"], dtype=np.float64).reshape(-1, 3)
            self.trajectories.add(trajectory, int(e["trajectory_capacity"]))
        self._layout()
        self.view = (np.concatenate([np.asarray(e["view"], dtype=np.float64) for e in rows])
                     if rows else np.zeros(0))
        if self.view.shape[0] != int(self._view_offsets[-1]):
            raise ValueError("the snapshot's observations do not fit its robots' spaces")
        self.signal = signal_reader(self.task.signal, [m.robot for m in self.members], world)
