"""The MuJoCo backend (it, ``mujoco_scene``, ``_scenes`` and ``_terrain`` import ``mujoco``).

One :class:`MujocoBackend` owns a scene's ``MjSpec`` (one spec per robot, attached; built by
:mod:`~revolve_env.world.mujoco_scene`) and its compiled ``MjModel``/``MjData``. Births and deaths
recompile the scene and copy every survivor's integration state bit for bit; a robot whose state
turns non-finite is put back at rest and reported as ``diverged``; snapshots restore exactly (the
rebuilt model must hash to the snapshot's). The settings (the ``discrete`` integrator with islands
off, velocity servos on hinges with a gearbox armature, stiff pyramidal contacts) and the
measurements behind each: docs/engines.md, "The MuJoCo backend".
"""

from __future__ import annotations

import hashlib
import importlib
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from revolve_env.world import mujoco_scene as scene
from revolve_env.world.backend import BodyStates, SnapshotMismatchError
from revolve_env.world.config import WorldConfig
from revolve_env.world.model import PlacedModel, RobotModel
from revolve_env.world.mujoco_gl import mujoco  # its OpenGL backend chosen first
from revolve_env.world.mujoco_scene import SERVO_KV, RobotLayout, robot_layout
from revolve_env.world.mujoco_view import View, Viewer
from revolve_env.world.opengl import HOW_TO, RenderUnavailableError, has_display, render_problem

__all__ = ["SERVO_KV", "MujocoBackend", "RawScene"]

_XYZ = np.arange(3)
_STATE = int(mujoco.mjtState.mjSTATE_INTEGRATION)
#: What a control period saves to replay itself should it diverge: time, positions, velocities,
#: the solver's warm start (in that order in the saved array).
_SAVED = int(mujoco.mjtState.mjSTATE_TIME | mujoco.mjtState.mjSTATE_QPOS
             | mujoco.mjtState.mjSTATE_QVEL | mujoco.mjtState.mjSTATE_WARMSTART)
# einsum's kernel without np.einsum's dispatch, which costs twice the product for a few robots
# (the same function: np.einsum(..., optimize=False) calls it).
_c_einsum = getattr(importlib.import_module("numpy._core.multiarray"), "c_einsum", np.einsum)


class _Views:
    """NumPy views of one ``MjData``'s arrays, made once (each attribute access makes a new one)."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self.data = data
        self.qpos: NDArray[np.float64] = data.qpos
        self.qvel: NDArray[np.float64] = data.qvel
        self.xpos: NDArray[np.float64] = data.xpos
        self.xmat: NDArray[np.float64] = data.xmat
        self.ctrl: NDArray[np.float64] = data.ctrl
        self.start = np.empty(mujoco.mj_stateSize(model, _SAVED))


def _all_finite(a: NDArray[np.float64]) -> bool:
    return math.isfinite(float(np.add.reduce(a, axis=None))) or bool(np.isfinite(a).all())


@dataclass(frozen=True, eq=False)
class RawScene:
    """A compiled scene as C code steps it (:meth:`MujocoBackend.raw_scene`).

    Valid while :meth:`MujocoBackend.scene_version` gives ``version``: a compile, a death, a new
    ``MjData`` or a robot found diverged makes another.

    Attributes:
        model: The ``mjModel*`` address.
        data: The ``mjData*`` address.
        version: Which scene this is.
        root_bodies: (n,) each robot's root body.
        root_qpos: (n,) each robot's free joint's first qpos.
        root_dofs: (n,) and first dof.
        hinge_qpos: Every robot's hinges' qpos, robots in order (``BodyStates.joint_pos``).
        hinge_dofs: Their dofs.
        start: Where a period's start (time, qpos, qvel, warm start) is saved for its replay.
        diverged: (n,) robots the backend found non-finite and put at rest
            (``BodyStates.diverged``).
    """

    model: int
    data: int
    version: int
    root_bodies: NDArray[np.intp]
    root_qpos: NDArray[np.intp]
    root_dofs: NDArray[np.intp]
    hinge_qpos: NDArray[np.intp]
    hinge_dofs: NDArray[np.intp]
    start: NDArray[np.float64]
    diverged: NDArray[np.bool_]


@dataclass(eq=False)  # identity: the arrays below have no truth value
class _Robot:
    """One robot's spec and its place in the compiled model (private)."""

    model: RobotModel
    spec: mujoco.MjSpec  # the robot alone (local names), attached under r<key>/
    color: int  # its collision bit (mujoco_scene.COLORS: the shared one)
    layout: RobotLayout
    # refreshed after every compile
    bodies: NDArray[np.intp]  # body id of each model link
    # the robot's qpos (free joint, then hinges in body order) and dofs
    qpos: slice = field(default_factory=lambda: slice(0, 0))
    dofs: slice = field(default_factory=lambda: slice(0, 0))
    hinge_qpos: NDArray[np.intp] = field(default_factory=lambda: np.zeros(0, dtype=np.intp))
    hinge_dofs: NDArray[np.intp] = field(default_factory=lambda: np.zeros(0, dtype=np.intp))
    diverged: bool = False


class MujocoBackend:
    """A MuJoCo scene holding a ground plane and any number of robots (see the module doc)."""

    def __init__(self, config: WorldConfig, *, gui: bool = False,
                 compile_empty: bool = True) -> None:
        """Build an empty scene.

        Args:
            config: Physics settings (timestep, gravity, friction, torque limit).
            gui: Show the scene in MuJoCo's own window (opened at the first ``look_at``).
            compile_empty: Compile the empty scene now. False for a scene whose first robot is
                added next (an isolated world's: :mod:`.mujoco_scenes`), compiled with it; until
                then nothing but :meth:`add` and :meth:`close` may be called.

        Raises:
            RuntimeError: ``gui`` was asked for without a display.
        """
        if gui and not has_display():
            raise RuntimeError("cannot open MuJoCo's window: no display ($DISPLAY is unset)")
        self.config = config
        self._robots: dict[int, _Robot] = {}
        self._next_key = 0
        self._version = 0  # see scene_version()
        self._closed = False
        self._view: View | None = None
        self._viewer: Viewer | None = Viewer() if gui else None
        self._render_error: str | None = None
        self._new_scene(compile_empty)

    # -- scene ----------------------------------------------------------------------------------
    def _new_scene(self, compile_it: bool = True) -> None:
        self._version += 1
        self._spec = scene.scene_spec(self.config)
        self._deaths_pending = False  # see remove()
        # Not compiled: the first add() compiles the scene with its robot (the same model).
        self._model: mujoco.MjModel = self._spec.compile() if compile_it else None
        self._data: mujoco.MjData = mujoco.MjData(self._model) if compile_it else None
        self._kinematics_fresh = False
        self._touching: NDArray[np.bool_] | None = None
        self._root_qpos = np.zeros(0, dtype=np.intp)
        self._root_bodies = np.zeros(0, dtype=np.intp)
        self._diverged = np.zeros(0, dtype=bool)
        self._root_dofs = np.zeros(0, dtype=np.intp)
        self._root_lin = np.zeros((0, 3), dtype=np.intp)
        self._root_ang = np.zeros((0, 3), dtype=np.intp)
        self._read_qpos = np.zeros(0, dtype=np.intp)
        self._read_qvel = np.zeros(0, dtype=np.intp)
        self._cached_views: _Views | None = None
        self._future: dict[int, int] | None = None  # see link_index()
        self._hinge_qpos = np.zeros(0, dtype=np.intp)
        self._hinge_dofs = np.zeros(0, dtype=np.intp)
        self._torque = self.config.max_torque

    def _build(self, model: RobotModel, position: tuple[float, float, float], yaw: float,
               color: int | None = None) -> _Robot:
        """A robot's spec, with the lowest free collision bit unless ``color`` is given."""
        if color is None:
            taken = {r.color for r in self._robots.values()}
            color = next((c for c in range(scene.COLORS) if c not in taken), scene.COLORS)
        spec = scene.robot_spec(model, position, yaw, self.config, color)
        layout = robot_layout(model)
        return _Robot(model=model, spec=spec, color=color, layout=layout,
                      bodies=np.zeros(layout.nbody, dtype=np.intp))

    def _rebuild(self) -> None:
        """A fresh scene spec holding every robot, in order (instead of deleting elements)."""
        self._spec = scene.scene_spec(self.config)
        for key, robot in self._robots.items():
            scene.attach(self._spec, robot.spec, key)

    def _sync(self) -> None:
        """Compile the scene without the robots removed since the last compile, if any."""
        if self._deaths_pending:
            self._rebuild()
            self._compile()

    def _compile(self) -> None:
        """Compile the edited spec; carry every existing robot's state over exactly."""
        old_m, old_d = self._model, self._data
        old = {k: (r.qpos, r.dofs) for k, r in self._robots.items() if r.qpos.stop > 0}
        m = self._spec.compile()  # raises ValueError on a model MuJoCo refuses
        self._deaths_pending = False
        self._torque = self.config.max_torque  # the servos' limit as compiled
        d = mujoco.MjData(m)
        self._model, self._data = m, d
        self._index()
        d.time = old_d.time if old_d is not None else 0.0  # None: the scene's first compile
        for key, (qpos, dofs) in old.items():
            r = self._robots[key]
            d.qpos[r.qpos] = old_d.qpos[qpos]
            d.qvel[r.dofs] = old_d.qvel[dofs]
        mujoco.mj_forward(m, d)  # poses and contacts of the new scene for the sensors
        for key, (_, dofs) in old.items():  # after mj_forward: the solver's warm start
            d.qacc_warmstart[self._robots[key].dofs] = old_d.qacc_warmstart[dofs]
        self._kinematics_fresh = True
        self._touching = None
        self._drop_renderer()  # it holds the old model
        del old_m

    def _index(self) -> None:
        """Addresses of every robot in the freshly compiled model (see ``RobotLayout``)."""
        body = 1  # the world body comes first
        q0 = d0 = 0
        for r in self._robots.values():
            lay = r.layout
            r.bodies = body + lay.bodies
            r.qpos = slice(q0, q0 + lay.nq)
            r.dofs = slice(d0, d0 + lay.nv)
            r.hinge_qpos = q0 + lay.hinge_qpos
            r.hinge_dofs = d0 + lay.hinge_dofs
            body += lay.nbody
            q0 += lay.nq
            d0 += lay.nv
        m = self._model
        assert (body, q0, d0) == (m.nbody, m.nq, m.nv), "robot layouts do not fit the model"
        self._arrays()

    def _arrays(self) -> None:
        """The index arrays over every robot, from each robot's addresses."""
        robots = self._robots.values()
        self._root_bodies = np.array([r.bodies[0] for r in robots], dtype=np.intp)
        self._diverged = np.array([r.diverged for r in robots], dtype=bool)
        self._diverged.flags.writeable = False
        self._root_qpos = np.array([r.qpos.start for r in robots], dtype=np.intp)
        self._root_dofs = np.array([r.dofs.start for r in robots], dtype=np.intp)
        self._root_lin = self._root_dofs[:, None] + _XYZ  # the free joints' linear velocities
        self._root_ang = self._root_lin + 3  # and angular velocities (body frame)
        none = np.zeros(0, dtype=np.intp)
        self._hinge_qpos = np.concatenate([r.hinge_qpos for r in robots]) if robots else none
        self._hinge_dofs = np.concatenate([r.hinge_dofs for r in robots]) if robots else none
        # read()'s two gathers (qpos, qvel), each one fresh array for its fields
        self._read_qpos = np.concatenate(((self._root_qpos[:, None] + _XYZ).ravel(),
                                          self._hinge_qpos))
        self._read_qvel = np.concatenate((self._root_lin.ravel(), self._root_ang.ravel(),
                                          self._hinge_dofs))
        self._future = None  # a death changes where the survivors' bodies will be
        self._version += 1

    # -- robots -------------------------------------------------------------------------------
    def add(self, model: RobotModel, position: tuple[float, float, float], yaw: float) -> int:
        key = self._next_key
        robot = self._build(model, position, yaw)
        if self._deaths_pending:
            self._rebuild()
        self._robots[key] = robot
        scene.attach(self._spec, robot.spec, key)
        try:
            self._compile()
        except ValueError as e:
            del self._robots[key]
            self._rebuild()  # the model is unchanged (with any robots removed before)
            raise ValueError(
                "MuJoCo cannot build this robot: " + " ".join(str(e).split())) from None
        self._next_key += 1
        return key

    def remove(self, key: int) -> None:
        """Take a robot out; the scene is rebuilt without it and compiled when next needed.

        Deaths are batched: until the next birth, step, contact read, snapshot or picture, the
        survivors are read where they are in the current model (their state is the same), so a
        cull of many robots compiles once. Nothing of a removed robot stays allocated after that
        compile.
        """
        del self._robots[key]
        self._arrays()
        self._deaths_pending = True

    def set_hinges(self, key: int, hinges: NDArray[np.intp], angles: NDArray[np.float64],
                   velocities: NDArray[np.float64]) -> None:
        self._sync()
        r = self._robots[key]
        d = self._data
        d.qpos[r.hinge_qpos[hinges]] = angles
        d.qvel[r.hinge_dofs[hinges]] = velocities
        mujoco.mj_kinematics(self._model, d)  # the links where the hinges now put them
        self._kinematics_fresh = True
        self._touching = None

    # -- stepping -------------------------------------------------------------------------------
    def set_joint_velocities(self, velocities: NDArray[np.float64], max_torque: float) -> None:
        self._sync()
        if max_torque != self._torque:
            self._torque = max_torque
            self._model.actuator_forcerange[:] = (-max_torque, max_torque)
        self._views().ctrl[:] = velocities  # actuators: robots in order, each in output order

    def step(self, substeps: int) -> None:
        self._sync()
        m, d = self._model, self._data
        v = self._views()
        mujoco.mj_getState(m, d, v.start, _SAVED)  # the period's start, should it diverge
        try:
            mujoco.mj_step(m, d, substeps)
            stepped = "calm" if _all_finite(v.qvel) and _all_finite(v.qpos) else "replay"
        except mujoco.FatalError:
            stepped = "restart"
        self.stepped(stepped, substeps)
        self._kinematics_fresh = False

    # -- the compiled step (revolve_env.world.compiled) ------------------------------------------
    def scene_version(self) -> int:
        """Which compiled scene steps now (deaths pending compiled first): see :class:`RawScene`."""
        self._sync()
        return self._version

    def raw_scene(self) -> RawScene:
        """The compiled scene for C code that steps it (the servos' torque limit set first)."""
        self._sync()
        if self._torque != self.config.max_torque:
            self._torque = self.config.max_torque
            self._model.actuator_forcerange[:] = (-self._torque, self._torque)
        return RawScene(self._model._address, self._data._address, self._version,
                        self._root_bodies, self._root_qpos, self._root_dofs, self._hinge_qpos,
                        self._hinge_dofs, self._views().start, self._diverged)

    def stepped(self, outcome: str, substeps: int) -> None:
        """After a control period of ``substeps`` stepped from the state saved in its start.

        ``outcome``: "calm" (a finite state, its body poses computed), "replay" (a state that
        is not finite) or "restart" (``mj_step`` failed: the data may be half-updated); the last
        two replay the period (:meth:`_replay`).
        """
        if outcome != "calm":
            start = self._views().start.copy()
            if outcome == "restart":
                # A non-finite state reached a later physics step's collision pass: its bounding
                # boxes overlap everything and exhaust MuJoCo's arena.
                d = self._data
                self._data = mujoco.MjData(self._model)
                self._data.ctrl[:] = d.ctrl
                self._version += 1
            self._replay(start, substeps)
        self._kinematics_fresh = outcome == "calm"
        self._touching = None

    def _views(self) -> _Views:
        """NumPy views of the current ``MjData``'s arrays (remade after every compile)."""
        v = self._cached_views
        if v is None or v.data is not self._data:
            v = self._cached_views = _Views(self._model, self._data)
        return v

    def _save(self) -> NDArray[np.float64]:
        """Time, positions, velocities and the solver's warm start (``_SAVED``) now."""
        state = np.empty(mujoco.mj_stateSize(self._model, _SAVED))
        mujoco.mj_getState(self._model, self._data, state, _SAVED)
        return state

    def _load(self, state: NDArray[np.float64]) -> None:
        mujoco.mj_setState(self._model, self._data, state, _SAVED)

    def _replay(self, start: NDArray[np.float64], substeps: int) -> None:
        """Redo a control period whose end state is not finite, one physics step at a time.

        MuJoCo's constraint solver spreads a NaN from one robot to every robot of the scene
        within the step, so after a step that went wrong: go back to its start, put the robots
        that caused it (non-finite state or unconstrained acceleration) back to their pose at the
        start of the period, at rest, mark them diverged and redo the step without them.
        """
        m, d = self._model, self._data
        nq = m.nq
        start_qpos = start[1:1 + nq]  # _SAVED's layout: time, qpos, qvel, warm start
        self._load(start)
        for _ in range(substeps):
            before = self._save()
            before_qpos, before_qvel = before[1:1 + nq], before[1 + nq:1 + nq + m.nv]
            mujoco.mj_step(m, d)
            if _all_finite(d.qvel) and _all_finite(d.qpos):
                continue
            culprits = [r for r in self._robots.values()
                        if not (_all_finite(before_qpos[r.qpos])
                                and _all_finite(before_qvel[r.dofs])
                                and _all_finite(d.qacc_smooth[r.dofs]))]
            if culprits:
                self._load(before)
                for r in culprits:
                    self._still(r, start_qpos)
                mujoco.mj_step(m, d)
            for r in self._robots.values():  # whatever is still not finite
                if not (_all_finite(d.qpos[r.qpos]) and _all_finite(d.qvel[r.dofs])):
                    self._still(r, start_qpos)

    def _still(self, r: _Robot, qpos: NDArray[np.float64]) -> None:
        """Put a robot at rest at its pose in ``qpos`` and mark it diverged."""
        d = self._data
        d.qpos[r.qpos] = qpos[r.qpos]
        d.qvel[r.dofs] = 0.0
        d.qacc_warmstart[r.dofs] = 0.0
        r.diverged = True
        self._version += 1  # a new diverged array (RawScene)
        diverged = self._diverged.copy()  # a new array: earlier reads keep what they saw
        diverged[list(self._robots.values()).index(r)] = True
        diverged.flags.writeable = False
        self._diverged = diverged

    def _kinematics(self) -> None:
        """Body poses of the current state (``mj_step`` leaves them one physics step old)."""
        if not self._kinematics_fresh:
            mujoco.mj_kinematics(self._model, self._data)
            self._kinematics_fresh = True

    def read(self) -> BodyStates:
        self._kinematics()
        v = self._views()
        n = self._root_bodies.shape[0]
        q = v.qpos[self._read_qpos]  # the roots' positions (a free joint's body sits at its
        w = v.qvel[self._read_qvel]  # first three qpos), hinges; velocities, spins, hinge speeds
        rot = v.xmat[self._root_bodies].reshape(-1, 3, 3)
        return BodyStates(
            core_pos=q[:3 * n].reshape(n, 3),  # the root body frame: the core centre
            core_rot=rot,
            core_vel=w[:3 * n].reshape(n, 3),  # the free joint: the root frame origin's, world
            core_angvel=_c_einsum("nij,nj->ni", rot, w[3 * n:6 * n].reshape(n, 3)),  # MuJoCo:
            joint_pos=q[3 * n:],  # body frame
            joint_vel=w[6 * n:],
            diverged=self._diverged,
        )

    # -- sensors --------------------------------------------------------------------------------
    def link_index(self, key: int, links: NDArray[np.intp]) -> NDArray[np.intp]:
        """Body ids in the scene of the robots present (valid until the next add or remove).

        With deaths pending (see :meth:`remove`), the ids of the model they will compile to:
        :meth:`link_poses` and :meth:`touching` compile it before they read.
        """
        robot = self._robots[key]
        if not self._deaths_pending:
            ids: NDArray[np.intp] = robot.bodies[links]
            return ids
        if self._future is None:  # each robot's first body, the robots laid out in order
            self._future, body = {}, 1
            for k, r in self._robots.items():
                self._future[k] = body
                body += r.layout.nbody
        future: NDArray[np.intp] = self._future[key] + robot.layout.bodies[links]
        return future

    def link_poses(self, ids: NDArray[np.intp]) -> tuple[NDArray[np.float64],
                                                         NDArray[np.float64]]:
        self._sync()  # the ids are those of the scene without the robots removed
        self._kinematics()
        d = self._data
        return d.xpos[ids], d.xmat[ids].reshape(-1, 3, 3)

    def touching(self, ids: NDArray[np.intp]) -> NDArray[np.bool_]:
        self._sync()  # the contacts of the scene without the robots removed
        touching: NDArray[np.bool_] = self._touching_now()[ids]
        return touching

    def total_mass(self, key: int) -> float:
        return float(self._model.body_subtreemass[self._robots[key].bodies[0]])

    def body_count(self) -> int:
        return 1 + len(self._robots)

    def reset(self) -> None:
        self._robots.clear()
        self._new_scene()
        self._drop_renderer()

    def _drop_renderer(self) -> None:
        if self._view is not None:
            self._view.close()
            self._view = None

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self._drop_renderer()
            if self._viewer is not None:
                self._viewer.close()

    # -- snapshots ------------------------------------------------------------------------------
    @property
    def exact_restore(self) -> bool:
        """True: :meth:`restore` continues a snapshot bit for bit (see the module doc)."""
        return True

    def mjcf(self) -> str:
        """MJCF that compiles to the model this backend steps (see :func:`.mujoco_scene.mjcf`)."""
        return scene.mjcf(scene.scene_spec(self.config),
                          [(key, r.spec) for key, r in self._robots.items()])

    def _model_digest(self) -> str:
        """SHA-256 of the compiled model's MJB bytes (every array, name and option)."""
        buffer = np.zeros(mujoco.mj_sizeModel(self._model), dtype=np.uint8)
        mujoco.mj_saveModel(self._model, None, buffer)
        return hashlib.sha256(buffer.tobytes()).hexdigest()

    def _touching_now(self) -> NDArray[np.bool_]:
        if self._touching is None:
            d = self._data
            touching = np.zeros(self._model.nbody, dtype=bool)
            if d.ncon:
                touching[self._model.geom_bodyid[d.contact.geom[: d.ncon]].ravel()] = True
            self._touching = touching
        return self._touching

    def snapshot(self) -> dict[str, Any]:
        """The scene's state now (see the module doc): plain data and NumPy arrays.

        Keys: ``engine``, ``mujoco`` (version), ``next_key``, ``keys`` (robots in order),
        ``model_sha256``, ``state`` (``mjSTATE_INTEGRATION``), ``diverged`` and ``colors``
        (per robot: blown up, collision bit), ``touching`` (per body).
        """
        self._sync()
        m, d = self._model, self._data
        state = np.empty(mujoco.mj_stateSize(m, _STATE))
        mujoco.mj_getState(m, d, state, _STATE)
        return {
            "engine": "mujoco", "mujoco": mujoco.__version__, "next_key": self._next_key,
            "keys": list(self._robots), "model_sha256": self._model_digest(), "state": state,
            "diverged": np.array([r.diverged for r in self._robots.values()], dtype=bool),
            "colors": [r.color for r in self._robots.values()],
            "touching": self._touching_now().copy(),
        }

    def restore(self, robots: Sequence[PlacedModel], state: dict[str, Any]) -> None:
        """Rebuild the scene from ``robots`` and put it in the snapshot's state, exactly.

        Raises:
            SnapshotMismatchError: another engine or MuJoCo version, other robots, or a compiled
                model that differs from the snapshot's (the backend is empty then).
        """
        self.reset()
        try:
            if state.get("engine") != "mujoco" or state.get("mujoco") != mujoco.__version__:
                raise SnapshotMismatchError(
                    f"the snapshot is of {state.get('engine')} {state.get('mujoco')}, not mujoco "
                    f"{mujoco.__version__}")
            keys = [r.key for r in robots]
            if keys != list(state["keys"]):
                raise SnapshotMismatchError(f"robots {keys} do not match the snapshot's "
                                            f"{list(state['keys'])}")
            diverged = np.asarray(state["diverged"], dtype=bool)
            colors = [int(c) for c in state["colors"]]
            if not all(0 <= c <= scene.COLORS for c in colors):
                raise SnapshotMismatchError(f"the snapshot's collision bits {colors} are invalid")
            for placed, was_diverged, color in zip(robots, diverged, colors, strict=True):
                robot = self._build(placed.model, placed.position, placed.yaw, color)
                robot.diverged = bool(was_diverged)
                self._robots[placed.key] = robot
            self._next_key = int(state["next_key"])
            self._rebuild()
            self._compile()
            m, d = self._model, self._data
            if self._model_digest() != state["model_sha256"]:
                raise SnapshotMismatchError("the rebuilt MuJoCo model differs from the snapshot's")
            values = np.ascontiguousarray(state["state"], dtype=np.float64)
            if values.shape != (mujoco.mj_stateSize(m, _STATE),):
                raise SnapshotMismatchError("the snapshot's state does not fit the rebuilt model")
            touching = np.asarray(state["touching"], dtype=bool)
            if touching.shape != (m.nbody,):
                raise SnapshotMismatchError("the snapshot's contacts do not fit the rebuilt model")
            mujoco.mj_setState(m, d, values, _STATE)
            mujoco.mj_forward(m, d)  # poses for the sensors
            mujoco.mj_setState(m, d, values, _STATE)  # the warm start exactly as saved
        except (SnapshotMismatchError, ValueError, KeyError, TypeError) as e:
            self.reset()
            if isinstance(e, SnapshotMismatchError):
                raise
            raise SnapshotMismatchError(f"cannot restore the MuJoCo snapshot: {e}") from e
        self._kinematics_fresh = True
        self._touching = touching.copy()
        self._drop_renderer()

    # -- rendering ------------------------------------------------------------------------------
    def render(self, width: int, height: int, target: tuple[float, float, float],
               distance: float, yaw_deg: float, pitch_deg: float) -> NDArray[np.uint8]:
        """A frame of the scene with a grid on the ground (:mod:`.mujoco_view`; looks only).

        Raises:
            RenderUnavailableError: no OpenGL context here (one line: what to install or set).
        """
        self._sync()
        view = self._view
        if view is None or view.physics is not self._model or (view.width, view.height) != (
                width, height):
            self._drop_renderer()
            if self._render_error is None:
                # MuJoCo's default GLFW context without a display: a failed context creation
                # followed by a second attempt aborts the whole process, so never try.
                self._render_error = render_problem()
            if self._render_error is not None:
                raise RenderUnavailableError(self._render_error)
            try:
                view = View(self._model, self._spec, width, height)
            except Exception as e:  # noqa: BLE001 (no GL context: EGL/OSMesa/GLFW all missing)
                gl, why = os.environ.get("MUJOCO_GL", "glfw"), " ".join(str(e).split())
                self._render_error = (f"MuJoCo cannot render here with MUJOCO_GL={gl} ({why}); "
                                      f"{HOW_TO}")  # never retried: a second failure aborts
                raise RenderUnavailableError(self._render_error) from None
            self._view = view
        return view.frame(self._data.qpos, target, distance, yaw_deg, pitch_deg)

    def look_at(self, target: tuple[float, float, float], distance: float) -> None:
        """Draw the scene now in MuJoCo's window (with ``gui``; else nothing)."""
        if self._viewer is not None:
            self._sync()
            self._viewer.show(self._model, self._spec, self._data.qpos, target, distance)
