"""MuJoCo scenes of one robot each, stepped and read together (an isolated world's backend).

With :mod:`~revolve_env.world.mujoco_backend`, which builds each scene, and
:mod:`~revolve_env.world.mujoco_terrain`, the only modules that import ``mujoco``.

:class:`MujocoScenes` is the MuJoCo form of :class:`~revolve_env.world.isolated.IsolatedBackend`:
each robot is built by a :class:`~revolve_env.world.mujoco_backend.MujocoBackend` of its own
(the very model, state and divergence handling of a world where it is alone), and each control
period costs, per robot, only what MuJoCo needs: its controls written, ``mj_step``,
``mj_kinematics`` and one ``mj_getState`` of its time, positions, velocities and warm start into
a shared buffer. Everything else (the finiteness check, the states of all robots, the world's
rules above) is array operations over that buffer. The buffer is kept twice, alternating: the
state a period starts from is the previous period's, which is what a scene replays from should
its period end non-finite (:meth:`MujocoBackend._replay`).

Why separate models rather than one model holding every robot far apart: in one compiled model
the robots' trajectories are not those of each robot alone (measured with MuJoCo 4.0: 1e-11 to
1e-10 m after 600 control periods, growing to centimetres in 12 s, whatever the distance and
with islands, sparse Jacobians, tolerance 0 or without warm start), so a robot's fitness would
depend on its batch; and one model steps only about 5 % faster than the same robots in
separate models (15 random robots, measured).
"""

from __future__ import annotations

from functools import partial

import numpy as np
from numpy.typing import NDArray

from revolve_env.world.backend import BodyStates
from revolve_env.world.config import WorldConfig
from revolve_env.world.isolated import IsolatedBackend
from revolve_env.world.mujoco_backend import _SAVED, MujocoBackend, _all_finite, _c_einsum
from revolve_env.world.mujoco_gl import mujoco  # its OpenGL backend chosen first

__all__ = ["MujocoScenes"]


class MujocoScenes(IsolatedBackend):
    """Robots in MuJoCo scenes of their own, one batched interface (see the module doc)."""

    def __init__(self, config: WorldConfig) -> None:
        # Each scene is compiled once, with its robot (not empty first, then again with it).
        super().__init__(config, scene=partial(MujocoBackend, compile_empty=False))
        self._velocities = np.zeros(0)
        self._torque = config.max_torque
        self._parity = 0  # which of the two state buffers holds the state now
        self._layout_scenes()

    def _scene_list(self) -> list[MujocoBackend]:
        scenes: list[MujocoBackend] = list(self._scenes.values())  # type: ignore[arg-type]
        return scenes

    def scenes(self) -> list[MujocoBackend]:
        """The robots' scenes, in order (for C code that steps them: their ``raw_scene()``)."""
        return self._scene_list()

    def _changed(self) -> None:
        super()._changed()
        self._layout_scenes()

    def _grown(self, key: int) -> None:
        super()._changed()  # IsolatedBackend's part: the link table
        scene = self._scenes[key]
        assert isinstance(scene, MujocoBackend)
        self._append_scene(key, scene)

    def _layout_scenes(self) -> None:
        """Each scene's places in the shared buffers; the state now gathered into them."""
        self._buffers = (np.zeros(0), np.zeros(0))  # the state buffers, with room to grow
        self._rot_buffer = np.zeros((0, 9))
        self._spans: list[tuple[int, int]] = []  # each scene's place in the state buffers
        self._rows: dict[int, int] = {}  # key -> the scene's row
        # read()'s gather by field (positions, velocities, angular velocities, hinges, hinge
        # speeds), each over every scene
        self._fields = tuple(np.zeros(0, dtype=np.intp) for _ in range(5))
        self._diverged = np.zeros(0, dtype=bool)
        self._plan: list[tuple[mujoco.MjModel, mujoco.MjData, NDArray[np.float64], int, int,
                               tuple[NDArray[np.float64], NDArray[np.float64]],
                               NDArray[np.float64]]] = []
        self._n_outputs = 0
        for key, scene in self._scenes.items():
            assert isinstance(scene, MujocoBackend)
            self._append_scene(key, scene)
        if not self._scenes:
            self._laid_out()

    def _fit(self, size: int, rows: int) -> None:
        """Room for ``size`` state entries and ``rows`` scenes (doubling: N births cost O(N))."""
        if size > self._buffers[0].shape[0]:
            grown = max(size, 2 * self._buffers[0].shape[0])
            buffers = (np.zeros(grown), np.zeros(grown))
            for new, old in zip(buffers, self._buffers, strict=True):
                new[:old.shape[0]] = old
            self._buffers = buffers
            self._plan = [(m, d, ctrl, a, b, (buffers[0][lo:hi], buffers[1][lo:hi]), xmat)
                          for (m, d, ctrl, a, b, _, xmat), (lo, hi)
                          in zip(self._plan, self._spans, strict=True)]
        if rows > self._rot_buffer.shape[0]:
            rot = np.zeros((max(rows, 2 * self._rot_buffer.shape[0]), 9))
            rot[:self._rot_buffer.shape[0]] = self._rot_buffer
            self._rot_buffer = rot

    def _append_scene(self, key: int, s: MujocoBackend) -> None:
        """Scene ``s`` (robot ``key``) after the others in the buffers; its state gathered."""
        m, d = s._model, s._data
        i = len(self._plan)
        lo = self._spans[-1][1] if self._spans else 0
        hi = lo + mujoco.mj_stateSize(m, _SAVED)
        self._fit(hi, i + 1)
        base = lo + 1  # _SAVED: time, qpos, qvel, warm start
        q0, v0 = base + int(s._root_qpos[0]), base + m.nq + int(s._root_dofs[0])
        three = np.arange(3, dtype=np.intp)
        parts = (q0 + three,  # a free joint's body sits at its first three qpos
                 v0 + three, v0 + 3 + three, base + s._hinge_qpos, base + m.nq + s._hinge_dofs)
        self._fields = tuple(np.concatenate((f, p.astype(np.intp)))
                             for f, p in zip(self._fields, parts, strict=True))
        views = (self._buffers[0][lo:hi], self._buffers[1][lo:hi])
        root = int(s._root_bodies[0])
        a = self._n_outputs
        self._n_outputs += m.nu
        self._plan.append((m, d, d.ctrl, a, self._n_outputs, views, d.xmat[root]))
        self._spans.append((lo, hi))
        self._rows[key] = i
        self._diverged = np.append(self._diverged, bool(s._diverged[0]))
        self._gather_scene(i, s)
        self._laid_out()

    def _rebind(self, i: int, s: MujocoBackend) -> None:
        """Scene ``i``'s step plan on its MjData now (after its data was made anew)."""
        m, _, _, a, b, views, _ = self._plan[i]
        d = s._data
        self._plan[i] = (m, d, d.ctrl, a, b, views, d.xmat[int(s._root_bodies[0])])

    def _gather_scene(self, i: int, s: MujocoBackend) -> None:
        """Scene ``i``'s state now into both state buffers, and its core's orientation."""
        m, d = s._model, s._data
        mujoco.mj_kinematics(m, d)
        s._kinematics_fresh = True
        for view in self._plan[i][5]:
            mujoco.mj_getState(m, d, view, _SAVED)
        self._rot_buffer[i] = d.xmat[int(s._root_bodies[0])]

    def _laid_out(self) -> None:
        """The arrays over every scene, after the scenes changed."""
        n, size = len(self._plan), self._spans[-1][1] if self._spans else 0
        self._states = (self._buffers[0][:size], self._buffers[1][:size])
        self._rot = self._rot_buffer[:n]
        self._gather: NDArray[np.intp] | None = None  # read()'s, made when read
        self._diverged.flags.writeable = False
        self._sensor_plans: dict[int, tuple[NDArray[np.intp],
                                            list[tuple[mujoco.MjData, NDArray[np.intp]]],
                                            NDArray[np.intp], int]] = {}

    def _gathered(self) -> tuple[NDArray[np.intp], int]:
        """read()'s one gather and the number of hinges.

        The gather: positions, velocities, angular velocities, hinges, hinge speeds.
        """
        if self._gather is None:
            self._gather = np.concatenate(self._fields)
        return self._gather, self._fields[3].shape[0]

    def set_hinges(self, key: int, hinges: NDArray[np.intp], angles: NDArray[np.float64],
                   velocities: NDArray[np.float64]) -> None:
        super().set_hinges(key, hinges, angles, velocities)
        i = self._rows[key]  # the shared state buffers gather its new state
        scene = self._scenes[key]
        assert isinstance(scene, MujocoBackend)
        self._rebind(i, scene)
        self._gather_scene(i, scene)
        diverged = self._diverged.copy()
        diverged[i] = bool(scene._diverged[0])
        self._diverged = diverged
        self._laid_out()

    # -- stepping -------------------------------------------------------------------------------
    def set_joint_velocities(self, velocities: NDArray[np.float64], max_torque: float) -> None:
        if max_torque != self._torque:
            self._torque = max_torque
            for s in self._scene_list():
                s._model.actuator_forcerange[:] = (-max_torque, max_torque)
        self._velocities = velocities  # written into each scene's controls by step()

    def step(self, substeps: int) -> None:
        vel, parity = self._velocities, 1 - self._parity
        rot, step, kinematics, get = self._rot, mujoco.mj_step, mujoco.mj_kinematics, \
            mujoco.mj_getState
        for i, (m, d, ctrl, a, b, views, xmat) in enumerate(self._plan):
            if b > a:
                ctrl[:] = vel[a:b]
            try:
                step(m, d, substeps)
            except mujoco.FatalError:
                self._fatal(i, substeps)
                continue
            kinematics(m, d)
            get(m, d, views[parity], _SAVED)
            rot[i] = xmat
        self._parity = parity
        if not _all_finite(self._states[parity]):
            self._contain(substeps)

    def _fatal(self, i: int, substeps: int) -> None:
        """Scene ``i``'s ``mj_step`` failed (see :meth:`MujocoBackend.step`): replay it anew.

        Its data may be half-updated, so it gets fresh data with the same controls, and its
        period is replayed from the state it started from, as its world alone would.
        """
        m, d, _, a, b, views, _ = self._plan[i]
        scene = self._scene_list()[i]
        fresh = scene._data = mujoco.MjData(m)
        fresh.ctrl[:] = d.ctrl
        scene._replay(views[self._parity].copy(), substeps)  # the period's start
        mujoco.mj_kinematics(m, fresh)
        mujoco.mj_getState(m, fresh, views[1 - self._parity], _SAVED)
        root = int(scene._root_bodies[0])
        self._plan[i] = (m, fresh, fresh.ctrl, a, b, views, fresh.xmat[root])
        self._rot[i] = fresh.xmat[root]
        diverged = self._diverged.copy()
        diverged[i] = bool(scene._diverged[0])
        diverged.flags.writeable = False
        self._diverged = diverged

    def _contain(self, substeps: int) -> None:
        """Replay the scenes whose period ended non-finite as each alone would (rare)."""
        scenes = self._scene_list()
        diverged = self._diverged.copy()
        for i, (m, d, _, _, _, views, xmat) in enumerate(self._plan):
            if _all_finite(views[self._parity]):
                continue
            start = views[1 - self._parity].copy()
            scenes[i]._replay(start, substeps)
            mujoco.mj_kinematics(m, d)
            mujoco.mj_getState(m, d, views[self._parity], _SAVED)
            self._rot[i] = xmat
            diverged[i] = bool(scenes[i]._diverged[0])
        diverged.flags.writeable = False
        self._diverged = diverged

    def read(self) -> BodyStates:
        gather, j = self._gathered()
        g = self._states[self._parity][gather]  # one fresh array for every field
        n = self._rot.shape[0]
        rot = self._rot.reshape(-1, 3, 3).copy()
        return BodyStates(
            core_pos=g[:3 * n].reshape(n, 3), core_rot=rot,
            core_vel=g[3 * n:6 * n].reshape(n, 3),
            core_angvel=_c_einsum("nij,nj->ni", rot, g[6 * n:9 * n].reshape(n, 3)),  # as alone
            joint_pos=g[9 * n:9 * n + j], joint_vel=g[9 * n + j:], diverged=self._diverged,
        )

    # -- sensors --------------------------------------------------------------------------------
    def _plan_of(self, ids: NDArray[np.intp]) -> tuple[list[tuple[mujoco.MjData,
                                                                  NDArray[np.intp]]],
                                                       NDArray[np.intp], int]:
        """Where to find the links ``ids`` name (remembered per array).

        Their scenes (data, each geom's body numbered across those scenes), each id's body in
        that numbering, and the number of bodies.
        """
        cached = self._sensor_plans.get(id(ids))
        if cached is not None and cached[0] is ids:
            return cached[1], cached[2], cached[3]
        rows = {key: row for row, key in enumerate(self._scenes)}
        scenes, bodies, offset = [], [], 0
        for key, inner in self._by_scene(ids):
            scene = self._scene_list()[rows[key]]
            scenes.append((scene._data, scene._model.geom_bodyid + offset))
            bodies.append(inner + offset)
            offset += scene._model.nbody
        flat = np.concatenate(bodies) if bodies else np.zeros(0, dtype=np.intp)
        self._sensor_plans[id(ids)] = (ids, scenes, flat, offset)
        return scenes, flat, offset

    def link_poses(self, ids: NDArray[np.intp]) -> tuple[NDArray[np.float64],
                                                         NDArray[np.float64]]:
        scenes, bodies, _ = self._plan_of(ids)
        pos = np.concatenate([d.xpos for d, _ in scenes]) if scenes else np.zeros((0, 3))
        rot = np.concatenate([d.xmat for d, _ in scenes]) if scenes else np.zeros((0, 9))
        return pos[bodies], rot[bodies].reshape(-1, 3, 3)

    def touching(self, ids: NDArray[np.intp]) -> NDArray[np.bool_]:
        # MujocoBackend._touching_now's rule for every scene at once: a body touches when one of
        # its geoms is in a contact of its scene's last physics step.
        scenes, bodies, count = self._plan_of(ids)
        touched = np.zeros(count, dtype=bool)
        hits = [body[d.contact.geom] for d, body in scenes if d.ncon]
        if hits:
            touched[np.concatenate(hits).ravel()] = True
        return touched[bodies]
