"""Validation of robot descriptions: structure, ranges, neural references, limits, constructibility.

An invalid robot never reaches the simulator: everything that builds robots calls
:func:`validate`, which raises one error type, :class:`RobotError`, naming the node and the rule.

A robot is validated and assembled once: :func:`check` returns the record of a robot that passed
(:class:`Checked`: the robot, its limits and its assembly) and remembers the last
:data:`REMEMBERED` of them by the robot object's identity, so that the checks a genome meets on
its way (the operators' on a parent, the evaluation's, the world's assembly when it builds the
robot's model: :func:`assembly_of`) find it instead of deriving it again. Robots are immutable,
so a record stays true; the memory is bounded and holds no robot that did not pass.
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from dataclasses import dataclass

from revolve_env.body.errors import RobotError
from revolve_env.body.errors import format_path as _fmt
from revolve_env.body.geometry import Assembly, assemble, overlapping_boxes
from revolve_env.body.parts import PART_SPECS
from revolve_env.body.robot import (
    ACTIVATION_PARAMS,
    NEURON_PARAM_BOUNDS,
    WEIGHT_BOUNDS,
    Activation,
    Layer,
    Node,
    PartType,
    Path,
    Robot,
)

__all__ = ["REMEMBERED", "Checked", "Limits", "RobotError", "assembly_of", "check", "validate"]

ORIENTATIONS = (0, 90, 180, 270)


@dataclass(frozen=True, slots=True)
class Limits:
    """Limits a robot must respect (the paper's Table 1 by default).

    Attributes:
        max_parts: Most parts, core included.
        max_inputs: Most sensor values (input neurons), the core's 6 IMU values included.
        max_outputs: Most actuators (output neurons).
        max_hidden: Most hidden neurons.
        overlap_tolerance: Parts may interpenetrate by up to this much. Metres.
    """

    max_parts: int = 30
    max_inputs: int = 10
    max_outputs: int = 10
    max_hidden: int = 10
    overlap_tolerance: float = 0.5e-3

    def __post_init__(self) -> None:
        for name in ("max_parts", "max_inputs", "max_outputs", "max_hidden"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 0:
                raise ValueError(f"Limits.{name} must be a non-negative integer, got {value!r}")
        if self.max_parts < 1:
            raise ValueError("Limits.max_parts must be at least 1 (the core)")
        if not (0.0 <= self.overlap_tolerance < 0.01):
            raise ValueError(
                f"Limits.overlap_tolerance must be in [0, 0.01) m, got {self.overlap_tolerance!r}"
            )


def _finite(x: object) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _integer(x: object) -> bool:
    return isinstance(x, int) and not isinstance(x, bool)


def _check_node(path: Path, node: Node) -> None:
    if not isinstance(node, Node):
        raise RobotError(f"expected a Node, got {type(node).__name__}", path=path, rule="node-type")
    if not isinstance(node.type, PartType):
        raise RobotError(f"unknown part type {node.type!r}", path=path, rule="part-type")
    if path and node.type == PartType.CORE:
        raise RobotError("a core can only be the root", path=path, rule="core-not-root")
    spec = PART_SPECS[node.type]
    # ``90.0 in ORIENTATIONS`` and ``False in ORIENTATIONS`` hold, but JSON would write a float or
    # a boolean that reading refuses: only real integers are orientations.
    if not _integer(node.orientation) or node.orientation not in ORIENTATIONS:
        raise RobotError(
            f"orientation {node.orientation!r} is not one of {ORIENTATIONS} degrees",
            path=path, rule="orientation",
        )
    if len(node.params) != len(spec.params):
        raise RobotError(
            f"{node.type.value} takes {len(spec.params)} parameters "
            f"{spec.param_names}, got {len(node.params)}",
            path=path, rule="param-count",
        )
    for p, value in zip(spec.params, node.params, strict=True):
        if not _finite(value) or not (p.low <= value <= p.high):
            raise RobotError(
                f"parameter {p.name}={value!r} is outside [{p.low}, {p.high}] {p.unit}",
                path=path, rule="param-range",
            )
    if len(node.color) != 3 or not all(_finite(c) and 0.0 <= c <= 1.0 for c in node.color):
        raise RobotError(f"colour {node.color!r} is not 3 values in [0, 1]", path=path,
                         rule="color")
    if not isinstance(node.children, tuple) or not all(
        isinstance(sc, tuple) and len(sc) == 2 and _integer(sc[0])
        and isinstance(sc[1], Node) for sc in node.children
    ):
        raise RobotError("children must be a tuple of (slot, Node) pairs", path=path,
                         rule="children")
    slots = [s for s, _ in node.children]
    for s in slots:
        if s not in spec.child_slots:
            allowed = ", ".join(map(str, spec.child_slots)) or "none"
            raise RobotError(
                f"{node.type.value} has no child slot {s!r} (child slots: {allowed})",
                path=path, rule="slot",
            )
    if len(set(slots)) != len(slots):
        raise RobotError("a slot holds more than one child", path=path, rule="slot-duplicate")
    if slots != sorted(slots):
        raise RobotError("children are not sorted by slot", path=path, rule="slot-order")
    _check_neurons(path, node)


def _check_neurons(path: Path, node: Node) -> None:
    """The neurons a part carries: one per sensor value and actuator, valid types and values."""
    spec = PART_SPECS[node.type]
    inputs = [n for n in node.neurons if n.layer == Layer.INPUT]
    outputs = [n for n in node.neurons if n.layer == Layer.OUTPUT]
    if len(inputs) != spec.n_inputs:
        raise RobotError(
            f"{node.type.value} has {spec.n_inputs} sensor values but carries {len(inputs)} "
            "input neurons", path=path, rule="input-neurons",
        )
    if len(outputs) != spec.n_outputs:
        raise RobotError(
            f"{node.type.value} has {spec.n_outputs} actuators but carries {len(outputs)} "
            "output neurons", path=path, rule="output-neurons",
        )
    for nr in node.neurons:
        if not isinstance(nr.layer, Layer) or not isinstance(nr.activation, Activation):
            raise RobotError(f"neuron {nr.id!r} has an unknown layer or activation",
                             path=path, rule="neuron-type")
        if (nr.layer == Layer.INPUT) != (nr.activation == Activation.INPUT):
            raise RobotError(
                f"neuron {nr.id!r}: only input neurons (and all of them) use the input activation",
                path=path, rule="neuron-activation",
            )
        for pname in NEURON_PARAM_BOUNDS:  # unused ones too: JSON cannot hold NaN or infinity
            value = getattr(nr, pname)
            low, high = NEURON_PARAM_BOUNDS[pname]
            if not _finite(value):
                raise RobotError(f"neuron {nr.id!r}: {pname}={value!r} is not a finite number",
                                 path=path, rule="neuron-param")
            if pname in ACTIVATION_PARAMS[nr.activation.value] and not (low <= value <= high):
                raise RobotError(
                    f"neuron {nr.id!r}: {pname}={value!r} is outside [{low}, {high}]",
                    path=path, rule="neuron-param",
                )


REMEMBERED = 64
"""How many checked robots :func:`check` remembers (the most recently used ones)."""


@dataclass(frozen=True, eq=False)
class Checked:
    """A robot that passed :func:`validate` under ``limits``, and its assembly.

    Attributes:
        robot: The robot.
        limits: The limits it was checked against.
        assembly: ``assemble(robot)``.
    """

    robot: Robot
    limits: Limits
    assembly: Assembly


class _Recent:
    """The last robots that passed, by identity: a bounded, thread-safe memory of records."""

    def __init__(self, size: int) -> None:
        self._size = size
        self._records: OrderedDict[int, Checked] = OrderedDict()
        self._lock = threading.Lock()

    def find(self, robot: Robot) -> Checked | None:
        """The record of this very robot object, or None."""
        with self._lock:
            record = self._records.get(id(robot))
            # A record holds its robot, so no other object can have that id while it is here.
            if record is None or record.robot is not robot:
                return None
            self._records.move_to_end(id(robot))
            return record

    def keep(self, record: Checked) -> None:
        with self._lock:
            self._records[id(record.robot)] = record
            self._records.move_to_end(id(record.robot))
            while len(self._records) > self._size:
                self._records.popitem(last=False)


_RECENT = _Recent(REMEMBERED)


def assembly_of(robot: Robot) -> Assembly:
    """``assemble(robot)``, taken from :func:`check`'s record of this robot object if it has one.

    The robot is assumed structurally valid, as for :func:`~revolve_env.body.geometry.assemble`.
    """
    record = _RECENT.find(robot)
    return record.assembly if record is not None else assemble(robot)


def validate(robot: Robot, limits: Limits | None = None) -> None:
    """Check that ``robot`` is a well-formed, constructible robot within ``limits``.

    (:func:`check`, which also returns the record.)

    Raises:
        RobotError: naming the first offending node and the rule it breaks.
    """
    check(robot, limits)


def check(robot: Robot, limits: Limits | None = None, *,
          assembly: Assembly | None = None) -> Checked:
    """:func:`validate` ``robot`` and return the record of it; checked once per robot object.

    A robot object that passed under equal limits among the last :data:`REMEMBERED` is not
    checked again: its record is returned.

    Args:
        robot: The robot.
        limits: The limits (default :class:`Limits`).
        assembly: The robot's assembly if the caller has made it (an operator's check of the
            body); used only if it is the assembly of this very body (its core's node is
            ``robot.body``), else the robot is assembled.

    Raises:
        RobotError: naming the first offending node and the rule it breaks.
    """
    limits = limits or Limits()
    known = _RECENT.find(robot)
    if known is not None:
        if known.limits == limits:
            return known
        assembly = known.assembly  # checked under other limits: assembled all the same
    _check_structure(robot, limits)
    if assembly is None or not assembly.parts or assembly.parts[0].node is not robot.body:
        assembly = assemble(robot)
    hits = overlapping_boxes(assembly, limits.overlap_tolerance)
    if hits:
        i, j = hits[0]
        a, b = assembly.boxes[i], assembly.boxes[j]
        pa, pb = assembly.parts[a.part].path, assembly.parts[b.part].path
        raise RobotError(
            f"not constructible: its {a.name} intersects the {b.name} of the part at {_fmt(pb)}",
            path=pa, rule="overlap",
        )
    record = Checked(robot, limits, assembly)
    _RECENT.keep(record)
    return record


def _check_structure(robot: Robot, limits: Limits) -> None:
    """Everything :func:`validate` checks but the parts' overlap."""
    if not isinstance(robot, Robot):
        raise RobotError(f"expected a Robot, got {type(robot).__name__}", rule="robot-type")
    if not isinstance(robot.body, Node) or robot.body.type != PartType.CORE:
        raise RobotError("the root part must be a core", path=(), rule="root-core")

    ids: dict[str, Path] = {}
    n_in = n_out = n_hidden = 0
    for n_parts, (path, node) in enumerate(robot.walk(), start=1):
        _check_node(path, node)
        for nr in node.neurons:
            if not isinstance(nr.id, str) or not nr.id:
                raise RobotError("a neuron id must be a non-empty string", path=path,
                                 rule="neuron-id")
            if nr.id in ids:
                raise RobotError(f"neuron id {nr.id!r} is used twice (also at {_fmt(ids[nr.id])})",
                                 path=path, rule="neuron-id-duplicate")
            ids[nr.id] = path
            n_in += nr.layer == Layer.INPUT
            n_out += nr.layer == Layer.OUTPUT
            n_hidden += nr.layer == Layer.HIDDEN
        if n_parts > limits.max_parts:
            raise RobotError(f"more than {limits.max_parts} parts", rule="max-parts")

    for name, count, limit in (
        ("inputs", n_in, limits.max_inputs),
        ("outputs", n_out, limits.max_outputs),
        ("hidden neurons", n_hidden, limits.max_hidden),
    ):
        if count > limit:
            raise RobotError(f"{count} {name}, more than the limit of {limit}",
                             rule=f"max-{name.split()[0]}")

    layers = {nr.id: nr.layer for nr in robot.neurons()}
    seen: set[tuple[str, str]] = set()
    low, high = WEIGHT_BOUNDS
    for c in robot.connections:
        for end in (c.src, c.dst):
            if end not in layers:
                raise RobotError(f"connection {c.src!r} -> {c.dst!r} refers to a missing neuron "
                                 f"{end!r}", rule="connection-ref")
        if layers[c.dst] == Layer.INPUT:
            raise RobotError(f"connection {c.src!r} -> {c.dst!r} ends at an input neuron",
                             rule="connection-into-input")
        if not _finite(c.weight) or not (low <= c.weight <= high):
            raise RobotError(f"connection {c.src!r} -> {c.dst!r}: weight {c.weight!r} is outside "
                             f"[{low}, {high}]", rule="connection-weight")
        if (c.src, c.dst) in seen:
            raise RobotError(f"connection {c.src!r} -> {c.dst!r} appears twice",
                             rule="connection-duplicate")
        seen.add((c.src, c.dst))
