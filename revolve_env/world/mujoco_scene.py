"""The MuJoCo model of a scene: one ``MjSpec`` per robot, the world's spec made of them, its MJCF.

Part of the MuJoCo backend (with :mod:`revolve_env.world.mujoco_backend`, the only modules that
import ``mujoco``). A robot's spec is built once, at its birth, from the engine-neutral
:class:`~revolve_env.world.model.RobotModel` with names local to it (``b3``: the body of link 3,
``root``, ``j3``, ``a3``), and copied into the world's spec under the prefix ``r<key>/``
(``MjSpec.attach``). A death rebuilds the world's spec from the survivors' specs (a fresh scene and
one ``attach`` each: 3-5 ms for 30 robots, an attach costing 0.02 ms plus 0.006 ms per robot
already in the scene) rather than deleting elements: ``MjSpec.delete`` costs 1-7 ms per body or
actuator in a 30-robot world (measured on MuJoCo 4.0), so a death cost 5-20 ms before the
compile, and its self-collision exclusions (n (n - 1) / 2 per robot) another 30-130 ms. The
compiled model is the same either way, bit for bit (every name, array and option).

**Self-collisions.** A robot never collides with itself, and collides with the ground and every
other robot. Each living robot gets a collision bit of its own (its *colour*, the lowest free one
of :data:`COLORS`, kept for life): its geoms have ``contype = 1 << colour`` and ``conaffinity`` =
every bit but its own, so two geoms of one robot never pass MuJoCo's filter and geoms of different
robots always do; the ground has every bit. With more than :data:`COLORS` robots alive, the others
share one more bit, which collides with itself, and exclude every pair of their own bodies as all
robots did before. MuJoCo's collision filter drops the same pairs either way: a crowd of 36
touching robots with births and deaths, and the five examples alone, gave trajectories identical
bit for bit to those of the exclusions every robot had before.

:func:`mjcf` writes a scene as MJCF that ``mujoco.MjModel.from_xml_string`` compiles to the very
model the backend steps (the same MJB bytes): every number is written with the shortest text that
reads back to the same double (``repr``), where ``MjSpec.to_xml`` keeps 6 significant digits.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from xml.sax.saxutils import quoteattr

import numpy as np
from numpy.typing import NDArray

from revolve_env.world._rotations import matrix_to_quat
from revolve_env.world.config import WorldConfig
from revolve_env.world.model import PlacedModel, RobotModel
from revolve_env.world.mujoco_gl import mujoco  # its OpenGL backend chosen first
from revolve_env.world.mujoco_terrain import add_ground

__all__ = ["COLORS", "CONTACT_STEPS", "HINGE_ARMATURE", "SERVO_KV", "RobotLayout", "attach",
           "mjcf", "robot_layout", "robot_spec", "scene_mjcf", "scene_spec"]

#: Velocity gain of the servo actuators. N m s/rad. The servo pushes with
#: ``SERVO_KV * (v_target - qvel)`` clipped to the torque limit, so it saturates at a speed error of
#: max_torque / SERVO_KV = 0.9 rad/s: close to pybullet's velocity motor (a constraint that
#: reaches the speed within the torque limit). Measured on the examples (12 s, see the backend
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
#: Friction between two robots (the ground's priority makes ``config.friction`` rule robot-ground
#: contacts), as in the pybullet backend.
ROBOT_FRICTION = 1.0
#: Robots with a collision bit of their own (see the module doc); the others share bit COLORS.
COLORS = 30
_EVERY_BIT = (1 << (COLORS + 1)) - 1


def _wxyz(m: NDArray[np.float64]) -> list[float]:
    x, y, z, w = matrix_to_quat(m)
    return [w, x, y, z]


def scene_spec(config: WorldConfig) -> mujoco.MjSpec:
    """A scene without robots: options, the ground (``config.terrain``) and the light."""
    spec = mujoco.MjSpec()
    spec.modelname = "revolve_world"
    spec.copy_during_attach = True  # robots' specs are attached again at every rebuild
    opt = spec.option
    opt.timestep = config.timestep
    opt.gravity = [0.0, 0.0, -config.gravity]
    opt.integrator = mujoco.mjtIntegrator.mjINT_DISCRETE  # these two: see docs/engines.md
    opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET | mujoco.mjtDisableBit.mjDSBL_ISLAND
    ground = add_ground(spec, config.terrain)  # the plane or the terrain's heightfield
    ground.friction = [config.friction, 0.0, 0.0]
    ground.priority = 1  # its friction rules robot-ground contacts
    ground.rgba = [0.85, 0.85, 0.8, 1.0]
    ground.solref = _solref(config)
    ground.contype = ground.conaffinity = _EVERY_BIT
    light = spec.worldbody.add_light()
    light.pos = [0.0, 0.0, 5.0]
    light.dir = [0.0, 0.0, -1.0]
    light.type = mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
    return spec


def _solref(config: WorldConfig) -> list[float]:
    return [CONTACT_STEPS * config.timestep, 1.0]


def robot_spec(model: RobotModel, position: tuple[float, float, float], yaw: float,
               config: WorldConfig, color: int) -> mujoco.MjSpec:
    """One robot alone, at rest, its root link frame at ``position`` turned by ``yaw`` (radians).

    Names are local (see the module doc); ``color`` is its collision bit (``COLORS``: the shared
    one, with the robot's own body pairs excluded).
    """
    spec = mujoco.MjSpec()
    own = 1 << color
    contype, conaffinity = own, (_EVERY_BIT if color == COLORS else _EVERY_BIT & ~own)
    solref = _solref(config)
    bodies: list[mujoco.MjsBody] = []
    for i, lk in enumerate(model.links):
        if i == 0:
            b = spec.worldbody.add_body()
            b.pos = list(position)
            b.quat = [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]
            b.add_freejoint().name = "root"
        else:
            b = bodies[lk.parent].add_body()
            b.pos = (lk.origin - model.links[lk.parent].origin).tolist()
            if not lk.fixed:
                j = b.add_joint()
                j.name = f"j{i}"
                j.type = mujoco.mjtJoint.mjJNT_HINGE
                j.axis = lk.joint_axis.tolist()
                j.limited = mujoco.mjtLimited.mjLIMITED_FALSE
                j.armature = HINGE_ARMATURE
        b.name = f"b{i}"
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
            g.friction = [ROBOT_FRICTION, 0.0, 0.0]
            g.condim = 3
            g.solref = solref
            g.contype, g.conaffinity = contype, conaffinity
        bodies.append(b)
    if color == COLORS:
        n = len(model.links)
        for a in range(n):
            for b_ in range(a + 1, n):
                e = spec.add_exclude()
                e.bodyname1 = f"b{a}"
                e.bodyname2 = f"b{b_}"
    for link in model.active_links:
        act = spec.add_actuator()
        act.name = f"a{link}"
        act.trntype = mujoco.mjtTrn.mjTRN_JOINT
        act.target = f"j{link}"
        act.set_to_velocity(kv=SERVO_KV)
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.forcerange = [-config.max_torque, config.max_torque]
    return spec


def attach(scene: mujoco.MjSpec, robot: mujoco.MjSpec, key: int) -> None:
    """Copy a robot's spec into ``scene`` after everything in it, under the prefix ``r<key>/``."""
    scene.attach(robot, prefix=f"r{key}/", frame=scene.worldbody.add_frame())


@dataclass(frozen=True, slots=True)
class RobotLayout:
    """Where a robot's elements sit in a compiled model, relative to its first of each.

    MuJoCo numbers bodies depth-first through the spec's tree (children in the order they were
    added: link order here), joints and degrees of freedom in body order, and a robot's elements
    are contiguous, so a robot's addresses are these offsets plus its first body, qpos and dof.

    Attributes:
        bodies: Body offset of each model link.
        hinge_qpos: qpos offset of each hinge (model link order, as in ``BodyStates``).
        hinge_dofs: Degree-of-freedom offset of each hinge.
        nbody: Bodies of the robot.
        nq: Its qpos entries (the free joint's 7, then one per hinge).
        nv: Its degrees of freedom (6, then one per hinge).
    """

    bodies: NDArray[np.intp]
    hinge_qpos: NDArray[np.intp]
    hinge_dofs: NDArray[np.intp]
    nbody: int
    nq: int
    nv: int


def robot_layout(model: RobotModel) -> RobotLayout:
    """The :class:`RobotLayout` of the spec :func:`robot_spec` builds for ``model``."""
    n = len(model.links)
    children: list[list[int]] = [[] for _ in range(n)]
    for i in range(1, n):
        children[model.links[i].parent].append(i)
    order: list[int] = []
    stack = [0]
    while stack:
        i = stack.pop()
        order.append(i)
        stack.extend(reversed(children[i]))
    bodies = np.empty(n, dtype=np.intp)
    bodies[order] = np.arange(n)
    hinged_in_body_order = [i for i in order if i > 0 and not model.links[i].fixed]
    rank = {link: k for k, link in enumerate(hinged_in_body_order)}
    hinges = np.array([rank[i] for i in range(1, n) if not model.links[i].fixed], dtype=np.intp)
    return RobotLayout(bodies=bodies, hinge_qpos=7 + hinges, hinge_dofs=6 + hinges, nbody=n,
                       nq=7 + len(hinges), nv=6 + len(hinges))


# -- MJCF --------------------------------------------------------------------------------------
def _num(x: float) -> str:
    return repr(float(x))  # the shortest text that reads back to the same double


def _nums(values: Sequence[float] | NDArray[np.float64]) -> str:
    return " ".join(_num(v) for v in values)


def _tag(indent: int, element: str, close: bool = True, **values: str) -> str:
    attrs = "".join(f" {k}={quoteattr(v)}" for k, v in values.items())
    return f"{'  ' * indent}<{element}{attrs}{'/' if close else ''}>"


def _geom(g: mujoco.MjsGeom, prefix: str, indent: int) -> str:
    names = {"name": prefix + g.name} if g.name else {}
    if g.type == mujoco.mjtGeom.mjGEOM_HFIELD:  # a terrain (its asset: see mjcf)
        names["hfield"] = g.hfieldname
    return _tag(indent, "geom", **names, type=_GEOMS[g.type], size=_nums(g.size),
                pos=_nums(g.pos), quat=_nums(g.quat), rgba=_nums(g.rgba),
                friction=_nums(g.friction), condim=str(g.condim), solref=_nums(g.solref),
                contype=str(g.contype), conaffinity=str(g.conaffinity), priority=str(g.priority))


def _body(b: mujoco.MjsBody, prefix: str, indent: int) -> list[str]:
    lines = [_tag(indent, "body", close=False, name=prefix + b.name, pos=_nums(b.pos),
                  quat=_nums(b.quat)),
             _tag(indent + 1, "inertial", pos=_nums(b.ipos), quat=_nums(b.iquat),
                  mass=_num(b.mass), diaginertia=_nums(b.inertia))]
    for j in b.joints:
        if j.type == mujoco.mjtJoint.mjJNT_FREE:
            lines.append(_tag(indent + 1, "freejoint", name=prefix + j.name))
        else:
            lines.append(_tag(indent + 1, "joint", name=prefix + j.name, type="hinge",
                              axis=_nums(j.axis), limited="false", armature=_num(j.armature)))
    lines += [_geom(g, prefix, indent + 1) for g in b.geoms]
    for child in b.bodies:
        lines += _body(child, prefix, indent + 1)
    lines.append("  " * indent + "</body>")
    return lines


_GEOMS = {mujoco.mjtGeom.mjGEOM_BOX: "box", mujoco.mjtGeom.mjGEOM_PLANE: "plane",
          mujoco.mjtGeom.mjGEOM_HFIELD: "hfield"}
_INTEGRATORS = {mujoco.mjtIntegrator.mjINT_EULER: "Euler", mujoco.mjtIntegrator.mjINT_RK4: "RK4",
                mujoco.mjtIntegrator.mjINT_IMPLICIT: "implicit",
                mujoco.mjtIntegrator.mjINT_IMPLICITFAST: "implicitfast",
                mujoco.mjtIntegrator.mjINT_DISCRETE: "discrete"}


def mjcf(scene: mujoco.MjSpec, robots: Sequence[tuple[int, mujoco.MjSpec]]) -> str:
    """MJCF of ``scene`` (from :func:`scene_spec`) holding ``robots`` (key, spec) in order.

    ``mujoco.MjModel.from_xml_string`` of the text compiles to the model of ``scene`` with each
    robot attached in order (:func:`attach`), bit for bit.
    """
    opt = scene.option
    disabled = "".join(f' {name.removeprefix("mjDSBL_").lower()}="disable"'  # MJCF's names
                       for name, bit in mujoco.mjtDisableBit.__members__.items()
                       if name != "mjNDISABLE" and opt.disableflags & int(bit))
    out = [_tag(0, "mujoco", close=False, model=scene.modelname),
           _tag(1, "option", close=False, timestep=_num(opt.timestep), gravity=_nums(opt.gravity),
                integrator=_INTEGRATORS[opt.integrator]),
           f"    <flag{disabled}/>", "  </option>"]
    # MJCF's elevation rows run from +y down (an image's order), the spec's from -y up
    fields = [_tag(2, "hfield", name=f.name, nrow=str(f.nrow), ncol=str(f.ncol),
                   size=_nums(f.size),
                   elevation=_nums(np.reshape(f.userdata, (f.nrow, f.ncol))[::-1].ravel()))
              for f in scene.hfields]
    if fields:  # a terrain's height grid (mujoco_terrain.add_ground)
        out += ["  <asset>", *fields, "  </asset>"]
    out.append("  <worldbody>")
    out += [_geom(g, "", 2) for g in scene.worldbody.geoms]
    for light in scene.worldbody.lights:
        directional = light.type == mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
        out.append(_tag(2, "light", pos=_nums(light.pos), dir=_nums(light.dir),
                        directional=str(directional).lower()))
    for key, robot in robots:
        for body in robot.worldbody.bodies:
            out += _body(body, f"r{key}/", 2)
    out.append("  </worldbody>")
    excludes = [_tag(2, "exclude", body1=f"r{key}/{e.bodyname1}", body2=f"r{key}/{e.bodyname2}")
                for key, robot in robots for e in robot.excludes]
    if excludes:
        out += ["  <contact>", *excludes, "  </contact>"]
    # the velocity shortcut, as MjsActuator.set_to_velocity (it also sets the ctrlspec)
    actuators = [_tag(2, "velocity", name=f"r{key}/{a.name}", joint=f"r{key}/{a.target}",
                      kv=_num(a.gainprm[0]), forcelimited="true", forcerange=_nums(a.forcerange))
                 for key, robot in robots for a in robot.actuators]
    if actuators:
        out += ["  <actuator>", *actuators, "  </actuator>"]
    out.append("</mujoco>")
    return "\n".join(out) + "\n"


def scene_mjcf(config: WorldConfig, robots: Sequence[PlacedModel]) -> str:
    """MJCF of a MuJoCo scene of ``config`` holding ``robots`` as placed, in order.

    The model a MuJoCo world compiles when these robots are added to it in this order (each
    robot gets the next collision bit), whichever engine's world they come from.
    """
    specs = [(r.key, robot_spec(r.model, r.position, r.yaw, config, min(i, COLORS)))
             for i, r in enumerate(robots)]
    return mjcf(scene_spec(config), specs)
