"""The physics-backend interface under :class:`~revolve_env.world.World`.

A backend is the only place that talks to a physics engine. It knows nothing of servos, sensors,
targets or blow-ups: :class:`~revolve_env.world.World` owns those rules and drives a backend
through a handful of batched primitives (one call per control period for all robots):

* :meth:`PhysicsBackend.add` / :meth:`PhysicsBackend.remove` a robot model,
* :meth:`PhysicsBackend.set_joint_velocities` of every active hinge (torque-limited),
* :meth:`PhysicsBackend.step`,
* :meth:`PhysicsBackend.read`: the core poses, velocities and hinge states of all robots as
  arrays (:class:`BodyStates`),
* :meth:`PhysicsBackend.link_poses` and :meth:`PhysicsBackend.touching` for the sensors: the
  poses of, and whether anything touches, any links of any robots at once, named by engine ids
  that :meth:`PhysicsBackend.link_index` gives once per birth or death,
* :meth:`PhysicsBackend.render`,
* :meth:`PhysicsBackend.snapshot` / :meth:`PhysicsBackend.restore`: the engine's whole state, for
  an exact continuation in a scene rebuilt from the same robots (where
  :attr:`PhysicsBackend.exact_restore` says the engine allows it),
* :meth:`PhysicsBackend.mjcf`: the scene as MuJoCo's MJCF.

The engines, and the factory that builds a backend by name, are in
:mod:`revolve_env.world.engines`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from revolve_env.world.model import PlacedModel, RobotModel

__all__ = ["BodyStates", "EngineUnavailableError", "PhysicsBackend", "SnapshotMismatchError"]


class EngineUnavailableError(ImportError):
    """The selected physics engine's Python package is not installed (or does not import)."""


class SnapshotMismatchError(ValueError):
    """A snapshot does not fit the scene rebuilt to restore it.

    Other robots, another engine or engine version, or damaged data: the continuation would not
    be exact.
    """


@dataclass(frozen=True, slots=True)
class BodyStates:
    """The state of every robot of a backend, rows in insertion order (read-only snapshot).

    Attributes:
        core_pos: (n, 3) core centres (root link frame origins), world frame. Metres.
        core_rot: (n, 3, 3) rotations from the root link (core) frame to the world frame.
        core_vel: (n, 3) linear velocities of the core centres, world frame. Metres per second.
        core_angvel: (n, 3) angular velocities of the cores, world frame. Radians per second.
        joint_pos: Angles of every hinge (active and passive) of every robot: each robot's hinges
            in model link order (link ``j + 1`` is hinge ``j``), robots one after the other.
            Radians.
        joint_vel: Hinge speeds, laid out like ``joint_pos``. Radians per second.
        diverged: (n,) robots whose state the engine found non-finite and restored (an engine
            that does not contain a divergence leaves NaN in the arrays instead and reports
            False).
    """

    core_pos: NDArray[np.float64]
    core_rot: NDArray[np.float64]
    core_vel: NDArray[np.float64]
    core_angvel: NDArray[np.float64]
    joint_pos: NDArray[np.float64]
    joint_vel: NDArray[np.float64]
    diverged: NDArray[np.bool_]


class PhysicsBackend(Protocol):
    """What :class:`~revolve_env.world.World` needs from a physics engine.

    A backend owns its engine handle (one per backend, released by :meth:`close`). Robots are
    identified by the ``key`` :meth:`add` returns; "all robots" always means the robots present,
    in insertion order. Hinges have no joint limits; robots collide with the ground and with each
    other, never with themselves.
    """

    def add(self, model: RobotModel, position: tuple[float, float, float], yaw: float) -> int:
        """Build a robot at rest; return its key.

        Its root link frame is at ``position`` (metres), turned by ``yaw`` (radians) about the
        vertical. Hinges start free (no torque).
        """
        ...

    def remove(self, key: int) -> None:
        """Delete a robot; every other robot's state is kept exactly."""
        ...

    def set_hinges(self, key: int, hinges: NDArray[np.intp], angles: NDArray[np.float64],
                   velocities: NDArray[np.float64]) -> None:
        """Put some hinges of one robot at angles (radians) and speeds (radians per second).

        ``hinges`` are indices into the robot's hinges in model link order (``joint_pos``'s
        layout); the rest of the scene is unchanged. For a start perturbation, before stepping.
        """
        ...

    def set_joint_velocities(self, velocities: NDArray[np.float64], max_torque: float) -> None:
        """Drive every active hinge of every robot towards a velocity until the next call.

        ``velocities`` (radians per second) holds each robot's active hinges in controller output
        order, robots one after the other; ``max_torque`` is the torque limit (newton metres).
        """
        ...

    def step(self, substeps: int) -> None:
        """Advance ``substeps`` physics steps of ``config.timestep``."""
        ...

    def read(self) -> BodyStates:
        """The state of every robot (see :class:`BodyStates`)."""
        ...

    def link_index(self, key: int, links: NDArray[np.intp]) -> NDArray[np.intp]:
        """Engine ids of some model links of a robot, for :meth:`link_poses` and :meth:`touching`.

        Valid until the next :meth:`add`, :meth:`remove`, :meth:`reset` or :meth:`restore`.
        """
        ...

    def link_poses(self, ids: NDArray[np.intp]) -> tuple[NDArray[np.float64],
                                                         NDArray[np.float64]]:
        """World positions (k, 3) (metres) and rotations (k, 3, 3) of the frames of links ``ids``.

        ``ids`` may name links of any robots (from :meth:`link_index`); one call for all.
        """
        ...

    def touching(self, ids: NDArray[np.intp]) -> NDArray[np.bool_]:
        """Whether each of the links ``ids`` (any robots') touches anything now, shape (k,)."""
        ...

    def total_mass(self, key: int) -> float:
        """Mass of a robot as the engine holds it. Kilograms."""
        ...

    def body_count(self) -> int:
        """Number of robots plus the ground (for leak checks)."""
        ...

    def reset(self) -> None:
        """Remove every robot and restart from time 0, like a new backend."""
        ...

    def render(self, width: int, height: int, target: tuple[float, float, float],
               distance: float, yaw_deg: float, pitch_deg: float) -> NDArray[np.uint8]:
        """An RGB picture (height, width, 3) from a camera looking at ``target``."""
        ...

    def look_at(self, target: tuple[float, float, float], distance: float) -> None:
        """Point an interactive window's camera at ``target`` (no effect without one)."""
        ...

    def close(self) -> None:
        """Release the engine (idempotent)."""
        ...

    @property
    def exact_restore(self) -> bool:
        """Whether :meth:`restore` continues a :meth:`snapshot` bit for bit."""
        ...

    def snapshot(self) -> dict[str, Any]:
        """The engine's state now: plain data (numbers, strings, lists, NumPy arrays).

        Raises:
            NotImplementedError: the engine cannot restore its state exactly.
        """
        ...

    def mjcf(self) -> str:
        """The scene as placed (the robots where they were added) as MuJoCo's MJCF text.

        Raises:
            ImportError: the ``mujoco`` package is not installed (``World.to_mjcf`` checks it
                first, in one line).
            NotImplementedError: no one scene holds the robots (an isolated world).
        """
        ...

    def restore(self, robots: Sequence[PlacedModel], state: dict[str, Any]) -> None:
        """Replace everything by a scene of ``robots`` in the state of a :meth:`snapshot`.

        ``robots`` are the robots present at the snapshot, in order, with their keys and the
        poses they were added at.

        Raises:
            SnapshotMismatchError: the rebuilt scene is not the one the snapshot was taken of.
            NotImplementedError: the engine cannot restore its state exactly.
        """
        ...
