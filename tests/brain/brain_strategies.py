"""Hypothesis strategies for random robots with random neural networks (hand-built bodies).

A core (6 IMU inputs) carries up to four arms; an arm is a chain of active hinges (one output
neuron each) that may end in a touch sensor (2 inputs) or a light sensor (1 input). Hidden neurons
sit on random parts; connections join random neurons (recurrent ones and self-loops included) and
never end in an input neuron. All parameters are drawn inside the package's bounds.
"""

from __future__ import annotations

from hypothesis import strategies as st

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
    Robot,
)

_NON_INPUT = (Activation.LINEAR, Activation.SIGMOID, Activation.OSCILLATOR)


def _bounded(name: str) -> st.SearchStrategy[float]:
    lo, hi = NEURON_PARAM_BOUNDS[name]
    return st.floats(lo, hi, allow_nan=False)


@st.composite
def neurons(draw: st.DrawFn, nid: str, layer: Layer) -> Neuron:
    """A non-input neuron with a random activation and parameters within bounds."""
    return Neuron(
        nid,
        layer,
        draw(st.sampled_from(_NON_INPUT)),
        bias=draw(_bounded("bias")),
        gain=draw(_bounded("gain")),
        period=draw(_bounded("period")),
        phase_offset=draw(_bounded("phase_offset")),
        amplitude=draw(_bounded("amplitude")),
    )


def _inputs(prefix: str, part: PartType) -> list[Neuron]:
    return [
        Neuron(f"{prefix}-{name}", Layer.INPUT, Activation.INPUT)
        for name in PART_SPECS[part].input_names
    ]


@st.composite
def robots(
    draw: st.DrawFn, max_arms: int = 4, max_hinges: int = 3, max_hidden: int = 6,
    max_connections: int = 40,
) -> Robot:
    """A random robot with a random network (see the module docstring)."""
    arms = draw(
        st.lists(
            st.tuples(
                st.integers(0, max_hinges),
                st.sampled_from([None, PartType.TOUCH_SENSOR, PartType.LIGHT_SENSOR]),
            ),
            max_size=max_arms,
        )
    )
    # Flat list of parts first (so hidden neurons can be placed anywhere), tree built after.
    parts: list[tuple[PartType, list[Neuron]]] = [(PartType.CORE, _inputs("core", PartType.CORE))]
    chains: list[list[int]] = []
    for a, (n_hinges, end) in enumerate(arms):
        chain = []
        for k in range(n_hinges):
            parts.append((PartType.ACTIVE_HINGE, [draw(neurons(f"a{a}h{k}-out", Layer.OUTPUT))]))
            chain.append(len(parts) - 1)
        if end is not None:
            parts.append((end, _inputs(f"a{a}s", end)))
            chain.append(len(parts) - 1)
        chains.append(chain)
    for k in range(draw(st.integers(0, max_hidden))):
        host = draw(st.integers(0, len(parts) - 1))
        parts[host][1].append(draw(neurons(f"hid{k}", Layer.HIDDEN)))

    def build(i: int, child: Node | None) -> Node:
        kind, nrs = parts[i]
        children = ((PART_SPECS[kind].child_slots[0], child),) if child is not None else ()
        return Node(kind, neurons=tuple(nrs), children=children)

    core_children = []
    for slot, chain in enumerate(chains):
        node: Node | None = None
        for i in reversed(chain):
            node = build(i, node)
        if node is not None:
            core_children.append((slot, node))
    core = Node(PartType.CORE, neurons=tuple(parts[0][1]), children=tuple(core_children))

    all_ids = [nr.id for _, nrs in parts for nr in nrs]
    targets = [nr.id for _, nrs in parts for nr in nrs if nr.layer != Layer.INPUT]
    connections: tuple[Connection, ...] = ()
    if targets:
        connections = tuple(
            draw(
                st.lists(
                    st.builds(
                        Connection,
                        st.sampled_from(all_ids),
                        st.sampled_from(targets),
                        st.floats(*WEIGHT_BOUNDS, allow_nan=False),
                    ),
                    max_size=max_connections,
                )
            )
        )
    return Robot(core, connections, name="random")
