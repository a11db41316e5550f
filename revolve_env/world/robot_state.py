"""The world's bookkeeping: one record per robot, and the index arrays over all of them.

Private to :mod:`revolve_env.world.world`. A :class:`RobotState` is made once per robot (its
model's sensor plan included); a :class:`Layout` is rebuilt from all of them at every birth and
death, so that each control period touches every robot through a handful of array operations.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.robot import Robot
from revolve_env.body.serialize import from_json
from revolve_env.world.backend import BodyStates, PhysicsBackend, SnapshotMismatchError
from revolve_env.world.model import LightSensorModel, RobotModel, TouchSensorModel, build_model

__all__ = ["Layout", "RobotState", "all_finite", "empty_states", "layout", "restored_states",
           "robot_state"]

_INTP = np.intp
IMU_VALUES = 6  # accelerometer x, y, z then gyroscope x, y, z: the first values of every robot


def all_finite(a: NDArray[np.float64]) -> bool:
    """Whether every entry is finite (fast path: one reduction; exact on overflow)."""
    return math.isfinite(float(np.add.reduce(a, axis=None))) or bool(np.isfinite(a).all())


def empty_states() -> BodyStates:
    """No robots' states (the world's state before the first step)."""
    return BodyStates(np.zeros((0, 3)), np.zeros((0, 3, 3)), np.zeros((0, 3)), np.zeros((0, 3)),
                      np.zeros(0), np.zeros(0), np.zeros(0, dtype=bool))


def _ints(values: Sequence[int] | NDArray[np.intp]) -> NDArray[np.intp]:
    return np.asarray(values, dtype=_INTP).reshape(-1)


@dataclass
class RobotState:
    """Per-robot bookkeeping of the world (private, mutable).

    The sensor plan (``touch_*``, ``light_*``) is the model's, in the robot's input order:
    ``*_local`` are indices into the robot's sensor values.
    """

    key: int  # the backend's key
    model: RobotModel
    robot: Robot
    active_local: NDArray[np.intp]  # active hinges among the robot's hinges, output order
    n_joints: int  # hinges, active and passive
    touch_links: NDArray[np.intp]  # model links of the touch halves (left, right per sensor)
    touch_local: NDArray[np.intp]
    light_links: NDArray[np.intp]  # model link of each light sensor
    light_local: NDArray[np.intp]
    light_position: NDArray[np.float64]  # (k, 3) sensing points in their link's frame. Metres
    light_direction: NDArray[np.float64]  # (k, 3) unit facings in their link's frame
    placed: tuple[float, float, float] = (0.0, 0.0, 0.0)  # root position given to the backend, m
    yaw: float = 0.0  # heading given to the backend. Radians
    row: int = 0  # row in the backend's BodyStates
    joint_start: int = 0  # first hinge in BodyStates.joint_pos
    blow_up: str | None = None

    @property
    def n_inputs(self) -> int:
        """Sensor values."""
        return self.model.n_inputs

    @property
    def n_outputs(self) -> int:
        """Active hinges."""
        return self.model.n_outputs


def robot_state(key: int, model: RobotModel, robot: Robot, placed: tuple[float, float, float],
                yaw: float) -> RobotState:
    """The world's bookkeeping of a robot the backend built under ``key``."""
    hinges = [i for i in range(1, len(model.links)) if not model.links[i].fixed]
    assert hinges == list(range(1, len(hinges) + 1)), "hinge links come before welded ones"
    assert model.sensors and model.sensors[0][0] == "imu", "the core's IMU comes first"
    touch_links: list[int] = []
    touch_local: list[int] = []
    lights: list[LightSensorModel] = []
    light_local: list[int] = []
    k = 0
    for kind, sensor in model.sensors:
        if kind == "imu":
            k += IMU_VALUES
        elif kind == "touch":
            assert isinstance(sensor, TouchSensorModel)
            touch_links += sensor.links
            touch_local += [k, k + 1]
            k += 2
        else:
            assert isinstance(sensor, LightSensorModel)
            lights.append(sensor)
            light_local.append(k)
            k += 1
    assert k == model.n_inputs
    return RobotState(
        key=key, model=model, robot=robot,
        active_local=_ints([i - 1 for i in model.active_links]), n_joints=len(hinges),
        touch_links=_ints(touch_links), touch_local=_ints(touch_local),
        light_links=_ints([s.link for s in lights]), light_local=_ints(light_local),
        light_position=np.array([s.position for s in lights], dtype=np.float64).reshape(-1, 3),
        light_direction=np.array([s.direction for s in lights], dtype=np.float64).reshape(-1, 3),
        placed=placed, yaw=yaw,
    )


def restored_states(snapshot: dict[str, Any]) -> tuple[dict[int, RobotState], NDArray[np.float64],
                                                       NDArray[np.float64]]:
    """The robots of a world snapshot by handle, their flat targets and the IMU's last velocities.

    Raises:
        SnapshotMismatchError: damaged data (targets that do not fit a robot, a missing key...).
    """
    robots: dict[int, RobotState] = {}
    targets: list[NDArray[np.float64]] = []
    try:
        for entry in snapshot["robots"]:
            robot = from_json(entry["robot"])
            model = build_model(robot)
            x, y, z = (float(v) for v in entry["placed"])
            state = robot_state(int(entry["key"]), model, robot, (x, y, z), float(entry["yaw"]))
            hinges = np.array(entry["targets"], dtype=np.float64).reshape(-1)
            if hinges.shape != (model.n_outputs,):
                raise SnapshotMismatchError(f"robot {entry['handle']}: {hinges.shape[0]} "
                                            f"targets for {model.n_outputs} active hinges")
            targets.append(hinges)
            state.blow_up = entry["blow_up"]
            robots[int(entry["handle"])] = state
        prev_vel = np.array(snapshot["prev_vel"], dtype=np.float64).reshape(-1, 3)
        if prev_vel.shape[0] != len(robots):
            raise SnapshotMismatchError("the snapshot's IMU state does not fit its robots")
    except (KeyError, TypeError, ValueError) as e:
        if isinstance(e, SnapshotMismatchError):
            raise
        raise SnapshotMismatchError(f"damaged world snapshot: {e}") from e
    return robots, np.concatenate(targets) if targets else np.zeros(0), prev_vel


def _empty_ints() -> NDArray[np.intp]:
    return np.zeros(0, dtype=_INTP)


def _empty_vectors() -> NDArray[np.float64]:
    return np.zeros((0, 3))


@dataclass(frozen=True)
class Layout:
    """Index arrays over every robot of a world, rows in insertion order (rebuilt on changes).

    Flat arrays: every robot's hinge targets (``n_outputs`` active hinges, controller output
    order) and sensor values (``n_inputs``, controller input order) one robot after the other;
    ``output_offsets`` and ``input_offsets`` (``n + 1`` entries) delimit each robot's part, as
    ``joint_offsets`` does its hinges in ``BodyStates.joint_pos``.
    Sensors: the IMU's six values of every robot start its part; touch halves and light
    sensors are listed with their place in the flat sensor values (``*_dest``). The light
    sensors on a core come first and read the core's pose (``light_root_rows``); those on other
    links read the poses the backend gives for ``light_link_ids`` (engine ids from
    :meth:`~revolve_env.world.backend.PhysicsBackend.link_index`, valid until the next birth or
    death, when the layout is rebuilt). ``light_points`` and ``light_facings`` are (k, 3, 1)
    columns, as the batched matrix products take them.
    """

    n: int = 0
    active_index: NDArray[np.intp] = field(default_factory=_empty_ints)  # into joint_pos
    output_offsets: NDArray[np.intp] = field(default_factory=lambda: np.zeros(1, dtype=_INTP))
    output_rows: NDArray[np.intp] = field(default_factory=_empty_ints)  # robot of each target
    joint_offsets: NDArray[np.intp] = field(default_factory=lambda: np.zeros(1, dtype=_INTP))
    input_offsets: NDArray[np.intp] = field(default_factory=lambda: np.zeros(1, dtype=_INTP))
    imu_dest: NDArray[np.intp] = field(default_factory=lambda: np.zeros((0, IMU_VALUES),
                                                                         dtype=_INTP))
    touch_dest: NDArray[np.intp] = field(default_factory=_empty_ints)
    touch_ids: NDArray[np.intp] = field(default_factory=_empty_ints)
    light_dest: NDArray[np.intp] = field(default_factory=_empty_ints)  # on the core, then links
    light_root_rows: NDArray[np.intp] = field(default_factory=_empty_ints)
    light_link_ids: NDArray[np.intp] = field(default_factory=_empty_ints)
    light_points: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3, 1)))
    light_facings: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3, 1)))

    @property
    def n_inputs(self) -> int:
        """Sensor values of all robots."""
        return int(self.input_offsets[-1])

    @property
    def n_outputs(self) -> int:
        """Active hinges of all robots."""
        return int(self.output_offsets[-1])


def layout(states: Sequence[RobotState], backend: PhysicsBackend) -> Layout:
    """Number the robots' rows and hinges and build the index arrays (sets ``row``, ...).

    Array operations over all robots, plus a loop over those with touch or light sensors only
    (in row order, as ``backend.link_index`` numbers them): a world that gains its robots one
    by one rebuilds this at every birth, so its per-robot Python must stay small.
    """
    if not states:
        return Layout()
    n = len(states)
    joints = np.fromiter((s.n_joints for s in states), _INTP, n)
    in_offsets = np.zeros(n + 1, dtype=_INTP)
    np.cumsum(np.fromiter((s.model.n_inputs for s in states), _INTP, n), out=in_offsets[1:])
    out_offsets = np.zeros(n + 1, dtype=_INTP)
    np.cumsum(np.fromiter((len(s.model.active_links) for s in states), _INTP, n),
              out=out_offsets[1:])
    joint_offsets = np.zeros(n + 1, dtype=_INTP)
    np.cumsum(joints, out=joint_offsets[1:])
    joint_starts = joint_offsets[:-1]
    for row, (s, start) in enumerate(zip(states, joint_starts.tolist(), strict=True)):
        s.row = row
        s.joint_start = start
    locals_ = [s.active_local for s in states]
    sizes = np.fromiter((a.shape[0] for a in locals_), _INTP, n)
    active = (np.concatenate(locals_) + np.repeat(joint_starts, sizes)).astype(_INTP)
    out_rows = np.repeat(np.arange(n, dtype=_INTP), np.diff(out_offsets))
    touch_dest: list[NDArray[np.intp]] = []
    touch_ids: list[NDArray[np.intp]] = []
    root: list[tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float64],
                     NDArray[np.float64]]] = []
    link: list[tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float64],
                     NDArray[np.float64]]] = []
    for row, s in enumerate(states):
        if not (s.touch_links.size or s.light_links.size):
            continue
        inputs = int(in_offsets[row])
        if s.touch_links.size:
            touch_dest.append(inputs + s.touch_local)
            touch_ids.append(backend.link_index(s.key, s.touch_links))
        on_root = s.light_links == 0
        if on_root.any():
            root.append((inputs + s.light_local[on_root], np.full(int(on_root.sum()), row,
                                                                  dtype=_INTP),
                         s.light_position[on_root], s.light_direction[on_root]))
        if (~on_root).any():
            link.append((inputs + s.light_local[~on_root],
                         backend.link_index(s.key, s.light_links[~on_root]),
                         s.light_position[~on_root], s.light_direction[~on_root]))
    input_offsets = in_offsets

    def cat(parts: list[NDArray[np.intp]]) -> NDArray[np.intp]:
        return np.concatenate(parts).astype(_INTP) if parts else _empty_ints()

    def vectors(parts: list[NDArray[np.float64]]) -> NDArray[np.float64]:
        # contiguous: the batched maths must see the arrays a robot alone would
        return np.ascontiguousarray(np.concatenate(parts)) if parts else _empty_vectors()

    points = vectors([r[2] for r in root] + [r[2] for r in link])
    facings = vectors([r[3] for r in root] + [r[3] for r in link])
    return Layout(
        n=n, active_index=active, output_offsets=out_offsets,
        output_rows=out_rows, joint_offsets=joint_offsets, input_offsets=input_offsets,
        imu_dest=input_offsets[:-1, None] + np.arange(IMU_VALUES, dtype=_INTP),
        touch_dest=cat(touch_dest), touch_ids=cat(touch_ids),
        light_dest=cat([r[0] for r in root] + [r[0] for r in link]),
        light_root_rows=cat([r[1] for r in root]), light_link_ids=cat([r[1] for r in link]),
        light_points=np.ascontiguousarray(points[:, :, None]),
        light_facings=np.ascontiguousarray(facings[:, :, None]),
    )
