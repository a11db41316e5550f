"""A population env's births up to the world: checks, placement, heading, ``reset``'s robots.

:func:`plan_birth` decides a birth in full before anything changes: the robot is checked, its
footprint placed (:mod:`revolve_env.envs.placement`), its heading drawn, and the result is a
:class:`BirthPlan` that the env then admits into its world. A birth is refused (``ValueError``,
or ``TypeError`` for a non-robot) before anything changes, naming the agent it would have been;
positions are ``(x, y)`` in metres, headings in radians.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.examples import EXAMPLES
from revolve_env.body.robot import Layer, Robot
from revolve_env.body.validate import Limits, validate
from revolve_env.brain.spec import NetworkSpec
from revolve_env.conditions import EvaluationConditions
from revolve_env.envs.members import Controller, sensor_bounds
from revolve_env.envs.placement import Disc, clash, footprint_radius, place
from revolve_env.terrain import Flat, Terrain, TerrainError

__all__ = ["BirthPlan", "BirthRules", "check_birth", "initial_births", "jittered",
           "next_robot_id", "plan_birth"]

INITIAL_KEYS = frozenset({"robot", "position", "controlled_by", "yaw"})
"""The keys of a mapping among ``reset``'s robots (``robot`` required)."""


def next_robot_id(next_id: int, robot_id: int | None, max_births: int) -> int:
    """The id of a newborn: ``robot_id`` if given (checked), else ``next_id``.

    Ids never repeat and only grow: a given id must be at least ``next_id`` (one more than the
    last id of the episode) and below ``max_births`` (the pool of agents).

    Raises:
        ValueError: naming the bad id; nothing changes then.
    """
    rid = next_id if robot_id is None else robot_id
    if not isinstance(rid, (int, np.integer)) or isinstance(rid, bool):
        raise ValueError(f"add_robot: robot_id must be an integer, got {rid!r}")
    rid = int(rid)
    if rid < next_id:
        raise ValueError(f"add_robot: robot_id {rid} is used or below the last one (ids never "
                         f"repeat; the next free one is {next_id})")
    if rid >= max_births:
        if robot_id is None:
            raise ValueError(f"cannot add a robot: max_births={max_births} births already "
                             "happened in this episode (raise max_births)")
        raise ValueError(f"add_robot: robot_id {rid} is not below max_births={max_births}")
    return rid


def check_birth(
    agent: str, robot: Robot, position: tuple[float, float] | None, controlled_by: str,
    yaw: float | None, limits: Limits | None,
) -> tuple[NetworkSpec | None, NDArray[np.float64], NDArray[np.float64]]:
    """Refuse a bad birth, naming the agent; its network (brain-controlled) and sensor bounds."""
    if controlled_by not in ("brain", "agent"):
        raise ValueError(f"add_robot ({agent}): controlled_by must be 'brain' or 'agent', "
                         f"got {controlled_by!r}")
    if not isinstance(robot, Robot):
        raise TypeError(f"add_robot ({agent}): expected a Robot, got {type(robot).__name__}")
    try:
        validate(robot, limits)
    except ValueError as e:
        raise ValueError(f"add_robot ({agent}): invalid robot: {e}") from e
    if yaw is not None and not math.isfinite(float(yaw)):
        raise ValueError(f"add_robot ({agent}): yaw must be finite, got {yaw!r}")
    if position is not None and len(position) != 2:
        raise ValueError(f"add_robot ({agent}): position must be (x, y), got {position!r}")
    low, high = sensor_bounds(robot)
    spec: NetworkSpec | None = None
    if controlled_by == "brain":
        try:
            spec = NetworkSpec.from_robot(robot)
        except ValueError as e:
            raise ValueError(f"add_robot ({agent}): invalid network: {e}") from e
        if spec.n_inputs != len(low):
            raise ValueError(f"add_robot ({agent}): the network has {spec.n_inputs} input "
                             f"neurons but the body has {len(low)} sensor values")
    return spec, low, high


def jittered(xy: tuple[float, float], jitter: float,
             rng: np.random.Generator) -> tuple[float, float]:
    """``xy`` moved to a point drawn uniformly from the disc of radius ``jitter`` around it.

    The draw of :meth:`EvaluationConditions.start` (metres), so that a requested birth position
    is jittered as an offline start is; nothing is drawn for ``jitter == 0``.
    """
    return EvaluationConditions(position_jitter=jitter).start(rng, xy).position


def initial_births(options: Mapping[str, Any] | None,
                   initial_robots: Iterable[Robot | Mapping[str, Any]] | None
                   ) -> Iterator[dict[str, Any]]:
    """The keyword arguments of ``add_robot`` for each of ``reset``'s robots, checked lazily.

    The robots are ``options["robots"]`` if given, else ``initial_robots``, else one of each
    example robot. Each entry is a ``Robot`` or a mapping with keys ``robot`` and optional
    ``position``, ``controlled_by``, ``yaw``; a bad one raises when it is reached (earlier ones
    were added).
    """
    entries: Iterable[Robot | Mapping[str, Any]]
    if options is not None and "robots" in options:
        entries = options["robots"]
    elif initial_robots is not None:
        entries = initial_robots
    else:
        entries = [make() for make in EXAMPLES.values()]
    for k, entry in enumerate(entries):
        if isinstance(entry, Robot):
            yield {"robot": entry}
        elif isinstance(entry, Mapping):
            unknown = set(entry) - INITIAL_KEYS
            if unknown or "robot" not in entry:
                raise ValueError(f"initial robot {k}: expected a Robot or a mapping with keys "
                                 f"'robot' and optional 'position', 'controlled_by', 'yaw'; "
                                 f"got keys {sorted(entry)}")
            yield {"robot": entry["robot"], "position": entry.get("position"),
                   "controlled_by": entry.get("controlled_by", "brain"), "yaw": entry.get("yaw")}
        else:
            raise TypeError(f"initial robot {k}: expected a Robot or a mapping, got "
                            f"{type(entry).__name__}")


@dataclass(frozen=True)
class BirthRules:
    """Where and how a population env's newborns are placed (its constructor's arguments).

    Attributes:
        birth_radius: Random births lie within this distance of the origin. Metres.
        clearance: Gap kept between footprints at birth. Metres.
        tries: Random draws in the birth disc before placing outside it.
        conditions: Heading and position jitter of newborns.
        limits: Validation limits.
        terrain: The ground: a newborn's footprint must lie on it.
    """

    birth_radius: float
    clearance: float
    tries: int
    conditions: EvaluationConditions
    limits: Limits | None
    terrain: Terrain = field(default_factory=Flat)


@dataclass(frozen=True)
class BirthPlan:
    """A birth decided in full: everything the env needs to admit the robot into its world.

    Attributes:
        robot_id: The newborn's id.
        agent: Its agent name (for messages).
        robot: Its body and network.
        controlled_by: ``"brain"`` or ``"agent"``.
        network: Its network (brain-controlled robots), else None.
        sensor_low: Lower bounds of its sensor values.
        sensor_high: Upper bounds of its sensor values.
        position: Core ``(x, y)``. Metres.
        inside: Whether it lies in the birth disc.
        yaw: Heading. Radians.
        radius: Footprint radius. Metres.
        joints: Its active hinges' start angles (radians) and speeds (radians per second), drawn
            by ``conditions.start_joints``; None: at rest at 0.
    """

    robot_id: int
    agent: str
    robot: Robot
    controlled_by: Controller
    network: NetworkSpec | None
    sensor_low: NDArray[np.float64]
    sensor_high: NDArray[np.float64]
    position: tuple[float, float]
    inside: bool
    yaw: float
    radius: float
    joints: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None


def plan_birth(rules: BirthRules, robot_id: int, agent: str, robot: Robot,
               position: tuple[float, float] | None, controlled_by: str, yaw: float | None,
               occupied: Sequence[Disc], names: Sequence[str], rng: np.random.Generator
               ) -> BirthPlan:
    """Check, place and head a newborn (draws from ``rng``: placement or jitter, heading, hinges).

    Args:
        rules: The env's placement rules.
        robot_id: The newborn's id; ``agent`` its agent name.
        agent: Its agent name, for messages.
        robot: The robot.
        position: Core ``(x, y)``, metres; None: placed by the rule of
            :func:`~revolve_env.envs.placement.place`.
        controlled_by: ``"brain"`` or ``"agent"``.
        yaw: Heading, radians; None: ``rules.conditions.heading`` (drawn when random).
        occupied: The living robots' footprints; ``names`` their agent names (for messages).
        names: The agent names of ``occupied``.
        rng: The env's generator.

    Raises:
        ValueError, TypeError: see :func:`check_birth`; a given position (after the jitter)
            overlapping a living robot, or a footprint reaching past the terrain's edge
            (``TerrainError``) (the generator is left as it was).
    """
    spec, low, high = check_birth(agent, robot, position, controlled_by, yaw, rules.limits)
    radius = footprint_radius(robot)
    inside = True
    before = rng.bit_generator.state
    if position is None:
        placement = place(occupied, radius, rules.birth_radius, rules.clearance, rng,
                          rules.tries)
        xy, inside = placement.position, placement.inside
    else:
        xy = (float(position[0]), float(position[1]))
        if not (math.isfinite(xy[0]) and math.isfinite(xy[1])):
            raise ValueError(f"add_robot ({agent}): position must be finite, got {position!r}")
        xy = jittered(xy, rules.conditions.position_jitter, rng)
        k = clash(occupied, xy, radius, rules.clearance)
        if k is not None:
            rng.bit_generator.state = before  # a refused birth changes nothing
            raise ValueError(f"add_robot ({agent}): position {xy} overlaps {names[k]}: a robot "
                             f"of footprint radius {radius:.3f} m needs "
                             f"{rules.clearance} m clearance")
    try:
        rules.terrain.ground_under(xy[0], xy[1], radius)
    except TerrainError as e:
        rng.bit_generator.state = before  # a refused birth changes nothing
        raise TerrainError(f"add_robot ({agent}): {e}") from None
    if yaw is not None:
        heading = float(yaw)
    elif rules.conditions.random_heading:
        heading = float(rng.uniform(0.0, 2.0 * math.pi))
    else:
        heading = float(rules.conditions.heading)
    joints = rules.conditions.start_joints(rng, len(robot.neurons_of(Layer.OUTPUT)))
    controller: Controller = "brain" if controlled_by == "brain" else "agent"
    return BirthPlan(robot_id, agent, robot, controller, spec, low, high, xy, inside, heading,
                     radius, joints)
