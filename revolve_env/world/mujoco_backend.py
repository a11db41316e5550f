"""The MuJoCo backend (it, ``mujoco_scene``, ``_scenes`` and ``_terrain`` import ``mujoco``).

The scene is an :class:`mujoco.MjSpec` that one :class:`MujocoBackend` owns with the compiled
``MjModel``/``MjData`` pair. Each robot is built from the same engine-neutral
:class:`~revolve_env.world.model.RobotModel` as the pybullet backend: one body per link (same
frames), explicit masses, centres of mass and principal inertias, the same collision boxes, a
free joint at the root, unlimited hinges at the hinge anchors, welded touch-sensor halves (bodies
without a joint) and one velocity servo per active hinge (:mod:`~revolve_env.world.mujoco_scene`
builds them, one spec per robot, and says how a robot is kept from colliding with itself).

Births append the newborn's spec to the scene's and compile it again; deaths rebuild the scene's
spec from the survivors' specs, compiled when the scene is next stepped or its contacts read, so
that a cull of many robots compiles once (the survivors are read where they are in the previous
model meanwhile: the same state). Either way every surviving robot's integration state (``qpos``,
``qvel``, ``qacc_warmstart``) is copied, slice by slice, from the old ``MjData`` to the new one (a
newborn is appended after every existing body), and a robot's addresses in the new model come from
its layout (:class:`~revolve_env.world.mujoco_scene.RobotLayout`), not from name look-ups. The
survivors' state is kept bit for bit, and the compiled model is the one a scene of the robots
present compiles to, bit for bit (snapshots check it). Where the newborn is moves them by 1e-13 m
(a birth 0.8 m away against one 40 m away, the order of the collision pass), and its presence by
2e-7 m within 1.5 s (the solver converges over more bodies; with the integrator and islands used
before, see below: not at all, and 1e-13 m). Measured by ``benchmarks/bench_births.py`` in a world
of 30 random robots: a birth costs 9-12 ms of CPU (before: 10-14 ms), a death with its compile
11-14 ms (before 17-96 ms: hundreds of ``MjSpec.delete`` calls), a cull of 10 robots 18 ms (before
2 s). The floor is MuJoCo's compile of the whole scene, 5.5-6 ms at 30 robots and growing with the
square of the scene's size (half of it is ``mj_setConst``'s inverse weight of every body, a solve
over every degree of freedom each).

Settings, chosen by measurement (the five example robots over 3 + 12 s on their own brains,
fitness ``v + 5 s`` in metres; pybullet gives spider 10.2, gecko 8.9, snake 10.0, sensor crawler
0.7, bar walker 0.6):

* Integrator ``discrete`` at ``config.timestep`` (1/240 s = 4.2 ms by default), the one that
  solves the constraints in the same metric as the implicit velocity update (``M + h D``: the
  mass matrix plus the servos' velocity gain times the step). ``implicitfast``, used before,
  solves the contacts with ``M`` and then integrates with ``M + h D``; on a servo's hinge
  ``h D`` (0.2 N m s/rad x 4.2 ms = 8e-4 kg m^2) is eight times the gearbox armature, so a
  contact impulse between two robots' light parts is applied to their hinges with a fraction of
  its planned effect, the parts go on interpenetrating (3 mm, then 7 mm a step later, 200 N) and
  the robots are flung: the online world lost robots in pairs and triples at one instant (core
  speeds 12-430 m/s, spins 200-300 rad/s). A stress crowd (30 walking example robots packed in
  a 1 m disc, each replaced after 60 s or when lost; three 3-minute runs) lost 18 robots in 288
  lives with ``implicitfast``, none in 270 with ``discrete``. What did not help there: softer
  robot-robot contacts (a 0.02 s time constant: 7 of 7 lost again in the same run), an elliptic
  cone (7), frictionless robot-robot contacts (32), a 2 mm contact margin (22), a 1e-3 kg m^2
  armature (9), half the timestep (9, at twice the cost); explicit ``Euler`` with a 1e-3
  armature lost none but ranked robots further from pybullet (Spearman rho 0.65 on 200 random
  robots). With ``discrete`` the examples score spider 10.3, gecko 7.8, snake 10.3, sensor
  crawler 2.2, bar walker 1.5 (``implicitfast``: 10.2, 7.5, 9.8, 2.3, 1.4) and rho is 0.73
  (0.745). It costs 30 % more per physics step for one robot (17 against 13 microseconds),
  2 % more for 30 robots in a crowd and 12 % for 30 robots spread out. Constraint islands are
  disabled (``mjDSBL_ISLAND``): with them ``discrete`` cost 28 % more in the crowd, and they no
  longer kept robots' solves apart (a robot frozen after a blow-up moved a distant one by
  1e-17 m); without them a birth moves the others by 2e-7 m within 1.5 s (1e-13 m before), the
  solver converging over more bodies. 1/120 s: the snake fell from 10.3 to 5.6 and rho to 0.61.
* The servo: a velocity actuator, ``force = kv * (v_target - qvel)`` clipped to the torque
  limit (see :data:`~revolve_env.world.mujoco_scene.SERVO_KV`), on hinges with a gearbox armature
  (see :data:`~revolve_env.world.mujoco_scene.HINGE_ARMATURE`).
  With kv = 0.2, armature 1e-4 and the contacts below the examples score spider 10.2, gecko 7.2,
  snake 9.8, sensor crawler 2.3, bar walker 1.4 (straight displacement 1.62, 1.04, 1.60, 0.33,
  0.17 m; ``implicitfast``); a commanded hinge reaches 0.86x its top speed within one control
  period and settles on its target with no error. kv 0.5 or 1.0 gave the same rank correlation
  with pybullet (0.73) and weaker gaits.
* Solver: Newton (MuJoCo's default) converges in 2-3 iterations per step. For 30 random robots
  in one world (about 170 contacts) a physics step took 0.30 ms; CG 0.48 ms, an elliptic cone
  0.36-0.40 ms, tolerance 1e-5 or 5 iterations no faster. Making and solving the constraints
  is about 70 % of a step, collision detection 11 %.
* Contacts: stiff (time constant :data:`~revolve_env.world.mujoco_scene.CONTACT_STEPS` physics
  steps, see there; MuJoCo's default 0.02 s let the light parts sink and slip), pyramidal cone
  (an elliptic cone with impratio 10, or 3 noslip iterations, ranked robots no closer to
  pybullet), condim 3 (sliding friction only, as in pybullet), the ground's friction on
  robot-ground contacts (``config.friction``) and 1.0 between robots, as in the pybullet
  backend. A robot never collides with itself (collision bits, see
  :mod:`~revolve_env.world.mujoco_scene`). Hinges have no limits (as in pybullet: the servo's
  target range is the limit).
* Blow-ups: ``mjDSBL_AUTORESET`` is set, since MuJoCo would otherwise reset the *whole* scene
  when one robot's accelerations became NaN. MuJoCo's constraint solver spreads a NaN to every
  robot within the step, so a control period that ends non-finite is replayed one physics step
  at a time and the robots that caused it are put back at rest where the period started and
  reported as ``diverged`` (the world flags them as blown up); the others carry on exactly as
  if nothing had happened.

Snapshots (:meth:`MujocoBackend.snapshot` / :meth:`MujocoBackend.restore`) are exact: the scene is
rebuilt from the same robots, keys and poses in the same order and compiled once; the compiled
model must hash to the snapshot's (its MJB bytes: every array, name and option), then MuJoCo's
full integration state (``mj_getState`` with ``mjSTATE_INTEGRATION``: time, positions,
velocities, actuator state, controls, applied forces, the solver's warm start) is written back.
The bodies touching something (which MuJoCo's contact list, one physics step old after a step,
gave the touch sensors) are stored too: a fresh ``mj_forward`` would find the contacts of the
current state instead.
"""

from __future__ import annotations

import hashlib
import importlib
import math
import os
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from revolve_env.world import mujoco_scene as scene
from revolve_env.world.backend import BodyStates, PlacedModel, SnapshotMismatchError
from revolve_env.world.config import WorldConfig
from revolve_env.world.model import RobotModel
from revolve_env.world.mujoco_scene import SERVO_KV, RobotLayout, robot_layout

__all__ = ["SERVO_KV", "MujocoBackend"]

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

    def __init__(self, config: WorldConfig, *, gui: bool = False) -> None:
        """Build an empty scene.

        Args:
            config: Physics settings (timestep, gravity, friction, torque limit).
            gui: Must be False: this backend has no interactive window (use ``render``).

        Raises:
            RuntimeError: ``gui`` was asked for.
        """
        if gui:
            raise RuntimeError("the 'mujoco' engine has no GUI window in revolve-env; "
                               "use render_mode='rgb_array'")
        self.config = config
        self._robots: dict[int, _Robot] = {}
        self._next_key = 0
        self._closed = False
        self._renderer: mujoco.Renderer | None = None
        self._render_error: str | None = None
        self._new_scene()

    # -- scene ----------------------------------------------------------------------------------
    def _new_scene(self) -> None:
        self._spec = scene.scene_spec(self.config)
        self._deaths_pending = False  # see remove()
        self._model = self._spec.compile()
        self._data = mujoco.MjData(self._model)
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
        d.time = old_d.time
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
            finite = _all_finite(v.qvel) and _all_finite(v.qpos)
        except mujoco.FatalError:
            # A non-finite state reached a later physics step's collision pass: its bounding boxes
            # overlap everything and exhaust MuJoCo's arena. The data may be half-updated.
            self._data = mujoco.MjData(m)
            self._data.ctrl[:] = d.ctrl
            finite = False
        if not finite:
            self._replay(v.start.copy(), substeps)
        self._kinematics_fresh = False
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
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self._drop_renderer()

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
            keys = [key for key, _, _, _ in robots]
            if keys != list(state["keys"]):
                raise SnapshotMismatchError(f"robots {keys} do not match the snapshot's "
                                            f"{list(state['keys'])}")
            diverged = np.asarray(state["diverged"], dtype=bool)
            colors = [int(c) for c in state["colors"]]
            if not all(0 <= c <= scene.COLORS for c in colors):
                raise SnapshotMismatchError(f"the snapshot's collision bits {colors} are invalid")
            for (key, model, position, yaw), was_diverged, color in zip(robots, diverged, colors,
                                                                         strict=True):
                robot = self._build(model, position, yaw, color)
                robot.diverged = bool(was_diverged)
                self._robots[key] = robot
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
        self._renderer = None

    # -- rendering ------------------------------------------------------------------------------
    def render(self, width: int, height: int, target: tuple[float, float, float],
               distance: float, yaw_deg: float, pitch_deg: float) -> NDArray[np.uint8]:
        self._sync()
        r = self._renderer
        if r is None or r.width != width or r.height != height:
            if r is not None:
                r.close()
            if self._render_error is None and sys.platform.startswith("linux") and (
                os.environ.get("MUJOCO_GL", "glfw") == "glfw"
                and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
            ):
                # MuJoCo's default GLFW context needs a display; a failed context creation
                # followed by a second attempt aborts the whole process: never try.
                self._render_error = "no display for MuJoCo's default GLFW context"
            if self._render_error is not None:
                raise RuntimeError(f"MuJoCo cannot render here ({self._render_error}); set "
                                   "MUJOCO_GL=egl or osmesa with that library installed")
            try:
                self._model.vis.global_.offwidth = max(width, self._model.vis.global_.offwidth)
                self._model.vis.global_.offheight = max(height, self._model.vis.global_.offheight)
                r = mujoco.Renderer(self._model, height, width)
            except Exception as e:  # noqa: BLE001 (no GL context: EGL/OSMesa/GLFW all missing)
                self._render_error = str(e)  # never retried: a second failure aborts
                raise RuntimeError(f"MuJoCo cannot render here ({e}); set MUJOCO_GL=egl or "
                                   "osmesa with that library installed") from None
            self._renderer = r
        mujoco.mj_kinematics(self._model, self._data)
        camera = mujoco.MjvCamera()
        camera.lookat[:] = target
        camera.distance = distance
        # pybullet's yaw 0 looks along +y; MuJoCo's azimuth 0 along +x.
        camera.azimuth = yaw_deg - 90.0
        camera.elevation = pitch_deg
        r.update_scene(self._data, camera)
        return np.asarray(r.render(), dtype=np.uint8).copy()

    def look_at(self, target: tuple[float, float, float], distance: float) -> None:
        """No interactive window: nothing to point."""
