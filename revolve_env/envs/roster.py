"""The robots of one population episode by robot id: births, deaths and the physics step.

:class:`Roster` is the population env without PettingZoo's API: it owns the world, the compiled
controller of every brain, the robots' :class:`~revolve_env.envs.members.Member` records keyed
by robot id (:mod:`revolve_env.status`) and their per-step arrays
(:class:`~revolve_env.envs.living.Living`, rows in the world's order). A birth is
:meth:`Roster.admit` of a :class:`~revolve_env.envs.births.BirthPlan` decided beforehand (so
that a birth asked for between two steps could be queued and admitted at the next one); a death
is :meth:`Roster.drop`, which keeps the robot's last state for its final report
(:attr:`Roster.dead`). :meth:`Roster.act` sets every hinge target and steps the world (one
period of the world's :class:`~revolve_env.rollout.Rollout`); :meth:`Roster.sense` reads every
robot after it. World handles and controller handles stay here.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from revolve_env.body.robot import Layer
from revolve_env.brain import BatchController
from revolve_env.envs.agent_spaces import AgentSpaces
from revolve_env.envs.births import BirthPlan
from revolve_env.envs.living import Living
from revolve_env.envs.members import Final, LifeClock, Member, noise_generator
from revolve_env.envs.placement import Disc
from revolve_env.envs.population_snapshot import member_snapshot, read_snapshot
from revolve_env.fitness.terms import TIME_EPS
from revolve_env.rollout import Rollout, task_rule
from revolve_env.status import Death, agent_name, robot_id
from revolve_env.world import World, WorldConfig, compiled
from revolve_env.world.backend import SnapshotMismatchError

__all__ = ["Roster"]


def _final(member: Member) -> Final:
    assert member.final is not None  # set when it left the world
    return member.final


class Roster:
    """Every robot of a population env's episode (see the module doc).

    Args:
        config: The world's settings.
        clock: The env's clock of insertion and maturity.
        living: The per-step arrays (owned from here on).
        spaces: The agents' spaces (a newborn's are registered at its birth).
        actuator_noise: Standard deviation of the noise on every hinge target.
        sensor_noise: Standard deviation of the noise on every sensor value.
    """

    def __init__(self, config: WorldConfig, clock: LifeClock, living: Living,
                 spaces: AgentSpaces, actuator_noise: float, sensor_noise: float) -> None:
        self.config = config
        self.clock = clock
        self.living = living
        self.spaces = spaces
        self.actuator_noise = actuator_noise
        self.sensor_noise = sensor_noise
        self.run: Rollout | None = None  # the world, its brains, the period
        self.members: dict[int, Member] = {}  # the living robots, by robot id, in row order
        self.agents: list[str] = []  # their agent names, in row order
        # PettingZoo's agents: the living robots the last step (or reset) reported; they change
        # only there, so a robot added or removed between two steps enters or leaves at the next.
        self.announced: list[str] = []
        self.dead: list[tuple[Member, Death]] = []  # left since the last step, to report
        # Agents whose death the last step reported: their spaces go at the next step.
        self.reported: list[str] = []
        self.births = 0  # robots born in this episode
        self.next_id = 0  # the id of the next robot born without one
        self.steps = 0  # control periods since reset
        self.noise: np.random.Generator | None = None  # sensor and actuator noise
        # The windows' compiled push on MuJoCo (with the compiled step; None: NumPy's).
        living.kernel = compiled.windows_kernel() if config.engine == "mujoco" else None

    @property
    def world(self) -> World | None:
        """The episode's world (None before a reset and after close)."""
        return None if self.run is None else self.run.world

    @property
    def brain(self) -> BatchController | None:
        """The compiled controller of every brain robot (None: no world)."""
        return None if self.run is None else self.run.brain

    # -- episodes ---------------------------------------------------------------------------
    def reset(self, seed: int | None, reseed: bool) -> None:
        """A fresh world with no robot; the noise generator from the reset's seed if ``reseed``."""
        if reseed or self.noise is None:
            self.noise = noise_generator(seed)
        if self.world is not None:
            self.world.close()
        # Brains step every control period (the env refuses another brain period).
        self.run = Rollout(World(self.config), BatchController(self.config.control_period), 1)
        self._forget()

    def _forget(self) -> None:
        self.members, self.agents, self.dead, self.announced = {}, [], [], []
        self.reported = []
        self.living.clear()
        self.births = self.next_id = self.steps = 0

    def close(self) -> None:
        """Release the world (a reset makes a new one)."""
        if self.world is not None:
            self.world.close()
        self.run = None
        self._forget()

    @property
    def time(self) -> float:
        """Simulated time since reset. Seconds."""
        return self.steps * self.config.control_period

    def member(self, robot: int | str, what: str) -> Member:
        """A living robot by id or agent name (KeyError naming ``what`` and why not)."""
        rid = robot if isinstance(robot, int) and not isinstance(robot, bool) else None
        if isinstance(robot, str):
            try:
                rid = robot_id(robot)
            except KeyError:
                raise KeyError(f"{what}: {self.spaces.unknown(robot)}") from None
        if rid is None:
            raise KeyError(f"{what}: expected a robot id or an agent name, got {robot!r}")
        member = self.members.get(rid)
        if member is not None:
            return member
        agent = agent_name(rid)
        if self.spaces.was_born(agent):
            raise KeyError(f"{what}: agent {agent!r} is dead (removed or blown up)")
        raise KeyError(f"{what}: {self.spaces.unknown(agent)}")

    def checked_actions(self, actions: Mapping[str, ArrayLike]
                        ) -> list[tuple[Member, NDArray[np.float64]]]:
        """Every action checked before anything changes; the agent-controlled robots' targets.

        An action for a robot removed since the last step (still one of ``announced``, reported
        dead by this step) is checked and dropped.

        Raises:
            KeyError: an action for an agent neither alive nor removed since the last step;
            ValueError: a bad shape or value.
        """
        checked: list[tuple[Member, NDArray[np.float64]]] = []
        if not actions:
            return checked
        leaving = {m.agent: m for m, _ in self.dead}
        for agent, action in actions.items():
            if agent in leaving:
                self.spaces.checked_action(leaving[agent], action)
                continue
            member = self.member(agent, "action")
            a = self.spaces.checked_action(member, action)
            if member.controlled_by == "agent":
                checked.append((member, a[:member.n_outputs] if member.padded else a))
        return checked

    def release_reported(self) -> None:
        """Forget the spaces and masks of the agents whose death the last step reported.

        Called once the next step's actions are checked: until then a caller may still ask for
        the spaces of every agent of the last step's dicts.
        """
        if self.reported:
            self.spaces.release(self.reported)
            self.reported = []

    # -- births and deaths ------------------------------------------------------------------
    def occupied(self) -> tuple[list[Disc], list[str]]:
        """The living robots' footprints and agent names (row order), for a placement."""
        if not self.members:
            return [], []
        assert self.world is not None
        members = list(self.members.values())
        centres = self.world.core_positions([m.handle for m in members])
        return ([Disc(float(c[0]), float(c[1]), m.radius) for c, m in zip(centres, members,
                                                                          strict=True)],
                list(self.agents))

    def admit(self, plan: BirthPlan) -> Member:
        """Build a planned newborn in the world (last row); nothing can fail on bad input here."""
        run, world, living = self.run, self.world, self.living
        assert run is not None and world is not None and self.noise is not None
        n_outputs = len(plan.robot.neurons_of(Layer.OUTPUT))
        padded = self.spaces.is_padded(plan.agent)
        # joints: the start noise (one value per active hinge, finite)
        handle = run.add(plan.robot, plan.position, plan.yaw, network=plan.network,
                         joints=plan.joints)
        member = Member(
            robot_id=plan.robot_id, agent=plan.agent, robot=plan.robot,
            controlled_by=plan.controlled_by, handle=handle, brain=run.network(handle),
            birth_step=self.steps, birth_time=self.steps * self.clock.dt,
            birth_position=plan.position, born_inside=plan.inside, yaw=plan.yaw,
            radius=plan.radius, n_outputs=n_outputs, padded=padded, sensor_low=plan.sensor_low,
            sensor_high=plan.sensor_high,
        )
        obs = member.sense(world.read_sensors(handle), self.sensor_noise, self.noise)
        self.births += 1
        self.next_id = plan.robot_id + 1
        self.members[plan.robot_id] = member
        self.agents.append(plan.agent)
        self.spaces.register(plan.agent, plan.sensor_low, plan.sensor_high, n_outputs, padded)
        living.add(member, obs, world.core_position(handle), world)
        row = len(living) - 1
        living.trajectories.append(np.array([row]), living.position[row:row + 1])
        if self.clock.insertion_steps == 0:
            living.first_sample(row, self.time, world)
        return member

    def drop(self, member: Member, death: Death | None = None) -> None:
        """Take a robot out of the world and the arrays; keep its last state for its report.

        ``death``: report it at the next step as dead of that (None: the caller reports it).
        """
        assert self.run is not None
        living = self.living
        row = self.agents.index(member.agent)
        member.final = living.final(row)
        self.run.remove([member.handle])  # from the world and, with its network, the brains
        del self.members[member.robot_id]
        del self.agents[row]
        living.remove(row, self.run.world)
        if death is not None:
            self.dead.append((member, death))

    # -- the step ---------------------------------------------------------------------------
    def act(self, checked: list[tuple[Member, NDArray[np.float64]]]) -> None:
        """Set every hinge target (actions, then one batch step of the brains); step the world.

        Actuator noise draws robot after robot: the agents in the order of ``checked``, then
        the brain robots in birth order.
        """
        run, noise = self.run, self.noise
        assert run is not None and noise is not None
        learner = None
        if checked:
            offsets = run.world.output_offsets
            rows = run.world.rows([m.handle for m, _ in checked])
            index = np.concatenate([np.arange(offsets[r], offsets[r + 1]) for r in rows.tolist()])
            learner = (index, np.concatenate([a for _, a in checked]))
        # the brains read the sensor values as the robots read them after the last step
        run.period(self.living.obs, learner, self.actuator_noise, noise)
        self.steps += 1

    def sense(self, rewards: bool = True) -> list[Death | None]:
        """After :meth:`act`: every robot sensed and scored; the rows that blew up.

        ``rewards``: whether the step's rewards are given (:meth:`Living.sense`).

        Returns:
            One entry per row: ``"blow_up"`` for a robot whose simulation blew up in this step
            (its reason is in its member's ``blow_up``; the caller drops it after its report),
            else None.
        """
        run, living = self.run, self.living
        assert run is not None and self.noise is not None
        world = run.world
        blown = run.blown()
        living.sense(world, self.time, self.noise, self.sensor_noise, blown, rewards)
        deaths: list[Death | None] = [None] * len(living)
        if blown is not None:
            for row in np.flatnonzero(blown).tolist():
                member = living.members[row]
                member.blow_up = world.blow_up(member.handle)
                deaths[row] = "blow_up"
        return deaths

    def compiled_periods(self, n: int) -> tuple[int, bool] | None:
        """Up to ``n`` periods of :meth:`act` and :meth:`sense` in one compiled call.

        What ``n`` steps of the env with no actions and nothing between them do (:meth:`act`,
        then :meth:`sense` without rewards, every robot alive), in
        :class:`~revolve_env.world.compiled.PopulationPeriods`: every robot brain-driven, no noise,
        no trajectories, a task the compiled rule scores, on a MuJoCo world that the compiled
        step steps, with no death to report and none reported. The same numbers. It stops at a
        period that needs Python: that one is acted here and left to sense (the caller senses
        it, as a step does).

        Returns:
            The periods done whole, and whether one more has been acted and must be sensed;
            None where the compiled periods do not apply (nothing done).
        """
        run, living = self.run, self.living
        if (run is None or n < 1 or not self.members or self.dead or self.reported
                or self.actuator_noise > 0 or self.sensor_noise > 0 or not run.all_brains
                or not living.compiled_ready or run.world.any_blown_up):
            return None
        world = run.world
        step = world.compiled_step()
        ring = living.windows.ring.ring()
        if step is None or ring is None:
            return None
        c, windows = self.config, living.windows
        periods = compiled.population_periods(
            step, run.brain, world.target_scale, c.control_period, task_rule(windows.task),
            windows.window, TIME_EPS, windows.stride, windows.insertion_steps,
            self.clock.insertion_steps)
        if periods is None:
            return None
        buffers = (step.buffers(), step.buffers())
        f, v, s = living.f.copy(), living.v.copy(), living.s.copy()
        k = len(living)
        window = (np.empty(2 * k), np.empty(2 * k), np.empty(k), np.empty(k),
                  np.empty(k, dtype=np.int64), np.empty(k))
        done, stop, outcome, seq, start, started, pushed, time = periods.run(
            n, self.steps, world.time, world.compiled_targets(), run.outputs, living.obs,
            step.start, buffers[0][0], buffers[0][1], buffers[1][0], buffers[1][1], living.ages,
            ring.t, ring.xy, ring.path, ring.first, ring.last, ring.seq, ring.start, f, v, s,
            *window)
        periods.give_back()
        if pushed:
            windows.ring.pushed(seq, start, started)
        run.periods += done
        self.steps += done
        if done:
            world.compiled_advanced(step, time, buffers[(done - 1) % 2])
            living.advanced(world, f, v, s)
            self.announced = list(self.agents)
        all_done, brain, _ = periods.stops
        if stop == all_done:
            periods.raise_pending()  # Ctrl-C in the compiled call: raised with the env whole
            return done, False
        if stop == brain:  # its outputs are not finite: the world flags it as ever
            run.period(None, None, thought=True)
        else:
            world.compiled_stepped(step, *step.finished(outcome, buffers[done % 2]))
            run.periods += 1
        self.steps += 1
        return done, True

    # -- snapshots --------------------------------------------------------------------------
    def snapshot(self) -> dict[str, Any]:
        """The world, the noise generator, the counters and every robot's state (plain data)."""
        world, brain = self.world, self.brain
        assert world is not None and brain is not None
        return {
            "world": world.snapshot(),
            "noise_rng": None if self.noise is None else dict(self.noise.bit_generator.state),
            "births": self.births, "next_id": self.next_id, "steps": self.steps,
            "announced": list(self.announced),
            "members": [member_snapshot(m, self.living.final(row), brain, with_robot=False)
                        for row, m in enumerate(self.living.members)],
            "dead": [(member_snapshot(m, _final(m), None, with_robot=True), death)
                     for m, death in self.dead],
        }

    def restore(self, snapshot: dict[str, Any], seed: int | None) -> np.random.Generator:
        """Continue from :meth:`snapshot` in a fresh world; the env's generator as it was.

        Raises:
            SnapshotMismatchError: the snapshot does not fit (left closed then).
            NotImplementedError: the engine cannot restore its state exactly (pybullet).
        """
        self.close()
        restored = read_snapshot(snapshot, self.config, self.clock)
        self.run = Rollout(restored.world, restored.brain, 1)
        for m in restored.members:
            if m.brain is not None:
                self.run.adopt(m.handle, m.brain)
        # A snapshot from before the noise generator existed: the reset's one.
        self.noise = restored.noise if restored.noise is not None else noise_generator(seed)
        self.births, self.steps = restored.births, restored.steps
        self.run.periods = restored.steps
        self.next_id = int(snapshot.get("next_id", restored.births))
        self.members = {m.robot_id: m for m in restored.members}
        self.agents = [m.agent for m in restored.members]
        self.dead = restored.dead
        # A snapshot from before `announced` existed: every robot it holds was announced.
        self.announced = [str(a) for a in snapshot.get(
            "announced", [m.agent for m, _ in restored.dead] + self.agents)]
        try:
            self.spaces.restore(restored.masks, restored.spaces, restored.uniform,
                                restored.born)
            # Snapshots keep the spaces of agents reported dead by their last step (older ones:
            # of every agent born); the next step releases them.
            keep = set(self.agents) | {m.agent for m, _ in self.dead}
            self.reported = [a for a in self.spaces.masks if a not in keep]
            self.living.restore(restored.members, restored.rows, restored.world)
        except (KeyError, TypeError, ValueError) as e:
            self.close()
            raise SnapshotMismatchError(f"damaged population snapshot: {e!r}") from e
        self.run.relayout()
        return restored.rng
