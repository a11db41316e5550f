"""The population env's five dicts and statuses as main built them before the bulk build (6d215cc).

The reference of ``tests/envs/test_population_dicts.py`` (the env's dicts must equal these) and
of ``benchmarks/bench_population_dicts.py`` (what the bulk build saves): ``report_step``,
``status_info`` and ``Living.statuses`` as they were, one robot status after the other.

Usage::

    from population_dicts_reference import old_info, old_report, old_statuses
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from revolve_env.envs.agent_spaces import Masks
from revolve_env.envs.living import Living, final_status
from revolve_env.envs.reports import Dicts
from revolve_env.envs.roster import Roster
from revolve_env.status import Death, RobotStatus


def old_statuses(living: Living, deaths: list[Death | None] | None = None) -> list[RobotStatus]:
    """``Living.statuses`` as it was: every living robot's status, in row order."""
    clock, ages = living.clock, living.ages
    members = living.members
    n = len(members)
    return list(map(RobotStatus._make, zip(
        [m.robot_id for m in members], living.f.tolist(), living.v.tolist(), living.s.tolist(),
        list(living.position.copy()), ages.tolist(), (ages * clock.dt).tolist(),
        (ages < clock.insertion_steps).tolist(), (ages >= clock.maturity_steps).tolist(),
        deaths if deaths is not None else [None] * n, [m.blow_up for m in members],
        [m.birth_time for m in members], [m.birth_position for m in members],
        [m.born_inside for m in members], [m.controlled_by for m in members],
        living.trajectories.views(), strict=True)))


def old_info(s: RobotStatus, masks: Masks) -> dict[str, Any]:
    """``status_info`` as it was."""
    return {
        "robot_id": s.robot_id, "age": s.age, "birth_time": s.birth_time,
        "birth_position": s.birth_position, "born_inside_disc": s.born_inside,
        "inserting": s.inserting, "is_mature": s.mature, "fitness": s.fitness,
        "fitness_v": s.v, "fitness_s": s.s, "position": s.position, "trajectory": s.trajectory,
        "controlled_by": s.controlled_by, "blow_up": s.blow_up, "death": s.death,
        "obs_mask": masks[0], "act_mask": masks[1],
    }


def old_report_step(roster: Roster, masks: dict[str, Masks], truncate: bool
                     ) -> tuple[Dicts, dict[int, RobotStatus]]:
    """``report_step`` as it was (main, 6d215cc)."""
    living = roster.living
    obs: dict[str, Any] = {}
    rewards: dict[str, float] = {}
    terminations: dict[str, bool] = {}
    truncations: dict[str, bool] = {}
    infos: dict[str, dict[str, Any]] = {}
    statuses: dict[int, RobotStatus] = {}
    for member, death in roster.dead:
        assert member.final is not None
        status = final_status(member, roster.clock, death)
        agent = member.agent
        obs[agent] = member.final.view.copy()
        rewards[agent] = 0.0
        terminations[agent] = True
        truncations[agent] = False
        infos[agent] = old_info(status, masks[agent])
        statuses[member.robot_id] = status
    reported = [member.agent for member, _ in roster.dead]
    roster.dead = []
    deaths = roster.sense()
    agents = roster.agents
    now = old_statuses(living, deaths)
    obs.update(zip(agents, living.views(), strict=True))
    rewards.update(zip(agents, living.rewards.tolist(), strict=True))
    ended = [d is not None for d in deaths]
    terminations.update(zip(agents, ended, strict=True))
    truncations.update(zip(agents, [truncate and not e for e in ended], strict=True))
    infos.update(zip(agents, [old_info(s, masks[a]) for s, a in zip(now, agents, strict=True)],
                     strict=True))
    statuses.update(zip([s.robot_id for s in now], now, strict=True))
    gone = [m for m, e in zip(living.members, ended, strict=True) if e or truncate]
    for member in reversed(gone):
        roster.drop(member)
    roster.announced = list(roster.agents)
    roster.reported += reported + [m.agent for m in gone]
    return (obs, rewards, terminations, truncations, infos), statuses


def old_report(roster: Roster, masks: dict[str, Masks], truncate: bool
                ) -> tuple[Dicts, Callable[[], dict[int, RobotStatus]]]:
    """``old_report_step`` in the env's place: its statuses as the env asks for them now."""
    dicts, statuses = old_report_step(roster, masks, truncate)
    return dicts, lambda: statuses
