"""Export of a robot to URDF and Gazebo SDF, and its bill of materials (pure Python, no physics).

Both formats come from :func:`revolve_env.body.geometry.assemble`: every rigid body becomes a link
and every hinge a revolute joint. A link's frame sits at its joint's anchor (the core's link at the
core's centre) with axes parallel to the robot frame, so joint axes and box poses are simply the
assembly's vectors. Each box of a part is one collision box and one visual box coloured with the
part's colour; a link's inertial is the exact sum of its solid boxes' inertias.

Joint limits: active hinges get RoboGen's servo range (+-45 deg, ``SERVO.range_deg``) with the
servo's torque and speed as effort and velocity; passive hinges swing freely within +-60 deg (the
limit Revolve used for its passive hinge, ``pyrevolve/angle/robogen/constants.py``
``HINGE_LIMIT``), since a box model of the hinge would otherwise pass through itself.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from collections import Counter
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.geometry import Assembly, assemble, mass_properties
from revolve_env.body.parts import PART_SPECS, SERVO
from revolve_env.body.robot import PartType, Robot
from revolve_env.body.validate import Limits, validate

__all__ = [
    "PASSIVE_HINGE_LIMIT_DEG",
    "BillOfMaterials",
    "bill_of_materials",
    "link_inertia",
    "to_sdf",
    "to_urdf",
]

PASSIVE_HINGE_LIMIT_DEG = 60.0
"""Range of a passive hinge in exported models, +- this many degrees (Revolve's HINGE_LIMIT)."""

Vec3 = NDArray[np.float64]
Mat3 = NDArray[np.float64]


# --- shared maths ------------------------------------------------------------------------------
def _fmt(x: float) -> str:
    # 12 significant digits keep sub-micrometre precision without float noise like 1e-17.
    v = float(x)
    if abs(v) < 1e-15:
        v = 0.0
    return f"{v:.12g}"


def _vec(v: Vec3 | tuple[float, ...]) -> str:
    return " ".join(_fmt(x) for x in v)


def _rpy(r: Mat3) -> tuple[float, float, float]:
    """Fixed-axis roll, pitch, yaw (URDF/SDF convention, ``R = Rz(yaw) Ry(pitch) Rx(roll)``)."""
    sy = -float(r[2, 0])
    sy = max(-1.0, min(1.0, sy))
    pitch = math.asin(sy)
    if abs(sy) < 1.0 - 1e-9:
        roll = math.atan2(float(r[2, 1]), float(r[2, 2]))
        yaw = math.atan2(float(r[1, 0]), float(r[0, 0]))
    else:  # gimbal lock: only roll - yaw (or roll + yaw) is defined; put it all in roll
        yaw = 0.0
        roll = math.atan2(-float(r[1, 2]), float(r[1, 1]))
    return roll, pitch, yaw


def link_inertia(assembly: Assembly, body: int) -> tuple[float, Vec3, Mat3]:
    """Mass (kg), centre of mass (robot frame, metres) and inertia about it (kg m^2) of a body.

    Computed by :func:`~revolve_env.body.geometry.mass_properties`, as the physics model does.
    """
    return mass_properties([assembly.boxes[i] for i in assembly.bodies[body].boxes])


def _link_origin(assembly: Assembly, body: int) -> Vec3:
    return np.zeros(3) if assembly.bodies[body].parent < 0 else assembly.bodies[body].joint_anchor


def _names(assembly: Assembly) -> tuple[list[str], list[str]]:
    """Readable unique link and joint names derived from the parts' paths."""
    links, joints = [], []
    for i, b in enumerate(assembly.bodies):
        if b.parent < 0:
            links.append("core")
            joints.append("")
            continue
        part = assembly.parts[b.joint_part]
        tag = "_".join(str(s) for s in part.path)
        links.append(f"link{i}_{part.node.type.value}_{tag}")
        joints.append(f"joint{i}_{part.node.type.value}_{tag}")
    return links, joints


def _model_name(robot: Robot) -> str:
    """The robot's name made safe for XML names and file systems (``robot`` if empty)."""
    return re.sub(r"[^A-Za-z0-9_.-]", "_", robot.name) or "robot"


def _prepare(robot: Robot, limits: Limits | None) -> Assembly:
    validate(robot, limits)
    return assemble(robot)


def _color(assembly: Assembly, box: int) -> tuple[float, float, float]:
    c = assembly.parts[assembly.boxes[box].part].node.color
    return float(c[0]), float(c[1]), float(c[2])


def _joint_limits(active: bool) -> tuple[float, float, float, float]:
    """(lower rad, upper rad, effort N m, velocity rad/s) of a hinge."""
    if active:
        r = math.radians(SERVO.range_deg)
        return -r, r, SERVO.max_torque, SERVO.max_velocity
    r = math.radians(PASSIVE_HINGE_LIMIT_DEG)
    return -r, r, 0.0, SERVO.max_velocity * 10.0


def _pretty(root: ET.Element) -> str:
    ET.indent(root, space="  ")
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


# --- URDF --------------------------------------------------------------------------------------
def to_urdf(robot: Robot, limits: Limits | None = None) -> str:
    """The robot as a URDF document.

    The robot is validated first (``limits`` as for :func:`validate`). Link ``core`` is the root.
    Lengths in metres, masses in kilograms, angles in radians.
    """
    asm = _prepare(robot, limits)
    links, joints = _names(asm)
    root = ET.Element("robot", name=_model_name(robot))
    for i, body in enumerate(asm.bodies):
        origin = _link_origin(asm, i)
        link = ET.SubElement(root, "link", name=links[i])
        mass, com, inertia = link_inertia(asm, i)
        inertial = ET.SubElement(link, "inertial")
        ET.SubElement(inertial, "origin", xyz=_vec(com - origin), rpy="0 0 0")
        ET.SubElement(inertial, "mass", value=_fmt(mass))
        ET.SubElement(inertial, "inertia", ixx=_fmt(inertia[0, 0]), ixy=_fmt(inertia[0, 1]),
                      ixz=_fmt(inertia[0, 2]), iyy=_fmt(inertia[1, 1]), iyz=_fmt(inertia[1, 2]),
                      izz=_fmt(inertia[2, 2]))
        for k in body.boxes:
            box = asm.boxes[k]
            xyz, rpy = _vec(box.center - origin), _vec(_rpy(box.rotation))
            for tag in ("visual", "collision"):
                el = ET.SubElement(link, tag, name=f"{box.name}_{k}")
                ET.SubElement(el, "origin", xyz=xyz, rpy=rpy)
                ET.SubElement(ET.SubElement(el, "geometry"), "box", size=_vec(box.size))
                if tag == "visual":
                    mat = ET.SubElement(el, "material", name=f"color_{k}")
                    ET.SubElement(mat, "color", rgba=_vec((*_color(asm, k), 1.0)))
        if body.parent >= 0:
            joint = ET.SubElement(root, "joint", name=joints[i], type="revolute")
            ET.SubElement(joint, "parent", link=links[body.parent])
            ET.SubElement(joint, "child", link=links[i])
            ET.SubElement(joint, "origin", xyz=_vec(origin - _link_origin(asm, body.parent)),
                          rpy="0 0 0")
            ET.SubElement(joint, "axis", xyz=_vec(body.joint_axis))
            lo, hi, effort, velocity = _joint_limits(body.active)
            ET.SubElement(joint, "limit", lower=_fmt(lo), upper=_fmt(hi), effort=_fmt(effort),
                          velocity=_fmt(velocity))
    return _pretty(root)


# --- SDF ---------------------------------------------------------------------------------------
def _text(parent: ET.Element, tag: str, text: str) -> ET.Element:
    el = ET.SubElement(parent, tag)
    el.text = text
    return el


def to_sdf(robot: Robot, limits: Limits | None = None) -> str:
    """The robot as a Gazebo SDF 1.6 model (one ``<model>`` in an ``<sdf>`` document).

    The robot is validated first. Link poses are in the model frame; collision, visual and
    inertial poses in their link's frame; a joint's pose is at its child link's origin.
    """
    asm = _prepare(robot, limits)
    links, joints = _names(asm)
    sdf = ET.Element("sdf", version="1.6")
    model = ET.SubElement(sdf, "model", name=_model_name(robot))
    for i, body in enumerate(asm.bodies):
        origin = _link_origin(asm, i)
        link = ET.SubElement(model, "link", name=links[i])
        _text(link, "pose", _vec((*origin, 0.0, 0.0, 0.0)))
        mass, com, inertia = link_inertia(asm, i)
        inertial = ET.SubElement(link, "inertial")
        _text(inertial, "pose", _vec((*(com - origin), 0.0, 0.0, 0.0)))
        _text(inertial, "mass", _fmt(mass))
        it = ET.SubElement(inertial, "inertia")
        for name, (a, b) in (("ixx", (0, 0)), ("ixy", (0, 1)), ("ixz", (0, 2)), ("iyy", (1, 1)),
                             ("iyz", (1, 2)), ("izz", (2, 2))):
            _text(it, name, _fmt(inertia[a, b]))
        for k in body.boxes:
            box = asm.boxes[k]
            pose = _vec((*(box.center - origin), *_rpy(box.rotation)))
            for tag in ("collision", "visual"):
                el = ET.SubElement(link, tag, name=f"{box.name}_{k}_{tag}")
                _text(el, "pose", pose)
                _text(ET.SubElement(ET.SubElement(el, "geometry"), "box"), "size", _vec(box.size))
                if tag == "visual":
                    mat = ET.SubElement(el, "material")
                    rgba = _vec((*_color(asm, k), 1.0))
                    _text(mat, "ambient", rgba)
                    _text(mat, "diffuse", rgba)
        if body.parent >= 0:
            joint = ET.SubElement(model, "joint", name=joints[i], type="revolute")
            _text(joint, "parent", links[body.parent])
            _text(joint, "child", links[i])
            _text(joint, "pose", "0 0 0 0 0 0")
            axis = ET.SubElement(joint, "axis")
            _text(axis, "xyz", _vec(body.joint_axis))
            _text(axis, "use_parent_model_frame", "true")
            lim = ET.SubElement(axis, "limit")
            lo, hi, effort, velocity = _joint_limits(body.active)
            _text(lim, "lower", _fmt(lo))
            _text(lim, "upper", _fmt(hi))
            _text(lim, "effort", _fmt(effort))
            _text(lim, "velocity", _fmt(velocity))
    return _pretty(sdf)


# --- bill of materials -------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class BillOfMaterials:
    """What to buy and print to build a robot.

    Attributes:
        counts: ``(part type, count)`` for each part type used, in ``PartType`` order.
        servos: Number of servo motors (one per active hinge).
        mass: Total mass of the robot. Kilograms.
        bar_lengths: Length of each parametric bar joint, in traversal order. Metres.
    """

    counts: tuple[tuple[PartType, int], ...]
    servos: int
    mass: float
    bar_lengths: tuple[float, ...] = ()

    def count(self, part: PartType) -> int:
        """How many parts of one type the robot has."""
        return dict(self.counts).get(part, 0)

    @property
    def n_parts(self) -> int:
        """Number of parts, core included."""
        return sum(n for _, n in self.counts)

    def to_dict(self) -> dict[str, object]:
        """Plain JSON-compatible data: part counts by type name, servos, total mass in kg."""
        return {
            "parts": {t.value: n for t, n in self.counts},
            "servos": self.servos,
            "total_mass_kg": self.mass,
            "bar_lengths_m": list(self.bar_lengths),
        }

    def to_text(self) -> str:
        """A table for people: one line per part type, then servos and total mass."""
        lines = [f"{'part':<16}{'count':>6}{'unit mass (g)':>15}"]
        for t, n in self.counts:
            # A bar's mass depends on its length; the others have one mass each.
            unit_text = ("varies" if t == PartType.PARAMETRIC_BAR
                         else f"{PART_SPECS[t].mass() * 1000:.1f}")
            lines.append(f"{t.value:<16}{n:>6}{unit_text:>15}")
        if self.bar_lengths:
            lengths = ", ".join(f"{x * 1000:.1f}" for x in self.bar_lengths)
            lines.append(f"bar lengths (mm): {lengths}")
        lines.append(f"servos: {self.servos}")
        lines.append(f"total mass: {self.mass * 1000:.1f} g")
        return "\n".join(lines)


def bill_of_materials(robot: Robot, limits: Limits | None = None) -> BillOfMaterials:
    """Count the parts and servos of ``robot`` and sum its mass (it is validated first)."""
    asm = _prepare(robot, limits)
    nodes = [n for _, n in robot.walk()]
    counter = Counter(n.type for n in nodes)
    counts = tuple((t, counter[t]) for t in PartType if counter[t])
    bars = tuple(float(n.params[0]) for n in nodes if n.type == PartType.PARAMETRIC_BAR)
    servos = sum(PART_SPECS[n.type].n_outputs for n in nodes)
    return BillOfMaterials(counts, servos, asm.mass, bars)
