"""The five dicts of a population env's step, built from the robots' typed statuses.

:func:`status_info` is the ONE place a robot's :class:`~revolve_env.status.RobotStatus` becomes
the info dict PettingZoo users read (the keys are documented on
:class:`~revolve_env.envs.population.PopulationEnv`, Info); :func:`report_step` senses every
robot after the physics and fills the five dicts, with the statuses they were made from;
:func:`end_step` does the same work without the dicts, for a caller that reads statuses only
(the evolution loop: brain-driven robots need their sensors, not dicts).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from revolve_env.envs.agent_spaces import Masks
from revolve_env.envs.living import final_status
from revolve_env.envs.roster import Roster
from revolve_env.status import RobotStatus

__all__ = ["Dicts", "end_step", "report_step", "status_info"]

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


def report_step(roster: Roster, masks: dict[str, Masks], truncate: bool
                ) -> tuple[Dicts, dict[int, RobotStatus]]:
    """After the physics: sense every robot, report it, and drop those whose life ended.

    Reported: every robot removed since the last step (once more, then never again), and every
    living robot; a robot that blew up in this step is reported terminated and dropped, and
    with ``truncate`` every living robot is reported truncated and dropped.

    Returns:
        The five dicts, and the statuses they were made from (by robot id, in report order).
    """
    living = roster.living
    obs: dict[str, NDArray[np.float64]] = {}
    rewards: dict[str, float] = {}
    terminations: dict[str, bool] = {}
    truncations: dict[str, bool] = {}
    infos: dict[str, dict[str, Any]] = {}
    statuses: dict[int, RobotStatus] = {}
    for member, death in roster.dead:  # removed since the last step: one last report
        assert member.final is not None
        status = final_status(member, roster.clock, death)
        agent = member.agent
        obs[agent] = member.final.view.copy()
        rewards[agent] = 0.0
        terminations[agent] = True
        truncations[agent] = False
        infos[agent] = status_info(status, masks[agent])
        statuses[member.robot_id] = status
    reported = [member.agent for member, _ in roster.dead]
    roster.dead = []
    deaths = roster.sense()
    agents = roster.agents
    now = living.statuses(deaths)
    obs.update(zip(agents, living.views(), strict=True))
    rewards.update(zip(agents, living.rewards.tolist(), strict=True))
    ended = [d is not None for d in deaths]
    terminations.update(zip(agents, ended, strict=True))
    truncations.update(zip(agents, [truncate and not e for e in ended], strict=True))
    infos.update(zip(agents, [status_info(s, masks[a]) for s, a in zip(now, agents, strict=True)],
                     strict=True))
    statuses.update(zip([s.robot_id for s in now], now, strict=True))
    gone = [m for m, e in zip(living.members, ended, strict=True) if e or truncate]
    for member in reversed(gone):
        roster.drop(member)
    roster.announced = list(roster.agents)
    roster.reported += reported + [m.agent for m in gone]
    return (obs, rewards, terminations, truncations, infos), statuses


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
