"""The five dicts of a population env's step, built from the robots' typed statuses.

:func:`status_info` is the ONE place a robot's :class:`~revolve_env.status.RobotStatus` becomes
the info dict PettingZoo users read (the keys are documented on
:class:`~revolve_env.envs.population.PopulationEnv`, Info); :func:`report_step` senses every
robot after the physics and fills the five dicts in bulk from the step's arrays (a living
robot's info is its template, made by :func:`status_info` at a birth or death, with the values
that change in a life written in), with the statuses they were made from, assembled when first
read (:class:`StepStatuses`); :func:`end_step` does the same work without the dicts, for a
caller that reads statuses only (the evolution loop: brain-driven robots need their sensors,
not dicts).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from revolve_env import _controller
from revolve_env.envs.agent_spaces import Masks
from revolve_env.envs.living import final_status
from revolve_env.envs.members import Member
from revolve_env.envs.roster import Roster
from revolve_env.status import RobotStatus

__all__ = ["Dicts", "StepStatuses", "end_step", "report_step", "status_info"]

Dicts = tuple[dict[str, NDArray[np.float64]], dict[str, float], dict[str, bool],
              dict[str, bool], dict[str, dict[str, Any]]]
"""The five dicts of a step: observations, rewards, terminations, truncations, infos."""


def status_info(s: RobotStatus, masks: Masks) -> dict[str, Any]:
    """A robot's info dict: its status under PettingZoo's names, and its masks."""
    return {
        "robot_id": s.robot_id, "age": s.age, "birth_time": s.birth_time,
        "birth_position": s.birth_position, "born_inside_disc": s.born_inside,
        "inserting": s.inserting, "is_mature": s.mature, "fitness": s.fitness,
        "fitness_v": s.v, "fitness_s": s.s, "position": s.position, "trajectory": s.trajectory,
        "controlled_by": s.controlled_by, "blow_up": s.blow_up, "death": s.death,
        "obs_mask": masks[0], "act_mask": masks[1],
    }


_LIFE = ("age", "inserting", "is_mature", "fitness", "fitness_v", "fitness_s", "position",
         "trajectory", "blow_up", "death")
"""The info keys whose values change during a life (the others are set at birth)."""

_PERIOD = _LIFE[:8]
"""The info keys every step writes in (death and blow_up only in a step where a life ends)."""


def _template(s: RobotStatus, masks: Masks) -> dict[str, Any]:
    """A robot's info with the values of its birth, the others None (a step writes them in)."""
    info = status_info(s, masks)
    info.update(dict.fromkeys(_LIFE, None))
    return info


class StepStatuses(NamedTuple):
    """The statuses a step's report was made from, assembled when called (first read).

    Attributes:
        final: The statuses of the robots removed before the step, in report order.
        members: The robots living in the step, in row order.
        columns: Their values, in row order: age (seconds), inserting, mature, fitness, v, s,
            position, trajectory, age_steps, death, blow_up.
    """

    final: dict[int, RobotStatus]
    members: list[Member]
    columns: tuple[list[Any], ...]

    def __call__(self) -> dict[int, RobotStatus]:
        """Every reported robot's status, by robot id, in report order."""
        members = self.members
        age, inserting, mature, f, v, s, position, trajectory, age_steps, death, blow_up = \
            self.columns
        ids = [m.robot_id for m in members]
        now = map(RobotStatus._make, zip(
            ids, f, v, s, position, age_steps, age, inserting, mature, death, blow_up,
            [m.birth_time for m in members], [m.birth_position for m in members],
            [m.born_inside for m in members], [m.controlled_by for m in members], trajectory,
            strict=True))
        return {**self.final, **dict(zip(ids, now, strict=True))}


def report_step(roster: Roster, masks: dict[str, Masks], truncate: bool
                ) -> tuple[Dicts, StepStatuses]:
    """After the physics: sense every robot, report it, and drop those whose life ended.

    Reported: every robot removed since the last step (once more, then never again), and every
    living robot; a robot that blew up in this step is reported terminated and dropped, and
    with ``truncate`` every living robot is reported truncated and dropped.

    The living robots' dicts are built in bulk, from the step's arrays, in one compiled call
    (``_controller.step_reports``): each info is a copy of its robot's template
    (:func:`status_info` of its status, made once per birth or death) with the values that
    change in a life written in, each observation a slice of one fresh copy; the statuses are
    made when first asked for, from the same values (most callers of ``step`` read the dicts
    only).

    Returns:
        The five dicts, and the statuses they were made from (by robot id, in report order),
        assembled when called.
    """
    living = roster.living
    obs: dict[str, NDArray[np.float64]] = {}
    rewards: dict[str, float] = {}
    terminations: dict[str, bool] = {}
    truncations: dict[str, bool] = {}
    infos: dict[str, dict[str, Any]] = {}
    final: dict[int, RobotStatus] = {}
    for member, death in roster.dead:  # removed since the last step: one last report
        assert member.final is not None
        status = final_status(member, roster.clock, death)
        agent = member.agent
        obs[agent] = member.final.view.copy()
        rewards[agent] = 0.0
        terminations[agent] = True
        truncations[agent] = False
        infos[agent] = status_info(status, masks[agent])
        final[member.robot_id] = status
    reported = [member.agent for member, _ in roster.dead]
    roster.dead = []
    deaths = roster.sense()
    agents, members, n = roster.agents, list(living.members), len(living)
    templates = living.row_cache
    if templates is None:  # a birth or a death since the last step
        templates = living.row_cache = [_template(living.status(row), masks[agent])
                                        for row, agent in enumerate(agents)]
    clock = living.clock
    # The living agents' observations, rewards and infos, and the status columns, in one
    # compiled call (controller_cpp/src/reports.cpp): what a loop over the agents made here.
    obs_now, rewards_now, infos_now, life = _controller.step_reports(
        agents, templates, _PERIOD, living.ages, clock.dt, clock.insertion_steps,
        clock.maturity_steps, living.f, living.v, living.s, living.rewards,
        living.position.copy(), *living.trajectories.spans(), *living.view_spans())
    blow_ups = [m.blow_up for m in members]
    alive = deaths.count(None) == n
    if not alive or blow_ups.count(None) < n:
        for info, why, blow_up in zip(infos_now.values(), deaths, blow_ups, strict=True):
            info["death"], info["blow_up"] = why, blow_up
    if alive:
        ended = dict.fromkeys(agents, False)
        cut = dict.fromkeys(agents, truncate)
        gone = members if truncate else []
    else:
        dead = [d is not None for d in deaths]
        ended = dict(zip(agents, dead, strict=True))
        cut = dict(zip(agents, [truncate and not e for e in dead], strict=True))
        gone = [m for m, e in zip(members, dead, strict=True) if e or truncate]
    dicts: Dicts = (obs_now, rewards_now, ended, cut, infos_now)
    if final:  # the robots removed before the step come first
        dicts = ({**obs, **dicts[0]}, {**rewards, **dicts[1]}, {**terminations, **dicts[2]},
                 {**truncations, **dicts[3]}, {**infos, **dicts[4]})
    statuses = StepStatuses(final, members, (*life, deaths, blow_ups))
    for member in reversed(gone):
        roster.drop(member)
    roster.announced = list(roster.agents)
    roster.reported += reported + [m.agent for m in gone]
    return dicts, statuses


def end_step(roster: Roster, truncate: bool) -> dict[int, RobotStatus]:
    """:func:`report_step` without the five dicts: the statuses of the lives that ended.

    The same work on the robots (sensed, scored, dropped, reported dead once) as
    :func:`report_step`; only the robots whose life ended are given a status: every robot
    removed since the last step, every robot that blew up in this step and, with
    ``truncate``, every living robot.

    Returns:
        Their statuses by robot id, in report order (as :func:`report_step`'s).
    """
    living = roster.living
    statuses = {member.robot_id: final_status(member, roster.clock, death)
                for member, death in roster.dead}
    reported = [member.agent for member, _ in roster.dead]
    roster.dead = []
    deaths = roster.sense(rewards=False)  # rewards: nobody reads them here
    gone = []
    if truncate or deaths.count(None) < len(deaths):  # some life ended
        for row, (member, death) in enumerate(zip(living.members, deaths, strict=True)):
            if death is not None or truncate:
                statuses[member.robot_id] = living.status(row)._replace(death=death)
                gone.append(member)
    for member in reversed(gone):
        roster.drop(member)
    roster.announced = list(roster.agents)
    roster.reported += reported + [m.agent for m in gone]
    return statuses
