"""Robots side by side that never meet: each in a scene of its own, stepped together.

:class:`IsolatedBackend` is a :class:`~revolve_env.world.backend.PhysicsBackend` whose robots
each live in a backend of their own (a world of one robot), so a robot's physics is exactly
that of a world where it is alone, whichever robots are beside it, however many: what
``World(config, isolated=True)`` uses for side-by-side evaluations
(:func:`revolve_env.evaluate_many`). The world's rules (servo law, sensors, blow-ups) still run
once per control period over every robot's arrays. Engines with a batched stepping of separate
scenes provide their own subclass (MuJoCo: :mod:`revolve_env.world.mujoco_scenes`); this generic
one steps and reads its scenes one after the other (pybullet: one client per robot).

Not available in an isolated world: snapshots (there is no one scene to save) and a GUI;
:meth:`IsolatedBackend.render` draws the first robot's scene.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import fields
from typing import Any

import numpy as np
from numpy.typing import NDArray

from revolve_env.world.backend import BodyStates, PhysicsBackend
from revolve_env.world.config import WorldConfig
from revolve_env.world.model import PlacedModel, RobotModel

__all__ = ["IsolatedBackend"]


class IsolatedBackend:
    """A backend per robot behind one batched interface (see the module doc)."""

    def __init__(self, config: WorldConfig, *,
                 scene: Callable[[WorldConfig], PhysicsBackend]) -> None:
        """No robots yet; each robot will get a scene of its own, ``scene(config)``.

        (:func:`~revolve_env.world.engines.make_backend` passes the engine's backend class.)
        """
        self.config = config
        self._make_scene = scene
        self._scenes: dict[int, PhysicsBackend] = {}
        self._outputs: dict[int, int] = {}  # active hinges of each robot
        self._next_key = 0
        self._links: list[tuple[int, int]] = []  # link_index's table: (key, id in its scene)
        # _by_scene's last answer: the ids array asked about and its runs
        self._runs: tuple[NDArray[np.intp], list[tuple[int, NDArray[np.intp]]]] | None = None
        self._closed = False

    # -- robots -------------------------------------------------------------------------------
    def add(self, model: RobotModel, position: tuple[float, float, float], yaw: float) -> int:
        scene = self._make_scene(self.config)
        try:
            scene.add(model, position, yaw)  # its only robot: key 0 in that scene
        except BaseException:
            scene.close()
            raise
        key = self._next_key
        self._next_key += 1
        self._scenes[key] = scene
        self._outputs[key] = model.n_outputs
        self._grown(key)
        return key

    def remove(self, key: int) -> None:
        """Close the robot's scene (nothing of it stays allocated)."""
        self._scenes.pop(key).close()
        del self._outputs[key]
        self._changed()

    def _changed(self) -> None:
        """After a birth or death: link ids are void; subclasses rebuild their arrays."""
        self._links = []
        self._runs = None

    def _grown(self, key: int) -> None:
        """After the birth of robot ``key`` (the last scene).

        As any change, unless a subclass extends its arrays by the new scene alone (then N
        births cost O(N), not O(N^2)).
        """
        self._changed()

    def set_hinges(self, key: int, hinges: NDArray[np.intp], angles: NDArray[np.float64],
                   velocities: NDArray[np.float64]) -> None:
        self._scenes[key].set_hinges(0, hinges, angles, velocities)  # its scene's only robot

    # -- stepping -------------------------------------------------------------------------------
    def set_joint_velocities(self, velocities: NDArray[np.float64], max_torque: float) -> None:
        start = 0
        for key, scene in self._scenes.items():
            n = self._outputs[key]
            scene.set_joint_velocities(velocities[start:start + n], max_torque)
            start += n

    def step(self, substeps: int) -> None:
        for scene in self._scenes.values():
            scene.step(substeps)

    def read(self) -> BodyStates:
        reads = [scene.read() for scene in self._scenes.values()]
        return BodyStates(*(np.concatenate([getattr(r, f.name) for r in reads])
                            for f in fields(BodyStates)))

    # -- sensors --------------------------------------------------------------------------------
    def link_index(self, key: int, links: NDArray[np.intp]) -> NDArray[np.intp]:
        """Rows of a table of (robot, id in its scene), emptied by every birth and death."""
        start = len(self._links)
        self._links += [(key, int(i)) for i in self._scenes[key].link_index(0, links)]
        return np.arange(start, len(self._links), dtype=np.intp)

    def _by_scene(self, ids: NDArray[np.intp]) -> list[tuple[int, NDArray[np.intp]]]:
        """``ids`` as (robot, ids in its scene) runs, in order.

        Remembered for the last array asked about: the world asks with the same array every
        control period until the next birth or death.
        """
        cached = self._runs
        if cached is not None and cached[0] is ids:
            return cached[1]
        runs = self._group(ids)
        self._runs = (ids, runs)
        return runs

    def _group(self, ids: NDArray[np.intp]) -> list[tuple[int, NDArray[np.intp]]]:
        pairs = [self._links[i] for i in ids.tolist()]
        runs: list[tuple[int, list[int]]] = []
        for key, inner in pairs:
            if runs and runs[-1][0] == key:
                runs[-1][1].append(inner)
            else:
                runs.append((key, [inner]))
        return [(key, np.array(inner, dtype=np.intp)) for key, inner in runs]

    def link_poses(self, ids: NDArray[np.intp]) -> tuple[NDArray[np.float64],
                                                         NDArray[np.float64]]:
        poses = [self._scenes[key].link_poses(inner) for key, inner in self._by_scene(ids)]
        if not poses:
            return np.zeros((0, 3)), np.zeros((0, 3, 3))
        return (np.concatenate([p for p, _ in poses]), np.concatenate([r for _, r in poses]))

    def touching(self, ids: NDArray[np.intp]) -> NDArray[np.bool_]:
        parts = [self._scenes[key].touching(inner) for key, inner in self._by_scene(ids)]
        return np.concatenate(parts) if parts else np.zeros(0, dtype=bool)

    def total_mass(self, key: int) -> float:
        return self._scenes[key].total_mass(0)

    def body_count(self) -> int:
        return 1 + len(self._scenes)

    # -- lifetime -----------------------------------------------------------------------------
    def reset(self) -> None:
        for scene in self._scenes.values():
            scene.close()
        self._scenes.clear()
        self._outputs.clear()
        self._changed()

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self.reset()

    # -- snapshots and rendering ----------------------------------------------------------------
    @property
    def exact_restore(self) -> bool:
        """False: an isolated world has no snapshots."""
        return False

    def snapshot(self) -> dict[str, Any]:
        """Not available: there is no one scene to save.

        Raises:
            NotImplementedError: always.
        """
        raise NotImplementedError("an isolated world (a scene per robot) has no snapshots")

    def mjcf(self) -> str:
        """Not available: no one model holds the robots (each scene's is that of a world of one).

        Raises:
            NotImplementedError: always.
        """
        raise NotImplementedError("an isolated world (a scene per robot) is no one MJCF scene; "
                                  "export a world holding the robot alone")

    def restore(self, robots: Sequence[PlacedModel], state: dict[str, Any]) -> None:
        """Not available (see :meth:`snapshot`).

        Raises:
            NotImplementedError: always.
        """
        raise NotImplementedError("an isolated world (a scene per robot) has no snapshots")

    def render(self, width: int, height: int, target: tuple[float, float, float],
               distance: float, yaw_deg: float, pitch_deg: float) -> NDArray[np.uint8]:
        """The first robot's scene (the others are elsewhere).

        Raises:
            RuntimeError: no robot, or the engine cannot render here.
        """
        if not self._scenes:
            raise RuntimeError("an isolated world without robots has no scene to draw")
        scene = next(iter(self._scenes.values()))
        return scene.render(width, height, target, distance, yaw_deg, pitch_deg)

    def look_at(self, target: tuple[float, float, float], distance: float) -> None:
        """No interactive window: nothing to point."""
