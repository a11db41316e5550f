"""Engine-neutral physical model of a robot: links, mass properties, joints and sensors.

Pure NumPy over :func:`revolve_env.body.geometry.assemble`. Every physics backend builds its
bodies from a :class:`RobotModel`, so all backends agree on masses, inertias, joint frames and the
sensor layout.

Frames: each rigid body of the assembly becomes one link. A link's frame has the orientation of
the robot frame at assembly; its origin is the core centre for the root link and the hinge anchor
for every other link, so a joint sits at its child link's origin. Touch sensor halves are extra
welded links whose origin is the half's centre.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.geometry import Assembly, PlacedBox, footprint_radius, mass_properties
from revolve_env.body.parts import PART_SPECS, SLOT_THICKNESS
from revolve_env.body.robot import PartType, Robot
from revolve_env.body.validate import assembly_of

__all__ = [
    "PART_SHADES",
    "LightSensorModel",
    "LinkModel",
    "PlacedModel",
    "RobotModel",
    "TouchSensorModel",
    "build_model",
    "drawn_colors",
    "part_color",
]

Vec3 = NDArray[np.float64]
Mat3 = NDArray[np.float64]

PART_SHADES: dict[PartType, tuple[tuple[float, float, float], float]] = {
    PartType.CORE: ((0.0, 0.0, 0.0), 0.0),
    PartType.BRICK: ((1.0, 1.0, 1.0), 0.45),
    PartType.PARAMETRIC_BAR: ((1.0, 1.0, 1.0), 0.7),
    PartType.ACTIVE_HINGE: ((0.0, 0.0, 0.0), 0.5),
    PartType.PASSIVE_HINGE: ((0.0, 0.0, 0.0), 0.3),
    PartType.TOUCH_SENSOR: ((0.1, 0.1, 0.1), 0.75),
    PartType.LIGHT_SENSOR: ((1.0, 0.85, 0.1), 0.7),
}
"""How each part type is drawn: ``(shade, weight)`` mixed into the part's own colour."""


def part_color(part_type: PartType, color: tuple[float, float, float]
               ) -> tuple[float, float, float]:
    """``color`` shaded for ``part_type`` (:data:`PART_SHADES`; the core's colour as is).

    Args:
        part_type: The part's type.
        color: The part's own colour, RGB in [0, 1].
    """
    shade, weight = PART_SHADES[part_type]
    r, g, b = ((1.0 - weight) * c + weight * s for c, s in zip(color, shade, strict=True))
    return (r, g, b)


@dataclass(frozen=True)
class LinkModel:
    """One rigid body.

    Attributes:
        parent: Index of the parent link, -1 for the root (which holds the core).
        origin: Link frame origin in the robot frame at assembly. Metres.
        mass: Kilograms.
        com: Centre of mass in the link frame. Metres.
        inertia_axes: 3x3 rotation whose columns are the principal axes (link frame), det +1.
        inertia_diagonal: Principal moments of inertia about the centre of mass. kg m^2.
        box_centers: (k, 3) box centres in the link frame. Metres.
        box_rotations: (k, 3, 3) box axes in the link frame.
        box_half_extents: (k, 3) half edge lengths. Metres.
        box_colors: (k, 3) RGB each box is drawn in (:func:`drawn_colors` of its part).
        joint_axis: Unit hinge axis in the link frame (unused for the root and fixed links).
        active: Whether the hinge is driven by a servo.
        fixed: Welded to its parent (a touch sensor half) rather than hinged.
    """

    parent: int
    origin: Vec3
    mass: float
    com: Vec3
    inertia_axes: Mat3
    inertia_diagonal: Vec3
    box_centers: NDArray[np.float64]
    box_rotations: NDArray[np.float64]
    box_half_extents: NDArray[np.float64]
    box_colors: NDArray[np.float64]
    joint_axis: Vec3
    active: bool
    fixed: bool = False


@dataclass(frozen=True)
class TouchSensorModel:
    """A touch sensor: its left and right halves are links of their own, welded to the carrier.

    Attributes:
        links: Link indices of the left and right halves.
    """

    links: tuple[int, int]


@dataclass(frozen=True)
class LightSensorModel:
    """A light sensor's sensing point and viewing direction in its link's frame.

    Attributes:
        link: Link index.
        position: Centre of the sensing face. Metres.
        direction: Unit outward normal of the sensing face.
    """

    link: int
    position: Vec3
    direction: Vec3


@dataclass(frozen=True)
class RobotModel:
    """Everything a physics backend needs to build and sense one robot.

    Attributes:
        links: Links: the assembly's rigid bodies in order, then the touch sensor halves;
            parents come before children.
        active_links: Link indices of the active hinges, in controller output order.
        passive_links: Link indices of the passive hinges.
        sensors: One entry per sensor part in controller input order: ``("imu", None)``,
            ``("touch", TouchSensorModel)`` or ``("light", LightSensorModel)``.
        n_inputs: Number of sensor values (6 per core IMU, 2 per touch sensor, 1 per light).
        lowest_z: Lowest point of the assembled robot below the core centre. Metres (<= 0).
        mass: Total mass. Kilograms.
        footprint_radius: Horizontal reach of the robot about its core, whatever its heading
            (:meth:`~revolve_env.body.geometry.Assembly.footprint_radius`). Metres.
    """

    links: tuple[LinkModel, ...]
    active_links: tuple[int, ...]
    passive_links: tuple[int, ...]
    sensors: tuple[tuple[str, TouchSensorModel | LightSensorModel | None], ...]
    n_inputs: int
    lowest_z: float
    mass: float
    footprint_radius: float

    @property
    def n_outputs(self) -> int:
        """Number of active hinges (controller outputs)."""
        return len(self.active_links)


@dataclass(frozen=True, slots=True)
class PlacedModel:
    """A robot as a backend built it (what rebuilding its scene needs).

    Attributes:
        key: The backend's key of the robot.
        model: Its physical model.
        position: Its root link frame's origin when it was added, world frame. Metres.
        yaw: Its turn about the vertical when it was added. Radians.
    """

    key: int
    model: RobotModel
    position: tuple[float, float, float]
    yaw: float


def drawn_colors(asm: Assembly) -> list[tuple[float, float, float]]:
    """The colour each part of ``asm`` is drawn in (both engines draw these).

    A part is drawn in its own colour (``Node.color``: what the robot's JSON gives it), except
    when it has the colour of the part it is attached to: then it is shaded by its type
    (:func:`part_color`: bricks and bars lighter, hinges darker, touch sensors near black,
    light sensors yellow). An evolved robot's parts all carry their lineage's colour, inherited
    so that a picture shows descent, and drawn as is it would be one blob; shaded, its hue
    stays and its parts stand apart. A designed robot whose neighbouring parts have colours of
    their own keeps them. Nothing physical depends on colours.
    """
    by_path = {part.path: part.node.color for part in asm.parts}
    out = []
    for part in asm.parts:
        color = part.node.color
        if part.path and by_path.get(part.path[:-1]) == color:
            color = part_color(part.node.type, color)
        out.append(color)
    return out


def _link(
    parent: int, origin: Vec3, boxes: list[PlacedBox], colors: list[tuple[float, float, float]],
    joint_axis: Vec3, active: bool,
    fixed: bool,
) -> LinkModel:
    centers = np.array([b.center for b in boxes]) - origin
    mass, com, inertia = mass_properties(boxes, origin)
    moments, axes = np.linalg.eigh(inertia)
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    return LinkModel(
        parent=parent,
        origin=np.asarray(origin, float),
        mass=mass,
        com=com,
        inertia_axes=axes,
        inertia_diagonal=np.maximum(moments, 1e-12),
        box_centers=centers,
        box_rotations=np.array([b.rotation for b in boxes]),
        box_half_extents=np.array([b.size for b in boxes]) / 2.0,
        box_colors=np.array(colors, dtype=float),
        joint_axis=np.asarray(joint_axis, float) / np.linalg.norm(joint_axis),
        active=active,
        fixed=fixed,
    )


def build_model(robot: Robot, assembly: Assembly | None = None) -> RobotModel:
    """The physical model of ``robot`` (assumed valid; see ``revolve_env.body.validate``).

    Each rigid body of the assembly becomes a link (same index), except that every touch
    sensor's two halves become two extra links welded to their carrier (appended after the
    bodies), so that the engine reports their contacts separately.

    Args:
        robot: The robot.
        assembly: Its assembly; default the one :func:`~revolve_env.body.validate.check` made
            when it validated this robot object, if it still remembers it, else assembled now.
    """
    asm = assembly if assembly is not None else assembly_of(robot)
    touch_halves = {
        k for k, b in enumerate(asm.boxes)
        if asm.parts[b.part].node.type == PartType.TOUCH_SENSOR and b.name in ("left", "right")
    }
    colors = drawn_colors(asm)
    links: list[LinkModel] = []
    for body in asm.bodies:
        origin = np.zeros(3) if body.parent < 0 else np.asarray(body.joint_anchor, float)
        keep = [k for k in body.boxes if k not in touch_halves]
        links.append(_link(
            body.parent, origin, [asm.boxes[k] for k in keep],
            [colors[asm.boxes[k].part] for k in keep],
            body.joint_axis, bool(body.active), fixed=False,
        ))

    sensors: list[tuple[str, TouchSensorModel | LightSensorModel | None]] = []
    n_inputs = 0
    for part_index, part in enumerate(asm.parts):
        kind = part.node.type
        n_inputs += PART_SPECS[kind].n_inputs
        if kind == PartType.CORE:
            sensors.append(("imu", None))
        elif kind == PartType.TOUCH_SENSOR:
            carrier = part.bodies[0]
            halves = {b.name: b for b in asm.boxes if b.part == part_index}
            indices = []
            for name in ("left", "right"):
                box = halves[name]
                links.append(_link(
                    carrier, box.center, [box], [colors[part_index]], np.array([0.0, 0.0, 1.0]),
                    active=False, fixed=True,
                ))
                indices.append(len(links) - 1)
            sensors.append(("touch", TouchSensorModel(links=(indices[0], indices[1]))))
        elif kind == PartType.LIGHT_SENSOR:
            link = part.bodies[0]
            direction = part.rotation[:, 0]
            sensors.append(("light", LightSensorModel(
                link=link,
                position=part.position + SLOT_THICKNESS * direction - links[link].origin,
                direction=direction.copy(),
            )))
        elif PART_SPECS[kind].n_inputs:
            raise ValueError(f"no sensor model for part type {kind.value!r}")

    lower, upper = asm.bounds()
    active = tuple(i for i in asm.active_joints())
    passive = tuple(i for i, b in enumerate(asm.bodies) if b.parent >= 0 and not b.active)
    return RobotModel(
        links=tuple(links),
        active_links=active,
        passive_links=passive,
        sensors=tuple(sensors),
        n_inputs=n_inputs,
        lowest_z=float(lower[2]),
        mass=asm.mass,
        footprint_radius=footprint_radius(lower, upper),
    )
