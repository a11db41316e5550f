"""Random robots grown part by part, and the tree helpers the operators share.

A random robot is grown from a core by attaching random parts to random free slots until a drawn
size is reached; a placement whose boxes would intersect the body is discarded. It then gets random
hidden neurons and connections. Every random choice draws from the ``numpy.random.Generator``
passed in, so a seed reproduces the robot.
"""

from __future__ import annotations

import colorsys
import re
from collections.abc import Iterable
from dataclasses import dataclass, replace

import numpy as np

from evolution.config import EvolutionConfig
from revolve_env.body.geometry import Assembly, assemble, overlapping_boxes
from revolve_env.body.parts import PART_SPECS
from revolve_env.body.robot import (
    ACTIVATION_PARAMS,
    NEURON_PARAM_BOUNDS,
    WEIGHT_BOUNDS,
    Activation,
    Connection,
    Layer,
    Neuron,
    Node,
    PartType,
    Path,
    Robot,
)
from revolve_env.body.validate import ORIENTATIONS, Limits, validate

__all__ = [
    "Counts",
    "IdAllocator",
    "RandomRobotError",
    "RandomRobotResult",
    "constructible",
    "constructible_assembly",
    "free_slots",
    "random_connections",
    "random_neuron",
    "random_part",
    "random_robot",
    "random_robot_with_report",
    "robot_counts",
    "subtree_counts",
]

NON_CORE_TYPES: tuple[PartType, ...] = tuple(t for t in PartType if t != PartType.CORE)
NEURON_ACTIVATIONS: tuple[Activation, ...] = (
    Activation.LINEAR,
    Activation.SIGMOID,
    Activation.OSCILLATOR,
)


class RandomRobotError(RuntimeError):
    """No valid random robot of the drawn size could be grown within the retry budget."""


@dataclass(frozen=True, slots=True)
class Counts:
    """Sizes that the limits bound: parts, input, output and hidden neurons."""

    parts: int = 0
    inputs: int = 0
    outputs: int = 0
    hidden: int = 0

    def __add__(self, other: Counts) -> Counts:
        return Counts(self.parts + other.parts, self.inputs + other.inputs,
                      self.outputs + other.outputs, self.hidden + other.hidden)

    def __sub__(self, other: Counts) -> Counts:
        return Counts(self.parts - other.parts, self.inputs - other.inputs,
                      self.outputs - other.outputs, self.hidden - other.hidden)

    def within(self, config: EvolutionConfig) -> bool:
        """Whether these counts respect every limit of ``config`` (min parts included)."""
        return (
            config.min_parts <= self.parts <= config.max_parts
            and self.inputs <= config.max_inputs
            and self.outputs <= config.max_outputs
            and self.hidden <= config.max_hidden
        )


def subtree_counts(node: Node) -> Counts:
    """Counts of the subtree rooted at ``node``."""
    parts = inputs = outputs = hidden = 0
    for _, n in node.walk():
        parts += 1
        for nr in n.neurons:
            inputs += nr.layer == Layer.INPUT
            outputs += nr.layer == Layer.OUTPUT
            hidden += nr.layer == Layer.HIDDEN
    return Counts(parts, inputs, outputs, hidden)


def robot_counts(robot: Robot) -> Counts:
    """Counts of the whole robot."""
    return subtree_counts(robot.body)


def free_slots(robot: Robot) -> list[tuple[Path, int]]:
    """``(path of a part, free slot of that part)`` in traversal order."""
    out: list[tuple[Path, int]] = []
    for path, node in robot.walk():
        used = {s for s, _ in node.children}
        out.extend((path, s) for s in PART_SPECS[node.type].child_slots if s not in used)
    return out


def constructible(robot: Robot, limits: Limits) -> bool:
    """Whether no two parts of ``robot`` intersect (the physical part of validation)."""
    return constructible_assembly(robot, limits) is not None


def constructible_assembly(robot: Robot, limits: Limits) -> Assembly | None:
    """``robot``'s assembly if no two of its parts intersect, else None.

    (What :func:`constructible` decides; the assembly lets the final check of a child that an
    operator has just assembled skip assembling it again: ``validate.check(..., assembly=)``.)
    """
    assembly = assemble(robot)
    return None if overlapping_boxes(assembly, limits.overlap_tolerance) else assembly


_SUFFIX = re.compile(r"(\d+)$")


class IdAllocator:
    """Fresh neuron ids ``n<k>``, with ``k`` counting up from above every numeric suffix in use.

    Deterministic: the ids depend only on the ids already taken, never on hashing or time.
    """

    def __init__(self, taken: Iterable[str]) -> None:
        self._taken = set(taken)
        suffixes = [int(m.group(1)) for t in self._taken if (m := _SUFFIX.search(t))]
        self._next = max(suffixes, default=-1) + 1

    def fresh(self) -> str:
        """A new id, never returned before and not in the initial set."""
        while f"n{self._next}" in self._taken:
            self._next += 1
        new = f"n{self._next}"
        self._taken.add(new)
        self._next += 1
        return new


def random_color(rng: np.random.Generator) -> tuple[float, float, float]:
    """A saturated random colour (RGB in [0, 1]) so that lineages stand apart in pictures."""
    r, g, b = colorsys.hsv_to_rgb(float(rng.random()), 0.75, 0.9)
    return (float(r), float(g), float(b))


def random_neuron(rng: np.random.Generator, neuron_id: str, layer: Layer) -> Neuron:
    """An output or hidden neuron with a random activation and parameters within their bounds."""
    if layer == Layer.INPUT:
        return Neuron(neuron_id, Layer.INPUT, Activation.INPUT)
    activation = NEURON_ACTIVATIONS[int(rng.integers(len(NEURON_ACTIVATIONS)))]
    params = {
        name: float(rng.uniform(*NEURON_PARAM_BOUNDS[name]))
        for name in ACTIVATION_PARAMS[activation.value]
    }
    return Neuron(neuron_id, layer, activation, **params)


def allowed_types(counts: Counts, config: EvolutionConfig) -> list[PartType]:
    """Part types that can be added to a robot with ``counts`` without breaking a limit."""
    if counts.parts >= config.max_parts:
        return []
    return [
        t for t in NON_CORE_TYPES
        if counts.inputs + PART_SPECS[t].n_inputs <= config.max_inputs
        and counts.outputs + PART_SPECS[t].n_outputs <= config.max_outputs
    ]


def random_part(
    rng: np.random.Generator, part_type: PartType, color: tuple[float, float, float],
    ids: IdAllocator,
) -> Node:
    """A childless part with random orientation and parameters and its input/output neurons."""
    spec = PART_SPECS[part_type]
    params = tuple(float(rng.uniform(p.low, p.high)) for p in spec.params)
    orientation = ORIENTATIONS[int(rng.integers(len(ORIENTATIONS)))]
    neurons = [Neuron(ids.fresh(), Layer.INPUT, Activation.INPUT) for _ in spec.input_names]
    neurons += [random_neuron(rng, ids.fresh(), Layer.OUTPUT) for _ in range(spec.n_outputs)]
    return Node(part_type, orientation, params, color, tuple(neurons))


def random_connections(
    rng: np.random.Generator, neurons: list[Neuron], density: float,
    only_touching: frozenset[str] | None = None, existing: Iterable[Connection] = (),
) -> list[Connection]:
    """Random connections over every allowed ``src -> dst`` pair (dst not an input).

    Args:
        rng: Draws the pairs.
        neurons: Candidate ends, in a fixed order (the draw order depends on it).
        density: Probability of each pair.
        only_touching: If given, only pairs with at least one end in this set are drawn.
        existing: Pairs already connected, never drawn again.
    """
    taken = {(c.src, c.dst) for c in existing}
    out: list[Connection] = []
    for src in neurons:
        for dst in neurons:
            if dst.layer == Layer.INPUT or (src.id, dst.id) in taken:
                continue
            if only_touching is not None and src.id not in only_touching \
                    and dst.id not in only_touching:
                continue
            if rng.random() < density:
                out.append(Connection(src.id, dst.id, float(rng.uniform(*WEIGHT_BOUNDS))))
    return out


def add_neurons(node: Node, extra: Iterable[Neuron]) -> Node:
    """A copy of ``node`` carrying ``extra`` neurons after its own."""
    return replace(node, neurons=(*node.neurons, *extra))


@dataclass(frozen=True, slots=True)
class RandomRobotResult:
    """A random robot and what it took to grow it.

    Attributes:
        robot: The robot (valid within the configuration's limits).
        target_parts: The drawn number of parts of the successful attempt.
        retries: Whole-robot attempts abandoned before the successful one.
        failed_placements: Part placements discarded (overlap) over all attempts.
    """

    robot: Robot
    target_parts: int
    retries: int
    failed_placements: int


def random_robot_with_report(rng: np.random.Generator,
                             config: EvolutionConfig) -> RandomRobotResult:
    """Grow a random valid robot; see :func:`random_robot`.

    Raises:
        RandomRobotError: if no attempt within ``config.max_random_robot_retries`` reached its
            drawn size.
    """
    limits = config.limits
    failed_total = 0
    for attempt in range(config.max_random_robot_retries):
        target = int(np.clip(round(rng.normal(config.initial_parts_mean, config.initial_parts_sd)),
                             config.min_parts, config.max_parts))
        color = random_color(rng)
        ids = IdAllocator(())
        core = random_part(rng, PartType.CORE, color, ids)
        robot = Robot(replace(core, orientation=0))
        counts = robot_counts(robot)
        failed = 0
        while counts.parts < target and failed < config.max_placement_attempts:
            slots = free_slots(robot)
            types = allowed_types(counts, config)
            if not slots or not types:
                break
            path, slot = slots[int(rng.integers(len(slots)))]
            part_type = types[int(rng.integers(len(types)))]
            part = random_part(rng, part_type, color, ids)
            candidate = robot.replace_node((*path, slot), part)
            if constructible(candidate, limits):
                robot = candidate
                counts = counts + subtree_counts(part)
            else:
                failed += 1
        failed_total += failed
        if counts.parts < target:
            continue
        robot = _add_random_brain(robot, rng, config, ids)
        validate(robot, limits)
        return RandomRobotResult(robot, target, attempt, failed_total)
    raise RandomRobotError(
        f"could not grow a valid random robot in {config.max_random_robot_retries} attempts "
        f"({failed_total} placements discarded for overlap); raise max_placement_attempts or "
        "lower initial_parts_mean"
    )


def random_robot(rng: np.random.Generator, config: EvolutionConfig) -> Robot:
    """A random valid robot: a tree grown part by part onto free slots up to a drawn size.

    The size is drawn from N(``initial_parts_mean``, ``initial_parts_sd``) and clipped to
    ``[min_parts, max_parts]``. Each step attaches a part of a random type (among those that keep
    the input and output limits) with random orientation and parameters to a random free slot; a
    part whose boxes would intersect the body is not added. All parts share one random colour, the
    robot's lineage colour. Active hinges get an output neuron with a random activation, sensors
    their input neurons; then ``Poisson(initial_hidden_mean)`` hidden neurons go on random parts
    and every allowed pair is connected with probability ``initial_connection_density``.
    """
    return random_robot_with_report(rng, config).robot


def _add_random_brain(
    robot: Robot, rng: np.random.Generator, config: EvolutionConfig, ids: IdAllocator
) -> Robot:
    n_hidden = min(int(rng.poisson(config.initial_hidden_mean)), config.max_hidden)
    paths = [p for p, _ in robot.walk()]
    for _ in range(n_hidden):
        path = paths[int(rng.integers(len(paths)))]
        node = robot.node(path)
        robot = robot.replace_node(path, add_neurons(node, [random_neuron(rng, ids.fresh(),
                                                                          Layer.HIDDEN)]))
    conns = random_connections(rng, robot.neurons(), config.initial_connection_density)
    return replace(robot, connections=tuple(conns))
