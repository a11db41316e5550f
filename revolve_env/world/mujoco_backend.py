"""The MuJoCo backend (with mujoco_scenes and mujoco_terrain, the modules that import ``mujoco``).

The scene is an :class:`mujoco.MjSpec` that one :class:`MujocoBackend` owns with the compiled
``MjModel``/``MjData`` pair. Each robot is built from the same engine-neutral
:class:`~revolve_env.world.model.RobotModel` as the pybullet backend: one body per link (same
frames), explicit masses, centres of mass and principal inertias, the same collision boxes, a
free joint at the root, unlimited hinges at the hinge anchors, welded touch-sensor halves (bodies
without a joint) and one velocity servo per active hinge.

Births and deaths edit the spec (``MjSpec.worldbody.add_body`` / ``MjSpec.delete``) and compile
it again; every surviving robot's integration state (``qpos``, ``qvel``, ``qacc_warmstart``) is
copied, slice by slice, from the old ``MjData`` to the new one (a newborn is appended after every
existing body). The survivors' state is kept bit for bit, and their trajectories do not depend on
where the newborn is (tested: a birth 0.8 m away and one 40 m away give identical survivors);
against a world with no birth at all they differ by about 1e-13 m, the summation order of a
collision pass and a constraint solve that now hold more bodies.

Settings, chosen by measurement (the five example robots over 3 + 12 s on their own brains,
fitness ``v + 5 s`` in metres; pybullet gives spider 10.2, gecko 8.9, snake 10.0, sensor crawler
0.7, bar walker 0.6):

* Integrator ``implicitfast`` at ``config.timestep`` (1/240 s = 4.2 ms by default, within the
  2-5 ms where MuJoCo is both fast and stable here). Explicit ``Euler`` at the same step: the
  snake blew up and the spider fell from 11 to 3.8. 1/120 s: the snake blew up. 1/480 s: no
  better gaits at twice the cost.
* The servo: a velocity actuator, ``force = kv * (v_target - qvel)`` clipped to the torque
  limit (see :data:`SERVO_KV`), on hinges with a gearbox armature (see :data:`HINGE_ARMATURE`).
  With kv = 0.2, armature 1e-4 and the contacts below the examples score spider 10.2, gecko 7.2,
  snake 9.8, sensor crawler 2.3, bar walker 1.4 (straight displacement 1.62, 1.04, 1.60, 0.33,
  0.17 m); a commanded hinge reaches 0.86x its top speed within one control period and settles
  on its target with no error. kv 0.5 or 1.0 gave the same rank correlation with pybullet
  (0.73) and weaker gaits.
* Solver: Newton (MuJoCo's default) converges in 2-3 iterations per step. For 30 random robots
  in one world (about 170 contacts) a physics step took 0.30 ms; CG 0.48 ms, an elliptic cone
  0.36-0.40 ms, tolerance 1e-5 or 5 iterations no faster. Making and solving the constraints
  is about 70 % of a step, collision detection 11 %.
* Contacts: stiff (time constant :data:`CONTACT_STEPS` physics steps, see there; MuJoCo's
  default 0.02 s let the light parts sink and slip), pyramidal cone (an elliptic cone with
  impratio 10, or 3 noslip iterations, ranked robots no closer to pybullet), condim 3 (sliding
  friction only, as in pybullet), the ground's friction on robot-ground contacts
  (``config.friction``) and 1.0 between robots, as in the pybullet backend. A robot never
  collides with itself (every pair of its bodies is excluded). Hinges have no limits (as in
  pybullet: the servo's target range is the limit).
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

from revolve_env.world._rotations import matrix_to_quat
from revolve_env.world.backend import BodyStates, PlacedModel, SnapshotMismatchError
from revolve_env.world.config import WorldConfig
from revolve_env.world.model import RobotModel
from revolve_env.world.mujoco_terrain import add_ground

__all__ = ["SERVO_KV", "MujocoBackend"]

#: Velocity gain of the servo actuators. N m s/rad. The servo pushes with
#: ``SERVO_KV * (v_target - qvel)`` clipped to the torque limit, so it saturates at a speed error of
#: max_torque / SERVO_KV = 0.9 rad/s: close to pybullet's velocity motor (a constraint that
#: reaches the speed within the torque limit). Measured on the examples (12 s, see the module
#: doc): 0.05 lets the servo lag, 1.0 leaves a 3 degree steady-state error and slows every gait.
SERVO_KV = 0.2
#: Rotor inertia reflected through each hinge's gearbox (MuJoCo's joint ``armature``). kg m^2.
#: The order of a hobby servo's (rotor ~5e-9 kg m^2 through a ~150:1 gear train). Without it an
#: unloaded outer link (1e-6 kg m^2) is flung 370 rad/s per physics step by a saturated servo and
#: chatters: the snake example blew up (> 200 rad/s) within half a second, the spider's hinges
#: moved 2.3x their top speed in one control period.
HINGE_ARMATURE = 1e-4
#: Contact time constant in physics steps (MuJoCo's ``solref[0]`` = CONTACT_STEPS * timestep,
#: damping ratio 1): the stiffest MuJoCo integrates safely (it clamps shorter ones to 2 steps).
#: Measured against pybullet on 200 random robots: Spearman rho of fitness 0.74 with it, 0.69
#: with MuJoCo's default 0.02 s (which lets the 10-60 g parts sink and slip: the snake example
#: walked 0.5 m straight instead of pybullet's 1.6 m; with it, 1.6 m).
CONTACT_STEPS = 2.0
_ROBOT_FRICTION = 1.0  # between two robots; the ground's friction rules robot-ground contacts


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


def _wxyz(m: NDArray[np.float64]) -> list[float]:
    x, y, z, w = matrix_to_quat(m)
    return [w, x, y, z]


def _all_finite(a: NDArray[np.float64]) -> bool:
    return math.isfinite(float(np.add.reduce(a, axis=None))) or bool(np.isfinite(a).all())


@dataclass(eq=False)  # identity: the arrays below have no truth value
class _Robot:
    """One robot's spec elements and its place in the compiled model (private)."""

    model: RobotModel
    root: mujoco.MjsBody
    excludes: list[mujoco.MjsExclude]
    actuators: list[mujoco.MjsActuator]
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
        c = self.config
        # The stiffest contacts MuJoCo keeps stable: a time constant of two physics steps.
        self._solref = [CONTACT_STEPS * c.timestep, 1.0]
        spec = mujoco.MjSpec()
        spec.modelname = "revolve_world"
        opt = spec.option
        opt.timestep = c.timestep
        opt.gravity = [0.0, 0.0, -c.gravity]
        opt.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
        ground = add_ground(spec, c.terrain)
        ground.friction = [c.friction, 0.0, 0.0]
        ground.priority = 1  # its friction rules robot-ground contacts
        ground.rgba = [0.85, 0.85, 0.8, 1.0]
        ground.solref = self._solref
        light = spec.worldbody.add_light()
        light.pos = [0.0, 0.0, 5.0]
        light.dir = [0.0, 0.0, -1.0]
        light.type = mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
        self._spec = spec
        self._model = spec.compile()
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
        self._hinge_qpos = np.zeros(0, dtype=np.intp)
        self._hinge_dofs = np.zeros(0, dtype=np.intp)
        self._torque = c.max_torque

    def _build(self, key: int, model: RobotModel, position: tuple[float, float, float],
               yaw: float) -> _Robot:
        spec = self._spec
        p = f"r{key}/"
        bodies: list[mujoco.MjsBody] = []
        for i, lk in enumerate(model.links):
            if i == 0:
                b = spec.worldbody.add_body()
                b.pos = list(position)
                b.quat = [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]
                b.add_freejoint().name = f"{p}root"
            else:
                b = bodies[lk.parent].add_body()
                b.pos = (lk.origin - model.links[lk.parent].origin).tolist()
                if not lk.fixed:
                    j = b.add_joint()
                    j.name = f"{p}j{i}"
                    j.type = mujoco.mjtJoint.mjJNT_HINGE
                    j.axis = lk.joint_axis.tolist()
                    j.limited = mujoco.mjtLimited.mjLIMITED_FALSE
                    j.armature = HINGE_ARMATURE
            b.name = f"{p}b{i}"
            b.explicitinertial = True
            b.mass = lk.mass
            b.ipos = lk.com.tolist()
            b.iquat = _wxyz(lk.inertia_axes)
            b.inertia = lk.inertia_diagonal.tolist()
            for k in range(len(lk.box_centers)):
                g = b.add_geom()
                g.type = mujoco.mjtGeom.mjGEOM_BOX
                g.size = lk.box_half_extents[k].tolist()
                g.pos = lk.box_centers[k].tolist()
                g.quat = _wxyz(lk.box_rotations[k])
                g.rgba = [*lk.box_colors[k].tolist(), 1.0]
                g.friction = [_ROBOT_FRICTION, 0.0, 0.0]
                g.condim = 3
                g.solref = self._solref
            bodies.append(b)
        excludes = []
        n = len(model.links)
        for a in range(n):
            for b_ in range(a + 1, n):
                e = spec.add_exclude()
                e.bodyname1 = f"{p}b{a}"
                e.bodyname2 = f"{p}b{b_}"
                excludes.append(e)
        actuators = []
        for link in model.active_links:
            act = spec.add_actuator()
            act.name = f"{p}a{link}"
            act.trntype = mujoco.mjtTrn.mjTRN_JOINT
            act.target = f"{p}j{link}"
            act.set_to_velocity(kv=SERVO_KV)
            act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
            act.forcerange = [-self._torque, self._torque]
            actuators.append(act)
        return _Robot(model=model, root=bodies[0], excludes=excludes, actuators=actuators,
                      bodies=np.zeros(n, dtype=np.intp))

    def _unbuild(self, robot: _Robot) -> None:
        for act in robot.actuators:
            self._spec.delete(act)
        for e in robot.excludes:
            self._spec.delete(e)
        self._spec.delete(robot.root)

    def _compile(self) -> None:
        """Compile the edited spec; carry every existing robot's state over exactly."""
        old_m, old_d = self._model, self._data
        old = {k: (r.qpos, r.dofs) for k, r in self._robots.items() if r.qpos.stop > 0}
        m = self._spec.compile()  # raises ValueError on a model MuJoCo refuses
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
        """Addresses of every robot in the freshly compiled model."""
        m = self._model
        roots_q, roots_d, hq, hd = [], [], [], []
        for key, r in self._robots.items():
            p = f"r{key}/"
            root = m.joint(f"{p}root").id
            q0, d0 = int(m.jnt_qposadr[root]), int(m.jnt_dofadr[root])
            hinges = [m.joint(f"{p}j{i}").id for i in range(1, len(r.model.links))
                      if not r.model.links[i].fixed]
            r.hinge_qpos = m.jnt_qposadr[hinges].astype(np.intp)
            r.hinge_dofs = m.jnt_dofadr[hinges].astype(np.intp)
            r.qpos = slice(q0, q0 + 7 + len(hinges))
            r.dofs = slice(d0, d0 + 6 + len(hinges))
            # a robot's joints are one contiguous block (its bodies are one subtree)
            assert all(r.qpos.start <= a < r.qpos.stop for a in r.hinge_qpos)
            r.bodies = np.array([m.body(f"{p}b{i}").id for i in range(len(r.model.links))],
                                dtype=np.intp)
            roots_q.append(q0)
            roots_d.append(d0)
            hq.append(r.hinge_qpos)
            hd.append(r.hinge_dofs)
        self._root_bodies = np.array([r.bodies[0] for r in self._robots.values()], dtype=np.intp)
        self._diverged = np.array([r.diverged for r in self._robots.values()], dtype=bool)
        self._root_qpos = np.array(roots_q, dtype=np.intp)
        self._root_dofs = np.array(roots_d, dtype=np.intp)
        self._root_lin = self._root_dofs[:, None] + _XYZ  # the free joints' linear velocities
        self._root_ang = self._root_lin + 3  # and angular velocities (body frame)
        self._diverged.flags.writeable = False
        self._hinge_qpos = np.concatenate(hq) if hq else np.zeros(0, dtype=np.intp)
        self._hinge_dofs = np.concatenate(hd) if hd else np.zeros(0, dtype=np.intp)
        # read()'s two gathers (qpos, qvel), each one fresh array for its fields
        self._read_qpos = np.concatenate(((self._root_qpos[:, None] + _XYZ).ravel(),
                                          self._hinge_qpos))
        self._read_qvel = np.concatenate((self._root_lin.ravel(), self._root_ang.ravel(),
                                          self._hinge_dofs))

    # -- robots -------------------------------------------------------------------------------
    def add(self, model: RobotModel, position: tuple[float, float, float], yaw: float) -> int:
        key = self._next_key
        robot = self._build(key, model, position, yaw)
        self._robots[key] = robot
        try:
            self._compile()
        except ValueError as e:
            del self._robots[key]
            self._unbuild(robot)
            raise ValueError(
                "MuJoCo cannot build this robot: " + " ".join(str(e).split())) from None
        self._next_key += 1
        return key

    def remove(self, key: int) -> None:
        """Delete a robot's bodies, joints, servos and exclusions from the spec and recompile.

        Nothing of it stays allocated.
        """
        robot = self._robots.pop(key)
        self._unbuild(robot)
        robot.qpos = slice(0, 0)
        self._compile()

    # -- stepping -------------------------------------------------------------------------------
    def set_joint_velocities(self, velocities: NDArray[np.float64], max_torque: float) -> None:
        if max_torque != self._torque:
            self._torque = max_torque
            self._model.actuator_forcerange[:] = (-max_torque, max_torque)
        self._views().ctrl[:] = velocities  # actuators: robots in order, each in output order

    def step(self, substeps: int) -> None:
        m, d = self._model, self._data
        v = self._views()
        mujoco.mj_getState(m, d, v.start, _SAVED)  # the period's start, should it diverge
        mujoco.mj_step(m, d, substeps)
        if not (_all_finite(v.qvel) and _all_finite(v.qpos)):
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
        """Body ids (valid until the next compile)."""
        ids: NDArray[np.intp] = self._robots[key].bodies[links]
        return ids

    def link_poses(self, ids: NDArray[np.intp]) -> tuple[NDArray[np.float64],
                                                         NDArray[np.float64]]:
        self._kinematics()
        d = self._data
        return d.xpos[ids], d.xmat[ids].reshape(-1, 3, 3)

    def touching(self, ids: NDArray[np.intp]) -> NDArray[np.bool_]:
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
        ``model_sha256``, ``state`` (``mjSTATE_INTEGRATION``), ``diverged`` (per robot),
        ``touching`` (per body).
        """
        m, d = self._model, self._data
        state = np.empty(mujoco.mj_stateSize(m, _STATE))
        mujoco.mj_getState(m, d, state, _STATE)
        return {
            "engine": "mujoco", "mujoco": mujoco.__version__, "next_key": self._next_key,
            "keys": list(self._robots), "model_sha256": self._model_digest(), "state": state,
            "diverged": np.array([r.diverged for r in self._robots.values()], dtype=bool),
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
            for (key, model, position, yaw), was_diverged in zip(robots, diverged, strict=True):
                robot = self._build(key, model, position, yaw)
                robot.diverged = bool(was_diverged)
                self._robots[key] = robot
            self._next_key = int(state["next_key"])
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
