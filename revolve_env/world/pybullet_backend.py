"""The pybullet backend (the only module of the package that imports pybullet).

One :class:`PybulletBackend` owns one pybullet client and passes ``physicsClientId`` on every
call; it never touches pybullet's implicit client 0. Each robot becomes one multibody built
directly (no URDF) from a :class:`~revolve_env.world.model.RobotModel`: one link per rigid body,
compound box collision shapes, exact masses, centres of mass and principal inertias, and revolute
joints (no limits) at the hinge anchors. Hinges are driven with pybullet's velocity motors (a
constraint that reaches the commanded speed within the torque limit). pybullet numbers a
multibody's links depth first whatever order they are given in, so they are given in that order
(:func:`pybullet_link_order`) and each robot keeps its model-link -> pybullet-link table.

pybullet has no batched calls: :meth:`PybulletBackend.read` and
:meth:`PybulletBackend.set_joint_velocities` loop over the bodies inside the backend, three engine
calls per robot and control period.

No exact snapshots: pybullet's ``saveBullet`` + ``restoreState(fileName=...)`` on a world rebuilt
with the same robots (in Bullet's own body order, which a removal permutes) restores every pose
and velocity exactly, but the continuation drifts (4.2 cm on a core after 2 s, measured with four
example robots after a death): the file does not hold the solver's warm-start and contact
caches. Online runs on pybullet therefore resume by deterministic replay.

pybullet's C code prints a build banner ("pybullet build time: ...") when it is imported, in
every process (on the installed 3.2 wheels to file descriptor 2, stderr); it is imported here with
descriptors 1 and 2 pointed at ``/dev/null`` so that our commands and workers print only their
own output.
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from revolve_env.terrain import Flat, Terrain
from revolve_env.world._rotations import matrix_to_quat, quat_to_matrix
from revolve_env.world.backend import BodyStates
from revolve_env.world.camera import FOV_DEG
from revolve_env.world.config import WorldConfig
from revolve_env.world.model import LinkModel, PlacedModel, RobotModel

__all__ = ["PybulletBackend", "pybullet_link_order"]


def _import_pybullet() -> Any:
    """Import pybullet without its build banner (see the module doc).

    The descriptors are restored even when the import fails.
    """
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(AttributeError, OSError, ValueError):
            stream.flush()
    try:
        saved = [os.dup(1), os.dup(2)]
    except OSError:  # no descriptors 1 and 2 to silence (a daemon): a plain import
        import pybullet

        return pybullet
    try:
        null = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(null, 1)
            os.dup2(null, 2)
        finally:
            os.close(null)
        import pybullet
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        os.close(saved[0])
        os.close(saved[1])
    return pybullet


pb = _import_pybullet()

_ROBOT_FRICTION = 1.0  # pybullet multiplies the two bodies' coefficients; the ground sets the value


def _add_ground(cid: int, terrain: Terrain) -> int:
    """The ground body of ``terrain``: the plane, or a heightfield of the terrain's height grid.

    Bullet splits each heightfield cell along the other diagonal than MuJoCo (and
    :mod:`~revolve_env.terrain`) does, so the grid is handed over turned a quarter turn
    and the body turned back: the same triangles. Bullet centres the field between its lowest
    and highest sample, hence the body's height.
    """
    if isinstance(terrain, Flat):
        plane = pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=cid)
        return int(pb.createMultiBody(0.0, plane, physicsClientId=cid))
    grid = terrain.heights()
    turned = np.rot90(grid, -1)
    s = terrain.spacing
    shape = pb.createCollisionShape(
        pb.GEOM_HEIGHTFIELD, meshScale=[s, s, 1.0], heightfieldData=turned.ravel().tolist(),
        numHeightfieldRows=turned.shape[1], numHeightfieldColumns=turned.shape[0],
        physicsClientId=cid)
    middle = (float(grid.min()) + float(grid.max())) / 2
    return int(pb.createMultiBody(0.0, shape, basePosition=[0.0, 0.0, middle],
                                  baseOrientation=_QUARTER_TURN, physicsClientId=cid))


_QUARTER_TURN = (0.0, 0.0, math.sin(-math.pi / 4), math.cos(-math.pi / 4))
"""A quarter turn about z (xyzw), for the pybullet heightfield."""


@dataclass
class _Body:
    """One robot's multibody (private)."""

    body: int
    model: RobotModel
    position: tuple[float, float, float]  # as placed: root link frame, metres
    yaw: float  # radians
    active_joints: list[int]  # pybullet joint indices of the active hinges, output order
    all_joints: list[int]  # pybullet joint of every hinge, in model link order
    links: NDArray[np.intp]  # pybullet link index of each model link (-1: the base)


def pybullet_link_order(model: RobotModel) -> NDArray[np.intp]:
    """The model's links after the root in the order pybullet numbers a multibody's links.

    ``createMultiBody`` renumbers the links it is given depth first from the base (children in
    the order given), whatever order they came in: a robot whose touch-sensor halves (appended
    after every rigid body by :func:`~revolve_env.world.model.build_model`) hang below another
    link would otherwise have its inertias, servos, joint readings and sensors on the wrong links.
    Handing the links over in this order makes pybullet's numbering the order itself.
    """
    children: list[list[int]] = [[] for _ in model.links]
    for i, lk in enumerate(model.links[1:], start=1):
        children[lk.parent].append(i)
    order: list[int] = []
    stack = list(reversed(children[0]))
    while stack:
        i = stack.pop()
        order.append(i)
        stack.extend(reversed(children[i]))
    return np.array(order, dtype=np.intp)


class PybulletBackend:
    """A pybullet client holding a ground plane and any number of robots (see the module doc)."""

    def __init__(self, config: WorldConfig, *, gui: bool = False) -> None:
        """Connect a fresh physics client and build the ground.

        Args:
            config: Physics settings (timestep, gravity, friction, solver iterations).
            gui: Open pybullet's window (one per process) instead of a headless client.

        Raises:
            RuntimeError: no physics server could be started, or a GUI was asked for without a
                display or while another GUI is open.
        """
        self.config = config
        self._gui = gui
        if gui and sys.platform.startswith("linux") and not (
            os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
        ):
            # pybullet's GUI would hang or abort the process without a display: refuse instead.
            raise RuntimeError("cannot open pybullet's GUI: no display (DISPLAY is not set)")
        self._cid: int = pb.connect(pb.GUI if gui else pb.DIRECT)
        if self._cid < 0:
            raise RuntimeError(
                "could not connect to a pybullet physics server"
                + (" (pybullet allows one GUI per process)" if gui else "")
            )
        self._closed = False
        self._bodies: dict[int, _Body] = {}
        self._shape_cache: dict[tuple[bytes, bytes, bytes], tuple[int, int]] = {}
        self._links: list[tuple[int, int]] = []  # link_index's table: (multibody, link)
        self._next_key = 0
        self._setup()

    def _setup(self) -> None:
        """Physics settings and the ground (on a fresh or freshly reset client)."""
        cid = self._cid
        c = self.config
        pb.setPhysicsEngineParameter(
            fixedTimeStep=c.timestep, numSubSteps=0, numSolverIterations=c.solver_iterations,
            deterministicOverlappingPairs=1, physicsClientId=cid,
        )
        pb.setGravity(0.0, 0.0, -c.gravity, physicsClientId=cid)
        if self._gui:
            pb.configureDebugVisualizer(pb.COV_ENABLE_GUI, 0, physicsClientId=cid)
        self._ground = _add_ground(cid, c.terrain)
        pb.changeDynamics(self._ground, -1, lateralFriction=c.friction, restitution=0.0,
                          physicsClientId=cid)
        pb.changeVisualShape(self._ground, -1, rgbaColor=(0.85, 0.85, 0.8, 1.0),
                             physicsClientId=cid)

    @property
    def client_id(self) -> int:
        """The pybullet client this backend owns (for benchmarks that drive it directly)."""
        return self._cid

    def body_id(self, key: int) -> int:
        """The pybullet multibody of a robot (for benchmarks that drive it directly)."""
        return self._bodies[key].body

    def reset(self) -> None:
        pb.resetSimulation(physicsClientId=self._cid)
        self._bodies.clear()
        self._shape_cache.clear()
        self._links = []
        self._setup()

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            # pb.error: already gone (e.g. the GUI window was closed).
            with contextlib.suppress(pb.error):
                pb.disconnect(physicsClientId=self._cid)

    def __del__(self) -> None:
        # Never raise from __del__: at interpreter shutdown pybullet may already be unloaded.
        with contextlib.suppress(Exception):
            self.close()

    # -- robots -------------------------------------------------------------------------------
    def _shapes(self, link: LinkModel) -> tuple[int, int]:
        """The collision and visual shapes of a link's boxes, made once per geometry.

        pybullet never frees a shape (see :meth:`remove`), so links of the same geometry, in
        any robot, share theirs; the colours are set per body (``changeVisualShape``).
        """
        key = (link.box_half_extents.tobytes(), link.box_centers.tobytes(),
               link.box_rotations.tobytes())
        shapes = self._shape_cache.get(key)
        if shapes is None:
            cid = self._cid
            boxes = {"shapeTypes": [pb.GEOM_BOX] * len(link.box_centers),
                     "halfExtents": link.box_half_extents.tolist(), "physicsClientId": cid}
            frames = [link.box_centers.tolist(), [matrix_to_quat(r) for r in link.box_rotations]]
            shapes = (
                int(pb.createCollisionShapeArray(**boxes, collisionFramePositions=frames[0],
                                                 collisionFrameOrientations=frames[1])),
                int(pb.createVisualShapeArray(**boxes, visualFramePositions=frames[0],
                                              visualFrameOrientations=frames[1])),
            )
            self._shape_cache[key] = shapes
        return shapes

    def add(self, model: RobotModel, position: tuple[float, float, float], yaw: float) -> int:
        cid = self._cid
        order = pybullet_link_order(model)  # pybullet link k is model link order[k]
        links = np.full(len(model.links), -1, dtype=np.intp)
        links[order] = np.arange(len(order))
        shapes = [self._shapes(link) for link in model.links]
        root = model.links[0]
        others = [model.links[i] for i in order.tolist()]
        base_rot = np.array([[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0],
                             [0, 0, 1.0]])
        body = pb.createMultiBody(
            baseMass=root.mass,
            baseCollisionShapeIndex=shapes[0][0],
            baseVisualShapeIndex=shapes[0][1],
            basePosition=position,
            baseOrientation=matrix_to_quat(base_rot),
            baseInertialFramePosition=root.com.tolist(),
            baseInertialFrameOrientation=matrix_to_quat(root.inertia_axes),
            linkMasses=[lk.mass for lk in others],
            linkCollisionShapeIndices=[shapes[i][0] for i in order.tolist()],
            linkVisualShapeIndices=[shapes[i][1] for i in order.tolist()],
            linkPositions=[(lk.origin - model.links[lk.parent].origin).tolist() for lk in others],
            linkOrientations=[(0.0, 0.0, 0.0, 1.0)] * len(others),
            linkInertialFramePositions=[lk.com.tolist() for lk in others],
            linkInertialFrameOrientations=[matrix_to_quat(lk.inertia_axes) for lk in others],
            # 0 = base, k = pybullet link k - 1
            linkParentIndices=[int(links[lk.parent]) + 1 for lk in others],
            linkJointTypes=[pb.JOINT_FIXED if lk.fixed else pb.JOINT_REVOLUTE for lk in others],
            linkJointAxis=[lk.joint_axis.tolist() for lk in others],
            physicsClientId=cid,
        )
        for i, lk in enumerate(model.links):
            link = int(links[i])
            pb.changeDynamics(
                body, link, lateralFriction=_ROBOT_FRICTION, restitution=0.0,
                localInertiaDiagonal=lk.inertia_diagonal.tolist(), physicsClientId=cid,
            )
            for shape, color in enumerate(lk.box_colors):  # each box in its part's colour
                pb.changeVisualShape(body, link, shapeIndex=shape, rgbaColor=(*color, 1.0),
                                     physicsClientId=cid)
        # The hinges in model link order (the order of the robot's joint states); a joint's
        # index is its link's.
        all_joints = [int(links[i]) for i, lk in enumerate(model.links) if i and not lk.fixed]
        if all_joints:
            # Free every joint first (pybullet motorizes joints by default); servos are re-driven
            # every control period.
            pb.setJointMotorControlArray(
                body, all_joints, pb.VELOCITY_CONTROL, targetVelocities=[0.0] * len(all_joints),
                forces=[0.0] * len(all_joints), physicsClientId=cid,
            )
        key = self._next_key
        self._next_key += 1
        self._links = []
        self._bodies[key] = _Body(body=body, model=model, position=position, yaw=yaw,
                                  active_joints=[int(links[i]) for i in model.active_links],
                                  all_joints=all_joints, links=links)
        return key

    def remove(self, key: int) -> None:
        """Delete a robot's multibody.

        pybullet keeps some of it: every shape (it refuses to remove a shape once a body has used
        it, "Don't remove collision shape: it is used", even after that body is gone, and has no
        call to remove visual shapes) and about 1.2 KB per link of the body's own bookkeeping
        (measured: create and remove a 9-link body with shared shapes, 11 KB per body). Links of
        the same geometry share their shapes (:meth:`_shapes`), so over 3,000 online births
        (each the child of two living robots, ``bench_engines.py --only memory``) a world grows
        16 KB per birth (+43 MB), where it grew 60 KB per birth (+158 MB) with shapes of its own
        for every link. Only ``resetSimulation`` releases the rest, and a world rebuilt after one
        does not continue exactly (see the module doc).
        """
        pb.removeBody(self._bodies.pop(key).body, physicsClientId=self._cid)
        self._links = []

    def set_hinges(self, key: int, hinges: NDArray[np.intp], angles: NDArray[np.float64],
                   velocities: NDArray[np.float64]) -> None:
        b = self._bodies[key]
        for hinge, angle, speed in zip(hinges.tolist(), angles.tolist(), velocities.tolist(),
                                       strict=True):
            pb.resetJointState(b.body, b.all_joints[hinge], angle, speed,
                               physicsClientId=self._cid)

    # -- stepping -------------------------------------------------------------------------------
    def set_joint_velocities(self, velocities: NDArray[np.float64], max_torque: float) -> None:
        cid = self._cid
        start = 0
        for b in self._bodies.values():
            n = len(b.active_joints)
            if n:
                pb.setJointMotorControlArray(
                    b.body, b.active_joints, pb.VELOCITY_CONTROL,
                    targetVelocities=velocities[start:start + n].tolist(),
                    forces=[max_torque] * n, physicsClientId=cid,
                )
                start += n

    def step(self, substeps: int) -> None:
        cid = self._cid
        for _ in range(substeps):
            pb.stepSimulation(physicsClientId=cid)

    def read(self) -> BodyStates:
        cid = self._cid
        n = len(self._bodies)
        pos = np.empty((n, 3))
        rots = np.empty((n, 3, 3))
        vel = np.empty((n, 3))
        angvel = np.empty((n, 3))
        jp: list[NDArray[np.float64]] = []
        jv: list[NDArray[np.float64]] = []
        for i, b in enumerate(self._bodies.values()):
            com, orn = pb.getBasePositionAndOrientation(b.body, physicsClientId=cid)
            v_com, w = pb.getBaseVelocity(b.body, physicsClientId=cid)
            root = b.model.links[0]
            # pybullet's base frame is the root's inertial frame: move to the link frame.
            rot = quat_to_matrix(orn) @ root.inertia_axes.T  # world <- root link frame
            ox, oy, oz = (-rot @ root.com).tolist()  # core centre minus centre of mass, world
            wx, wy, wz = w
            rots[i] = rot
            pos[i] = (com[0] + ox, com[1] + oy, com[2] + oz)
            vel[i] = (v_com[0] + wy * oz - wz * oy, v_com[1] + wz * ox - wx * oz,
                      v_com[2] + wx * oy - wy * ox)
            angvel[i] = w
            if b.all_joints:
                js = np.array([j[:2] for j in pb.getJointStates(b.body, b.all_joints,
                                                                 physicsClientId=cid)])
                jp.append(js[:, 0])
                jv.append(js[:, 1])
        empty = np.zeros(0)
        return BodyStates(
            core_pos=pos, core_rot=rots, core_vel=vel, core_angvel=angvel,
            joint_pos=np.concatenate(jp) if jp else empty,
            joint_vel=np.concatenate(jv) if jv else empty,
            diverged=np.zeros(n, dtype=bool),
        )

    # -- sensors --------------------------------------------------------------------------------
    def link_index(self, key: int, links: NDArray[np.intp]) -> NDArray[np.intp]:
        """Rows of a table of (multibody, pybullet link) pairs, emptied by every change."""
        b = self._bodies[key]
        start = len(self._links)
        self._links += [(b.body, int(b.links[link])) for link in links]
        return np.arange(start, len(self._links), dtype=np.intp)

    def link_poses(self, ids: NDArray[np.intp]) -> tuple[NDArray[np.float64],
                                                         NDArray[np.float64]]:
        pos = np.empty((len(ids), 3))
        rot = np.empty((len(ids), 3, 3))
        pairs = [self._links[i] for i in ids.tolist()]
        start = 0
        while start < len(pairs):  # one call per multibody, for its links in a row
            body = pairs[start][0]
            stop = start + 1
            while stop < len(pairs) and pairs[stop][0] == body:
                stop += 1
            states = pb.getLinkStates(body, [link for _, link in pairs[start:stop]],
                                      computeForwardKinematics=1, physicsClientId=self._cid)
            for k, s in enumerate(states, start):
                pos[k] = s[4]
                rot[k] = quat_to_matrix(s[5])
            start = stop
        return pos, rot

    def touching(self, ids: NDArray[np.intp]) -> NDArray[np.bool_]:
        touched = set()
        for c in pb.getContactPoints(physicsClientId=self._cid):  # every contact of the world
            touched.add((c[1], c[3]))
            touched.add((c[2], c[4]))
        return np.array([self._links[i] in touched for i in ids.tolist()], dtype=bool)

    def total_mass(self, key: int) -> float:
        b = self._bodies[key]
        return float(sum(
            pb.getDynamicsInfo(b.body, link, physicsClientId=self._cid)[0]
            for link in range(-1, len(b.model.links) - 1)
        ))

    def body_count(self) -> int:
        return int(pb.getNumBodies(physicsClientId=self._cid))

    def mjcf(self) -> str:
        """The robots as placed, in MuJoCo's model (:func:`~.mujoco_scene.scene_mjcf`).

        Raises:
            ImportError: the ``mujoco`` package is not installed.
        """
        from revolve_env.world.mujoco_scene import scene_mjcf  # MuJoCo only when exported

        return scene_mjcf(self.config, [PlacedModel(key, b.model, b.position, b.yaw)
                                         for key, b in self._bodies.items()])

    # -- snapshots ------------------------------------------------------------------------------
    @property
    def exact_restore(self) -> bool:
        """False: pybullet cannot continue a saved state exactly (see the module doc)."""
        return False

    def snapshot(self) -> dict[str, Any]:
        """Not available (see the module doc).

        Raises:
            NotImplementedError: always.
        """
        raise NotImplementedError("pybullet cannot restore a saved state exactly; replay instead")

    def restore(self, robots: Sequence[PlacedModel], state: dict[str, Any]) -> None:
        """Not available (see the module doc).

        Raises:
            NotImplementedError: always.
        """
        raise NotImplementedError("pybullet cannot restore a saved state exactly; replay instead")

    # -- rendering ------------------------------------------------------------------------------
    def render(self, width: int, height: int, target: tuple[float, float, float],
               distance: float, yaw_deg: float, pitch_deg: float) -> NDArray[np.uint8]:
        cid = self._cid
        view = pb.computeViewMatrixFromYawPitchRoll(
            cameraTargetPosition=list(target), distance=distance, yaw=yaw_deg, pitch=pitch_deg,
            roll=0.0, upAxisIndex=2, physicsClientId=cid,
        )
        proj = pb.computeProjectionMatrixFOV(fov=FOV_DEG, aspect=width / height, nearVal=0.01,
                                             farVal=100.0, physicsClientId=cid)
        renderer = pb.ER_BULLET_HARDWARE_OPENGL if self._gui else pb.ER_TINY_RENDERER
        _, _, rgba, _, _ = pb.getCameraImage(width, height, view, proj, renderer=renderer,
                                             physicsClientId=cid)
        return np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3].copy()

    def look_at(self, target: tuple[float, float, float], distance: float) -> None:
        if self._gui:
            pb.resetDebugVisualizerCamera(distance, 45.0, -30.0, list(target),
                                          physicsClientId=self._cid)
