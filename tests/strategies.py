"""Hypothesis strategies for random valid robots, shared by the test suites.

``robots()`` grows a random tree from the core: each step picks a free slot of a part already
placed and attaches a random part (type, orientation, parameters, colour) there, skipping any part
that would intersect the others or break a limit, so every robot drawn is constructible. Each part
carries the input and output neurons its type requires; hidden neurons sit on random parts;
connections join random neuron pairs (recurrent ones and self-loops included), never end in an
input neuron, and are unique per pair. Every number lies inside its bounds and the result always
passes ``validate`` with the given limits.

Usage::

    from strategies import robots

    @given(robots(max_parts=6))
    def test_something(robot): ...
"""

from __future__ import annotations

from dataclasses import dataclass, field

from hypothesis import strategies as st

from revolve_env.body.geometry import assemble, overlapping_boxes
from revolve_env.body.parts import PART_SPECS
from revolve_env.body.robot import (
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

__all__ = ["neuron_params", "part_types", "robots"]

_CHILD_TYPES = tuple(t for t in PartType if t != PartType.CORE)
_NON_INPUT = (Activation.LINEAR, Activation.SIGMOID, Activation.OSCILLATOR)


def part_types() -> st.SearchStrategy[PartType]:
    """Any part type that can be attached to another part (all but the core)."""
    return st.sampled_from(_CHILD_TYPES)


@st.composite
def neuron_params(draw: st.DrawFn) -> dict[str, float]:
    """Values for all five neuron parameters, each inside ``NEURON_PARAM_BOUNDS``."""
    return {
        name: draw(st.floats(lo, hi, allow_nan=False, allow_infinity=False))
        for name, (lo, hi) in NEURON_PARAM_BOUNDS.items()
    }


@dataclass
class _Draft:
    """A part under construction (mutable while the tree grows)."""

    type: PartType
    orientation: int
    params: tuple[float, ...]
    color: tuple[float, float, float]
    neurons: list[Neuron] = field(default_factory=list)
    children: dict[int, _Draft] = field(default_factory=dict)

    def freeze(self) -> Node:
        return Node(
            self.type, self.orientation, self.params, self.color, tuple(self.neurons),
            tuple((s, c.freeze()) for s, c in sorted(self.children.items())),
        )

    def walk(self, path: Path = ()) -> list[tuple[Path, _Draft]]:
        out = [(path, self)]
        for s, c in sorted(self.children.items()):
            out.extend(c.walk((*path, s)))
        return out


@st.composite
def _color(draw: st.DrawFn) -> tuple[float, float, float]:
    unit = st.floats(0.0, 1.0, allow_nan=False)
    return (draw(unit), draw(unit), draw(unit))


@st.composite
def robots(
    draw: st.DrawFn,
    max_parts: int = 8,
    max_hidden: int = 3,
    max_connections: int = 8,
    limits: Limits | None = None,
) -> Robot:
    """A random valid robot.

    Args:
        max_parts: Most parts, core included (also capped by ``limits.max_parts``).
        max_hidden: Most hidden neurons (also capped by ``limits.max_hidden``).
        max_connections: Most connections.
        limits: Limits the robot must satisfy (default ``Limits()``).
    """
    limits = limits or Limits()
    counter = iter(range(10**6))

    def new_id() -> str:
        # Unique by the running number, which the colon ends ("n1" + "0" would equal "n10" + "");
        # the random suffix exercises JSON string escaping.
        return f"n{next(counter)}:{draw(st.text(max_size=3))}"

    def sensor_neurons(part: PartType) -> list[Neuron]:
        spec = PART_SPECS[part]
        out = [Neuron(new_id(), Layer.INPUT, Activation.INPUT, **draw(neuron_params()))
               for _ in spec.input_names]
        out += [Neuron(new_id(), Layer.OUTPUT, draw(st.sampled_from(_NON_INPUT)),
                       **draw(neuron_params())) for _ in range(spec.n_outputs)]
        return out

    core = _Draft(PartType.CORE, draw(st.sampled_from(ORIENTATIONS)), (), draw(_color()))
    core.neurons = sensor_neurons(PartType.CORE)
    n_in, n_out = PART_SPECS[PartType.CORE].n_inputs, 0

    attempts = draw(st.integers(0, max(0, min(max_parts, limits.max_parts) - 1)))
    for _ in range(attempts):
        free = [(p, d, s) for p, d in core.walk() for s in PART_SPECS[d.type].child_slots
                if s not in d.children]
        if not free:
            break
        _, parent, slot = draw(st.sampled_from(free))
        part = draw(part_types())
        spec = PART_SPECS[part]
        if n_in + spec.n_inputs > limits.max_inputs or n_out + spec.n_outputs > limits.max_outputs:
            continue
        params = tuple(draw(st.floats(p.low, p.high, allow_nan=False)) for p in spec.params)
        child = _Draft(part, draw(st.sampled_from(ORIENTATIONS)), params, draw(_color()))
        parent.children[slot] = child
        if overlapping_boxes(assemble(Robot(core.freeze())), limits.overlap_tolerance):
            del parent.children[slot]  # not constructible there: skip this part
            continue
        child.neurons = sensor_neurons(part)
        n_in += spec.n_inputs
        n_out += spec.n_outputs

    placed = [d for _, d in core.walk()]
    for _ in range(draw(st.integers(0, min(max_hidden, limits.max_hidden)))):
        host = draw(st.sampled_from(placed))
        host.neurons.append(Neuron(new_id(), Layer.HIDDEN, draw(st.sampled_from(_NON_INPUT)),
                                   **draw(neuron_params())))
    # Shuffle each part's neurons: the order within a part is free (it sets the I/O layout).
    for d in placed:
        d.neurons = draw(st.permutations(d.neurons))

    body = core.freeze()
    all_neurons = [nr for _, n in body.walk() for nr in n.neurons]
    targets = [nr.id for nr in all_neurons if nr.layer != Layer.INPUT]
    connections: list[Connection] = []
    if targets:
        pairs = draw(st.lists(
            st.tuples(st.sampled_from([nr.id for nr in all_neurons]), st.sampled_from(targets)),
            max_size=max_connections, unique=True,
        ))
        weight = st.floats(*WEIGHT_BOUNDS, allow_nan=False)
        connections = [Connection(src, dst, draw(weight)) for src, dst in pairs]
    robot = Robot(body, tuple(connections), draw(st.text(max_size=8)))
    validate(robot, limits)  # a failure here is a bug in this strategy or in validate
    return robot
