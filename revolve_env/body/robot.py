"""Robot description: a tree of parts that also carries the neural network.

Pure data, no physics. A :class:`Robot` is a root :class:`Node` (always a core) whose children are
keyed by the parent's slot, plus the weighted :class:`Connection` s between the neurons that the
nodes carry. Everything is a frozen dataclass, so robots are hashable, comparable and safe to share
between processes.

Conventions used everywhere in the package:

* **Traversal order.** ``Robot.walk()`` is a depth-first pre-order walk with children visited in
  increasing slot order. Sensor values (controller inputs) and actuator targets (controller
  outputs) are laid out in that order, and within a node in the order of its neurons.
* **Paths.** A node is addressed by its path: the tuple of slots taken from the root, ``()`` for
  the core.
* **Neuron ids** are strings, unique within a robot. Connections refer to neurons by id.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from enum import Enum

from revolve_env.body.errors import RobotError

__all__ = [
    "ACTIVATION_PARAMS",
    "NEURON_PARAM_BOUNDS",
    "WEIGHT_BOUNDS",
    "Activation",
    "Connection",
    "Layer",
    "Neuron",
    "Node",
    "PartType",
    "Path",
    "Robot",
]

Path = tuple[int, ...]
"""Slots taken from the root to reach a node; ``()`` is the core."""


class PartType(str, Enum):
    """The seven RoboGen part types."""

    CORE = "core"
    BRICK = "brick"
    PARAMETRIC_BAR = "parametric_bar"
    ACTIVE_HINGE = "active_hinge"
    PASSIVE_HINGE = "passive_hinge"
    TOUCH_SENSOR = "touch_sensor"
    LIGHT_SENSOR = "light_sensor"


WEIGHT_BOUNDS: tuple[float, float] = (-2.0, 2.0)
"""Allowed range of connection weights."""

NEURON_PARAM_BOUNDS: dict[str, tuple[float, float]] = {
    "bias": (-2.0, 2.0),
    "gain": (0.0, 4.0),
    "period": (0.25, 4.0),  # seconds
    "phase_offset": (0.0, 1.0),  # fraction of the period
    "amplitude": (0.0, 1.0),
}
"""Allowed range of each neuron parameter (used by validation, mutation and learners)."""

ACTIVATION_PARAMS: dict[str, tuple[str, ...]] = {
    "input": (),
    "linear": ("bias", "gain"),
    "sigmoid": ("bias", "gain"),
    "oscillator": ("period", "phase_offset", "amplitude"),
}
"""The parameters that matter for each activation (by ``Activation`` value)."""


class Layer(str, Enum):
    """Where a neuron sits in the network."""

    INPUT = "input"
    OUTPUT = "output"
    HIDDEN = "hidden"


class Activation(str, Enum):
    """Neuron activation (RoboGen/Revolve neuron types).

    * ``INPUT``: the value of one sensor reading; only for input neurons.
    * ``LINEAR``: ``gain * (sum_in - bias)``.
    * ``SIGMOID``: ``1 / (1 + exp(-gain * (sum_in - bias)))``.
    * ``OSCILLATOR``:
      ``0.5 - amplitude/2 + amplitude * (sin(2 pi (t - period*phase_offset) / period) + 1) / 2``;
      depends only on time, its inputs are ignored.
    """

    INPUT = "input"
    LINEAR = "linear"
    SIGMOID = "sigmoid"
    OSCILLATOR = "oscillator"


@dataclass(frozen=True, slots=True)
class Neuron:
    """One neuron, placed on the part that carries it.

    Attributes:
        id: Unique within the robot.
        layer: Input, output or hidden.
        activation: Activation function (``INPUT`` for input neurons, never for the others).
        bias: Linear and sigmoid only. Dimensionless.
        gain: Linear and sigmoid only. Dimensionless.
        period: Oscillator only. Seconds.
        phase_offset: Oscillator only. Fraction of the period, in [0, 1].
        amplitude: Oscillator only. Dimensionless, in [0, 1]: the output swings in
            ``[0.5 - amplitude/2, 0.5 + amplitude/2]``.
    """

    id: str
    layer: Layer
    activation: Activation
    bias: float = 0.0
    gain: float = 1.0
    period: float = 1.0
    phase_offset: float = 0.0
    amplitude: float = 1.0


@dataclass(frozen=True, slots=True)
class Connection:
    """A weighted connection ``src -> dst`` between two neurons of the same robot.

    Any pair is allowed except into an input neuron; recurrent connections read the source's value
    of the previous control tick (as RoboGen does).
    """

    src: str
    dst: str
    weight: float


@dataclass(frozen=True, slots=True)
class Node:
    """One part of the robot and the subtree attached to it.

    Attributes:
        type: Part type.
        orientation: Rotation of the part about its attachment axis, degrees, one of 0/90/180/270.
        params: Part parameters, in the order of ``PART_SPECS[type].param_names`` (only the
            parametric bar has any: length in metres, tilt and rotation in degrees).
        color: RGB in [0, 1], inherited through reproduction so a picture shows descent.
        neurons: Neurons carried by this part: its input neurons (one per sensor value), its
            output neurons (one per actuator), and any hidden neurons placed on it.
        children: ``(slot, child)`` pairs sorted by slot; a slot appears at most once.
    """

    type: PartType
    orientation: int = 0
    params: tuple[float, ...] = ()
    color: tuple[float, float, float] = (0.7, 0.7, 0.7)
    neurons: tuple[Neuron, ...] = ()
    children: tuple[tuple[int, Node], ...] = ()

    def child(self, slot: int) -> Node | None:
        """The child attached at ``slot``, or None."""
        for s, c in self.children:
            if s == slot:
                return c
        return None

    def with_child(self, slot: int, child: Node | None) -> Node:
        """A copy with ``child`` attached at ``slot`` (replacing any), or detached if None."""
        kept = [(s, c) for s, c in self.children if s != slot]
        if child is not None:
            kept.append((slot, child))
        kept.sort(key=lambda sc: sc[0])
        return replace(self, children=tuple(kept))

    def size(self) -> int:
        """Number of parts in this subtree."""
        return 1 + sum(c.size() for _, c in self.children)

    def walk(self, path: Path = ()) -> Iterator[tuple[Path, Node]]:
        """Depth-first pre-order walk, children in slot order, yielding ``(path, node)``."""
        yield path, self
        for slot, c in self.children:
            yield from c.walk((*path, slot))


@dataclass(frozen=True, slots=True)
class Robot:
    """A robot: the body tree rooted at a core, and the connections of its neural network.

    Attributes:
        body: Root node; must be a core.
        connections: Weighted connections between neurons carried by the body's nodes.
        name: Free text, for people (not used by any algorithm). Text that UTF-8 cannot
            encode (a lone surrogate) raises RobotError at construction.
    """

    body: Node
    connections: tuple[Connection, ...] = ()
    name: str = field(default="", compare=True)

    def __post_init__(self) -> None:
        # A name that UTF-8 cannot hold (a lone surrogate, e.g. from a "\ud800" JSON escape)
        # could never be saved: refuse it here rather than let save() fail later.
        if isinstance(self.name, str) and not self.name.isascii():
            try:
                self.name.encode("utf-8")
            except UnicodeEncodeError as exc:
                raise RobotError(f"name holds text that UTF-8 cannot encode ({exc.reason} "
                                 f"{self.name[exc.start]!a} at character {exc.start})",
                                 rule="json-text") from None

    # -- traversal --------------------------------------------------------------------------
    def walk(self) -> Iterator[tuple[Path, Node]]:
        """Depth-first pre-order walk of the body, children in slot order."""
        return self.body.walk()

    def node(self, path: Path) -> Node:
        """The node at ``path``. Raises KeyError if there is none."""
        n = self.body
        for slot in path:
            c = n.child(slot)
            if c is None:
                raise KeyError(f"no part at path {path}")
            n = c
        return n

    def num_parts(self) -> int:
        """Number of parts, core included."""
        return self.body.size()

    def neurons(self) -> list[Neuron]:
        """All neurons in traversal order."""
        return [nr for _, n in self.walk() for nr in n.neurons]

    def neurons_of(self, layer: Layer) -> list[Neuron]:
        """Neurons of one layer in traversal order (the controller's input/output layout)."""
        return [nr for nr in self.neurons() if nr.layer == layer]

    def neuron_paths(self) -> dict[str, Path]:
        """Map each neuron id to the path of the part that carries it."""
        return {nr.id: p for p, n in self.walk() for nr in n.neurons}

    # -- functional updates ------------------------------------------------------------------
    def replace_node(self, path: Path, new: Node | None) -> Robot:
        """A copy with the subtree at ``path`` replaced by ``new`` (removed if None).

        Connections are not touched; call :meth:`prune_connections` afterwards if neurons went
        away. The root cannot be removed.
        """
        if not path:
            if new is None:
                raise ValueError("the core cannot be removed")
            return replace(self, body=new)
        parents = [self.body]
        for slot in path[:-1]:
            c = parents[-1].child(slot)
            if c is None:
                raise KeyError(f"no part at path {path[:-1]}")
            parents.append(c)
        if parents[-1].child(path[-1]) is None and new is None:
            raise KeyError(f"no part at path {path}")
        updated: Node | None = new
        for depth in range(len(path) - 1, -1, -1):
            updated = parents[depth].with_child(path[depth], updated)
        assert updated is not None
        return replace(self, body=updated)

    def prune_connections(self) -> Robot:
        """A copy without connections whose ends are missing or whose destination is an input."""
        layers = {nr.id: nr.layer for nr in self.neurons()}
        kept = tuple(
            c
            for c in self.connections
            if c.src in layers and c.dst in layers and layers[c.dst] != Layer.INPUT
        )
        return replace(self, connections=kept)
