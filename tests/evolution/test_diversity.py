"""Tree edit distance: hand-computed cases for each cost rule, and the fast path equals zss."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evolution import _treedit
from evolution.config import EvolutionConfig
from evolution.diversity import (
    TreeArrays,
    brain_aware_distance,
    brain_aware_diversity,
    diversity,
    neural_distance,
    pairwise_distances,
    tree_arrays,
    tree_edit_distance,
    tree_edit_distance_zss,
    zss_distance_arrays,
)
from evolution.random_robot import random_robot
from revolve_env.body.examples import example
from revolve_env.body.robot import Activation, Connection, Layer, Neuron, Node, PartType, Robot

T = PartType


def body(children: dict[int, Node] | None = None) -> Robot:
    return Robot(Node(T.CORE, children=tuple(sorted((children or {}).items()))))


def n(t: PartType, children: dict[int, Node] | None = None, **kw: object) -> Node:
    return Node(t, children=tuple(sorted((children or {}).items())), **kw)  # type: ignore[arg-type]


CASES = [
    ("identical", body({0: n(T.BRICK)}), body({0: n(T.BRICK)}), 0),
    ("insert one node", body(), body({0: n(T.BRICK)}), 1),
    ("remove a two-node subtree", body({0: n(T.BRICK, {1: n(T.BRICK)})}), body(), 2),
    ("type change", body({0: n(T.BRICK)}), body({0: n(T.ACTIVE_HINGE)}), 1),
    ("different parent slot", body({0: n(T.BRICK)}), body({1: n(T.BRICK)}), 1),
    ("type and slot change", body({0: n(T.BRICK)}), body({3: n(T.TOUCH_SENSOR)}), 2),
    ("deep type change", body({0: n(T.BRICK, {2: n(T.BRICK)})}),
     body({0: n(T.BRICK, {2: n(T.LIGHT_SENSOR)})}), 1),
    ("remove an inner node, child moves up", body({0: n(T.BRICK, {1: n(T.ACTIVE_HINGE)})}),
     body({0: n(T.ACTIVE_HINGE)}), 2),  # remove brick (1) + the hinge's slot 1 -> 0 (1)
]


@pytest.mark.parametrize("name, a, b, expected", CASES, ids=[c[0] for c in CASES])
def test_hand_computed_distances(name: str, a: Robot, b: Robot, expected: int) -> None:
    assert tree_edit_distance_zss(a, b) == expected
    assert tree_edit_distance(a, b) == expected
    assert tree_edit_distance(b, a) == expected


def test_neural_and_parameter_differences_are_ignored() -> None:
    a = body({0: n(T.PARAMETRIC_BAR, params=(0.05, 0.0, 0.0))})
    b = Robot(
        Node(T.CORE, orientation=90, children=((0, n(
            T.PARAMETRIC_BAR, params=(0.1, 30.0, 90.0), orientation=180, color=(1.0, 0.0, 0.0),
            neurons=(Neuron("h", Layer.HIDDEN, Activation.LINEAR),))),)),
    )
    assert tree_edit_distance(a, b) == 0 == tree_edit_distance_zss(a, b)


@st.composite
def trees(draw: st.DrawFn, max_nodes: int = 25) -> TreeArrays:
    """Random ordered trees in pre-order: each new node hangs below a node on the right spine."""
    size = draw(st.integers(1, max_nodes))
    types = [draw(st.integers(0, 6)) for _ in range(size)]
    slots = [-1] + [draw(st.integers(0, 3)) for _ in range(size - 1)]
    parents = [-1]
    spine = [0]
    for k in range(1, size):
        depth = draw(st.integers(0, len(spine) - 1))
        del spine[depth + 1:]
        parents.append(spine[-1])
        spine.append(k)
    return TreeArrays(*(np.asarray(xs, dtype=np.int32) for xs in (types, slots, parents)))


@settings(max_examples=150, deadline=None)
@given(trees(), trees())
def test_fast_path_equals_zss_on_random_trees(a: TreeArrays, b: TreeArrays) -> None:
    fast = _treedit.distance(a.types, a.slots, a.parents, b.types, b.slots, b.parents)
    assert fast == zss_distance_arrays(a, b)


def test_pairwise_and_diversity_on_random_robots() -> None:
    rng = np.random.default_rng(0)
    robots = [random_robot(rng, EvolutionConfig()) for _ in range(6)]
    d = pairwise_distances(robots)
    assert d.shape == (6, 6) and np.all(np.diag(d) == 0) and np.array_equal(d, d.T)
    for i in range(6):
        for j in range(i + 1, 6):
            assert d[i, j] == tree_edit_distance_zss(robots[i], robots[j])
    assert diversity(robots) == pytest.approx(d[np.triu_indices(6, 1)].mean())
    assert diversity(robots[:1]) == 0.0 and diversity([]) == 0.0
    assert diversity([robots[0]] * 3) == 0.0
    assert pairwise_distances([]).shape == (0, 0)


def test_tree_arrays_are_pre_order_with_slots() -> None:
    t = tree_arrays(body({0: n(T.BRICK, {2: n(T.BRICK)}), 3: n(T.LIGHT_SENSOR)}))
    assert t.parents.tolist() == [-1, 0, 1, 0]
    assert t.slots.tolist() == [-1, 0, 2, 3]


@pytest.mark.parametrize("parents, match", [
    ([0, 0], "parent -1"),
    ([-1, 1], "pre-order"),
    ([-1, 0, 0, 1], "pre-order"),  # node 3 hangs under 1 after 1's subtree was closed
])
def test_malformed_trees_raise_value_error(parents: list[int], match: str) -> None:
    k = len(parents)
    z = np.zeros(k, dtype=np.int32)
    with pytest.raises(ValueError, match=match):
        _treedit.distance(z, z, np.asarray(parents, dtype=np.int32), z[:1], z[:1],
                          np.asarray([-1], dtype=np.int32))
    with pytest.raises(ValueError, match="same length"):
        _treedit.distance(z, z[:1], np.asarray(parents, dtype=np.int32), z, z, z)


@pytest.mark.parametrize("offsets, match", [
    ([], "at least one"),
    ([0, 1], "end at the total"),
    ([0, 100, 2], "must not decrease"),  # refused before tree 0 (100 nodes) would be read
])
def test_pairwise_refuses_bad_offsets(offsets: list[int], match: str) -> None:
    z = np.zeros(2, dtype=np.int32)
    parents = np.asarray([-1, -1], dtype=np.int32)
    with pytest.raises(ValueError, match=match):
        _treedit.pairwise(z, z, parents, np.asarray(offsets, dtype=np.int32))


# -- brain-aware distance -----------------------------------------------------------------------

def _hinge_brain(weight: float, extra: bool = False) -> Robot:
    """A core with one active hinge: its output neuron, an oscillator on the core driving it."""
    core_neurons = [Neuron("osc", Layer.HIDDEN, Activation.OSCILLATOR)]
    if extra:
        core_neurons.append(Neuron("h", Layer.HIDDEN, Activation.LINEAR))
    hinge = n(T.ACTIVE_HINGE, neurons=(Neuron("out", Layer.OUTPUT, Activation.LINEAR),))
    return Robot(Node(T.CORE, neurons=tuple(core_neurons), children=((0, hinge),)),
                 (Connection("osc", "out", weight),))


def test_neural_distance_by_hand() -> None:
    a, b = _hinge_brain(0.5), _hinge_brain(-0.25)
    assert neural_distance(a, b) == pytest.approx(0.75)  # one connection, |0.5 - -0.25|
    c = _hinge_brain(0.5, extra=True)
    assert neural_distance(a, c) == pytest.approx(1.0)  # one neuron in c only
    assert brain_aware_distance(a, body({0: n(T.ACTIVE_HINGE)})) == pytest.approx(
        0 + 2 + 0.5)  # same body; 2 neurons and the 0.5 connection in a only
    assert brain_aware_distance(a, b, weight=2.0) == pytest.approx(1.5)
    assert brain_aware_distance(a, b, weight=0.0) == tree_edit_distance(a, b) == 0
    with pytest.raises(ValueError, match="brain weight"):
        brain_aware_distance(a, b, weight=-1.0)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(0, 2**32 - 1),
       st.floats(0.0, 10.0, allow_nan=False))
def test_brain_aware_distance_properties(seed_a: int, seed_b: int, weight: float) -> None:
    config = EvolutionConfig(max_parts=12)
    a = random_robot(np.random.default_rng(seed_a), config)
    b = random_robot(np.random.default_rng(seed_b), config)
    assert brain_aware_distance(a, a, weight) == 0.0
    d = brain_aware_distance(a, b, weight)
    assert d == pytest.approx(brain_aware_distance(b, a, weight))
    assert d >= tree_edit_distance(a, b)
    assert d == pytest.approx(tree_edit_distance(a, b) + weight * neural_distance(a, b))


def test_brain_aware_diversity_is_the_mean_pairwise_distance() -> None:
    rng = np.random.default_rng(1)
    robots = [random_robot(rng, EvolutionConfig(max_parts=12)) for _ in range(4)]
    pairs = [brain_aware_distance(robots[i], robots[j], 0.5)
             for i in range(4) for j in range(i + 1, 4)]
    assert brain_aware_diversity(robots, 0.5) == pytest.approx(np.mean(pairs))
    assert brain_aware_diversity(robots, 0.0) == pytest.approx(diversity(robots))
    assert brain_aware_diversity(robots[:1]) == 0.0


def test_neural_distance_sees_oscillator_timing() -> None:
    """Two robots that differ only in an oscillator's period and phase are apart by exactly the
    differences (seconds and fractions of a period)."""
    spider = example("spider")
    oscillators = [n for _, node in spider.walk() for n in node.neurons
                   if n.activation == Activation.OSCILLATOR]
    assert oscillators
    first = oscillators[0]
    changed = replace_neuron(spider, first.id, period=first.period + 0.25,
                             phase_offset=abs(first.phase_offset - 0.5))
    expected = 0.25 + abs(abs(first.phase_offset - 0.5) - first.phase_offset)
    assert neural_distance(spider, changed) == pytest.approx(expected)
    assert neural_distance(spider, spider) == 0.0


def replace_neuron(robot: Robot, neuron_id: str, **changes: float) -> Robot:
    """``robot`` with one neuron's parameters changed."""
    def node(n: Node) -> Node:
        neurons = tuple(dataclasses.replace(x, **changes) if x.id == neuron_id else x
                        for x in n.neurons)
        return dataclasses.replace(n, neurons=neurons,
                                   children=tuple((s, node(c)) for s, c in n.children))

    return dataclasses.replace(robot, body=node(robot.body))
