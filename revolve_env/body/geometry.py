"""Assembly of a robot tree into posed boxes and rigid bodies (pure data, no physics engine).

:func:`assemble` places every part of a robot in the robot frame (core at the origin, joints at
angle 0) and groups the boxes into rigid bodies separated by hinge joints. The physics world builds
its multibody from an :class:`Assembly`; constructibility checks use :func:`overlapping_boxes`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.parts import PART_SPECS, PartGeometry, rotation_about
from revolve_env.body.robot import Node, PartType, Path, Robot

__all__ = [
    "Assembly",
    "PlacedBox",
    "PlacedPart",
    "RigidBody",
    "assemble",
    "child_frame",
    "footprint_radius",
    "mass_properties",
    "overlapping_boxes",
]

Vec3 = NDArray[np.float64]
Mat3 = NDArray[np.float64]


@dataclass(frozen=True)
class PlacedPart:
    """A part placed in the robot frame.

    Attributes:
        path: The node's path.
        node: The node itself (its subtree included).
        position: Origin of the part frame. Metres.
        rotation: Part frame to robot frame.
        bodies: Rigid-body index of the part's body 0 and (hinges only) body 1.
    """

    path: Path
    node: Node
    position: Vec3
    rotation: Mat3
    bodies: tuple[int, ...]


@dataclass(frozen=True)
class PlacedBox:
    """A box in the robot frame.

    Attributes:
        part: Index into ``Assembly.parts``.
        name: The box's name within its part.
        center: Metres.
        rotation: Box axes to robot frame.
        size: Full edge lengths. Metres.
        mass: Kilograms.
        body: Index into ``Assembly.bodies``.
    """

    part: int
    name: str
    center: Vec3
    rotation: Mat3
    size: Vec3
    mass: float
    body: int


@dataclass(frozen=True)
class RigidBody:
    """A set of rigidly joined boxes; all but the first body hang from a parent by a hinge.

    Attributes:
        parent: Index of the parent body, -1 for the body holding the core.
        joint_part: Index into ``Assembly.parts`` of the hinge that joins it to its parent (-1 for
            the root).
        joint_anchor: A point on the joint axis in the robot frame at assembly. Metres.
        joint_axis: Unit joint axis in the robot frame at assembly.
        active: Whether the joint is driven by a servo.
        boxes: Indices into ``Assembly.boxes``.
    """

    parent: int
    joint_part: int
    joint_anchor: Vec3
    joint_axis: Vec3
    active: bool
    boxes: tuple[int, ...]


@dataclass(frozen=True)
class Assembly:
    """A robot assembled at joint angles 0, core centred on the origin."""

    parts: tuple[PlacedPart, ...]
    boxes: tuple[PlacedBox, ...]
    bodies: tuple[RigidBody, ...]

    @property
    def mass(self) -> float:
        """Total mass. Kilograms."""
        return float(sum(b.mass for b in self.boxes))

    def body_mass(self, body: int) -> float:
        """Mass of one rigid body. Kilograms."""
        return float(sum(self.boxes[i].mass for i in self.bodies[body].boxes))

    def active_joints(self) -> list[int]:
        """Indices of bodies hanging on an active hinge, in traversal order of the hinges.

        This is the order of the controller's outputs.
        """
        return [i for i, b in enumerate(self.bodies) if b.parent >= 0 and b.active]

    def bounds(self) -> tuple[Vec3, Vec3]:
        """Axis-aligned bounds ``(lower, upper)`` of all boxes in the robot frame. Metres."""
        lows, highs = [], []
        for b in self.boxes:
            ext = np.abs(b.rotation) @ (b.size / 2)
            lows.append(b.center - ext)
            highs.append(b.center + ext)
        return np.min(lows, axis=0), np.max(highs, axis=0)

    def footprint_radius(self) -> float:
        """Radius of the smallest vertical cylinder about the core holding every box. Metres.

        Whatever the robot's heading, its horizontal footprint lies within this distance of its
        core centre (the one rule of birth placement and of the ground under a robot).
        """
        return footprint_radius(*self.bounds())


def footprint_radius(lower: Vec3, upper: Vec3) -> float:
    """:meth:`Assembly.footprint_radius` from the assembly's :meth:`~Assembly.bounds`. Metres."""
    return float(math.hypot(max(-lower[0], upper[0]), max(-lower[1], upper[1])))


def child_frame(
    parent_pos: Vec3, parent_rot: Mat3, slot_pos: Vec3, slot_normal: Vec3, slot_tangent: Vec3,
    orientation: float,
) -> tuple[Vec3, Mat3]:
    """Frame of a child attached at a slot (slot given in the parent's frame).

    The child's ``+x`` is the slot's outward normal and its ``+z`` the slot's tangent turned about
    the normal by ``orientation`` degrees.
    """
    # Plain float arithmetic: this runs for every part of every robot that operators check, and
    # NumPy's per-call overhead on 3-vectors dominated the cost of assembling a robot.
    nx, ny, nz = (float(v) for v in slot_normal)
    inv = 1.0 / math.sqrt(nx * nx + ny * ny + nz * nz)
    nx, ny, nz = nx * inv, ny * inv, nz * inv
    tx, ty, tz = (float(v) for v in slot_tangent)
    c, s = _cos_sin(orientation)
    # Rodrigues' rotation of the tangent about the normal.
    cx, cy, cz = ny * tz - nz * ty, nz * tx - nx * tz, nx * ty - ny * tx
    d = nx * tx + ny * ty + nz * tz
    zx, zy, zz = tx * c + cx * s + nx * d * (1 - c), ty * c + cy * s + ny * d * (1 - c), \
        tz * c + cz * s + nz * d * (1 - c)
    d = zx * nx + zy * ny + zz * nz  # remove any component along the normal
    zx, zy, zz = zx - nx * d, zy - ny * d, zz - nz * d
    inv = 1.0 / math.sqrt(zx * zx + zy * zy + zz * zz)
    zx, zy, zz = zx * inv, zy * inv, zz * inv
    yx, yy, yz = zy * nz - zz * ny, zz * nx - zx * nz, zx * ny - zy * nx
    local = np.array([[nx, yx, zx], [ny, yy, zy], [nz, yz, zz]])
    return parent_pos + parent_rot @ slot_pos, parent_rot @ local


def _cos_sin(degrees: float) -> tuple[float, float]:
    """Exact cosine and sine for multiples of 90 degrees (the legal orientations)."""
    exact = {0: (1.0, 0.0), 90: (0.0, 1.0), 180: (-1.0, 0.0), 270: (0.0, -1.0)}
    key = int(degrees) % 360 if float(degrees).is_integer() else None
    if key in exact:
        return exact[key]
    t = math.radians(degrees)
    return math.cos(t), math.sin(t)


@functools.lru_cache(maxsize=512)
def _part_geometry(part_type: PartType, params: tuple[float, ...]) -> PartGeometry:
    """Geometry of a part type with given parameters (cached: specs are pure functions)."""
    return PART_SPECS[part_type].geometry(params)


def assemble(robot: Robot) -> Assembly:
    """Place every part of ``robot`` and group its boxes into rigid bodies.

    The robot is assumed structurally valid (known part types, legal slots, parameter counts);
    :func:`revolve_env.body.validate.validate` checks that first.
    """
    parts: list[PlacedPart] = []
    boxes: list[PlacedBox] = []
    bodies: list[dict[str, Any]] = [
        {"parent": -1, "joint_part": -1, "joint_anchor": np.zeros(3),
         "joint_axis": np.array([0, 0, 1.0]), "active": False, "boxes": []}
    ]

    def place(node: Node, path: Path, pos: Vec3, rot: Mat3, body: int) -> None:
        spec = PART_SPECS[node.type]
        geom = _part_geometry(node.type, node.params if node.params else spec.default_params())
        part_index = len(parts)
        part_bodies = [body]
        if geom.joint is not None:
            bodies.append({
                "parent": body, "joint_part": part_index,
                "joint_anchor": pos + rot @ geom.joint.anchor,
                "joint_axis": rot @ geom.joint.axis,
                "active": geom.joint.active, "boxes": [],
            })
            part_bodies.append(len(bodies) - 1)
        parts.append(PlacedPart(path, node, pos, rot, tuple(part_bodies)))
        for b in geom.boxes:
            body_index = part_bodies[b.body]
            boxes.append(PlacedBox(
                part_index, b.name, pos + rot @ b.center, rot @ b.rotation, b.size, b.mass,
                body_index,
            ))
            bodies[body_index]["boxes"].append(len(boxes) - 1)
        for slot, child in node.children:
            s = geom.slots[slot]
            cpos, crot = child_frame(pos, rot, s.position, s.normal, s.tangent, child.orientation)
            place(child, (*path, slot), cpos, crot, part_bodies[s.body])

    core = robot.body
    # The core's own orientation turns it about the vertical axis.
    place(core, (), np.zeros(3), rotation_about("z", core.orientation), 0)
    return Assembly(
        tuple(parts), tuple(boxes),
        tuple(RigidBody(
            b["parent"], b["joint_part"], b["joint_anchor"], b["joint_axis"], b["active"],
            tuple(b["boxes"]),
        ) for b in bodies),
    )


_MARGIN = 1e-9
"""Metres. Where the fast test's separation (or overlap) on an axis is this clear, rounding
cannot change the decision: the two ways of computing it differ by under 1e-11 m."""

_AXIS_CLEAR = 1e-4
"""A cross product of edge directions at least this long gives an accurate unit axis; one at
most :data:`_AXIS_NONE` long is no axis in either computation (the threshold is 1e-9)."""

_AXIS_NONE = 1e-12


def overlapping_boxes(assembly: Assembly, tolerance: float = 0.5e-3) -> list[tuple[int, int]]:
    """Pairs of boxes of different parts that intersect, by an exact oriented-box (SAT) test.

    Each box is first shrunk by ``tolerance`` (metres) on every face, so parts that merely touch,
    as attached parts do, are not reported. Boxes of the same part never count: RoboGen's own
    primitives of a hinge interpenetrate by design.

    Every candidate pair and all 15 separating axes are tested at once. A pair whose answer
    rests on less than :data:`_MARGIN` on some axis (boxes that touch after shrinking, or edges
    within 1e-4 rad of parallel) is not decided by that fast test: the whole assembly is then
    tested axis by axis as before (:func:`_overlapping_by_axis`), so the pairs found are always
    exactly those.

    Returns:
        ``(i, j)`` index pairs into ``assembly.boxes`` with ``i < j``.
    """
    candidates = _candidate_pairs(assembly, tolerance)
    if candidates is None:
        return []
    i_idx, j_idx, d, rots, half = candidates
    a_rot, b_rot = rots[i_idx], rots[j_idx]  # (m, 3, 3), columns are box axes
    a_half, b_half = half[i_idx], half[j_idx]
    # The 15 candidate axes of every pair, one (m, 15) array per component: each box's 3 face
    # normals, then the 9 cross products of an edge of a with an edge of b (a's edge major).
    ax, ay, az = (a_rot[:, c, :, None] for c in range(3))
    bx, by, bz = (b_rot[:, c, None, :] for c in range(3))
    m = len(i_idx)
    comps = [np.concatenate((a_rot[:, c, :], b_rot[:, c, :], cross.reshape(m, 9)), axis=1)
             for c, cross in enumerate((ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx))]
    norm = np.sqrt(comps[0] * comps[0] + comps[1] * comps[1] + comps[2] * comps[2])
    valid = norm > _AXIS_CLEAR
    scale = 1.0 / np.where(valid, norm, 1.0)
    ux, uy, uz = (u * scale for u in comps)
    # Each box's reach along every axis: the sum over its edges of half extent x |edge . axis|.
    reach = np.abs(d[:, 0, None] * ux + d[:, 1, None] * uy + d[:, 2, None] * uz)
    for rot, h in ((a_rot, a_half), (b_rot, b_half)):
        for j in range(3):
            edge = rot[:, :, j]
            reach -= h[:, j, None] * np.abs(edge[:, 0, None] * ux + edge[:, 1, None] * uy
                                            + edge[:, 2, None] * uz)
    gap = reach  # centre distance minus both reaches; > 0: separated on that axis
    separated = (valid & (gap > _MARGIN)).any(axis=1)
    overlapping = ((norm <= _AXIS_NONE) | (valid & (gap < -_MARGIN))).all(axis=1)
    if not (separated | overlapping).all():
        return _overlapping_by_axis(assembly, tolerance)
    return [(int(i), int(j)) for i, j in zip(i_idx[overlapping], j_idx[overlapping], strict=True)]


def _candidate_pairs(assembly: Assembly, tolerance: float) -> tuple[
        NDArray[np.intp], NDArray[np.intp], NDArray[np.float64], NDArray[np.float64],
        NDArray[np.float64]] | None:
    """Pairs of boxes of different parts whose bounding spheres meet (shrunk boxes).

    Returns:
        Their indices ``i < j``, the centre offsets ``c_j - c_i``, every box's rotation and
        shrunk half extents; None when no pair is left.
    """
    n = len(assembly.boxes)
    if n < 2:
        return None
    centers = np.array([b.center for b in assembly.boxes])
    rots = np.array([b.rotation for b in assembly.boxes])
    half = np.maximum(np.array([b.size for b in assembly.boxes]) / 2 - tolerance, 0.0)
    part = np.array([b.part for b in assembly.boxes])
    radius = np.linalg.norm(half, axis=1)

    i_idx, j_idx = np.triu_indices(n, k=1)
    keep = part[i_idx] != part[j_idx]
    d = centers[j_idx] - centers[i_idx]
    keep &= np.linalg.norm(d, axis=1) < radius[i_idx] + radius[j_idx]
    if not keep.any():
        return None
    return i_idx[keep], j_idx[keep], d[keep], rots, half


def _overlapping_by_axis(assembly: Assembly, tolerance: float) -> list[tuple[int, int]]:
    """:func:`overlapping_boxes` one separating axis at a time over all pairs (the reference).

    Its decisions are the definition: the fast test defers to it wherever rounding could
    matter.
    """
    candidates = _candidate_pairs(assembly, tolerance)
    if candidates is None:
        return []
    i_idx, j_idx, d, rots, half = candidates
    a_rot, b_rot = rots[i_idx], rots[j_idx]  # (m, 3, 3), columns are box axes
    a_half, b_half = half[i_idx], half[j_idx]
    # Candidate separating axes: 3 face normals of each box and the 9 edge cross products.
    axes = [a_rot[:, :, k] for k in range(3)] + [b_rot[:, :, k] for k in range(3)]
    for ka in range(3):
        for kb in range(3):
            axes.append(np.cross(a_rot[:, :, ka], b_rot[:, :, kb]))
    separated = np.zeros(len(i_idx), dtype=bool)
    for axis in axes:
        norm = np.linalg.norm(axis, axis=1)
        valid = norm > 1e-9  # parallel edges give no axis; the face axes cover that case
        unit = np.where(valid[:, None], axis / np.where(valid, norm, 1.0)[:, None], 0.0)
        ra = np.sum(a_half * np.abs(np.einsum("mij,mi->mj", a_rot, unit)), axis=1)
        rb = np.sum(b_half * np.abs(np.einsum("mij,mi->mj", b_rot, unit)), axis=1)
        dist = np.abs(np.sum(d * unit, axis=1))
        separated |= valid & (dist > ra + rb)
    return [(int(i), int(j)) for i, j in zip(i_idx[~separated], j_idx[~separated], strict=True)]


def mass_properties(boxes: Sequence[PlacedBox], origin: Vec3 | None = None
                    ) -> tuple[float, Vec3, Mat3]:
    """Mass properties of rigidly joined solid boxes (one rigid body of a robot).

    The one home of this rule: the physics model (:mod:`revolve_env.world.model`) and the
    URDF/SDF export (:mod:`revolve_env.body.export`) both use it.

    Args:
        boxes: The body's boxes (robot frame).
        origin: Point the centre of mass is given relative to (robot frame, metres); default
            the robot frame's origin.

    Returns:
        Mass (kilograms), centre of mass relative to ``origin`` (metres) and the inertia tensor
        about the centre of mass in the robot frame's axes (kilogram square metres).

    Raises:
        ValueError: the boxes have no mass.
    """
    masses = np.array([b.mass for b in boxes])
    centers = np.array([b.center for b in boxes])
    if origin is not None:
        centers = centers - origin
    mass = float(masses.sum())
    if not mass > 0:
        raise ValueError("a rigid body of the robot has no mass")
    com = (masses[:, None] * centers).sum(axis=0) / mass
    inertia = np.zeros((3, 3))
    for b, c in zip(boxes, centers, strict=True):
        x, y, z = b.size**2
        principal = b.mass / 12.0 * np.array([y + z, x + z, x + y])
        local = b.rotation @ np.diag(principal) @ b.rotation.T
        d = c - com
        inertia += local + b.mass * (float(d @ d) * np.eye(3) - np.outer(d, d))
    return mass, com, inertia
