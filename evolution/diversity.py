"""Genetic diversity: tree edit distance between robot bodies with the Revolve paper's costs.

Costs: inserting or removing a node 1; changing a node's part type 1; attaching it to a different
slot of its parent 1 (a relabel that changes both costs 2, the same as removing and inserting).
Orientations, parameters, colours and all neural differences are ignored. Children are ordered by
slot (the order of :meth:`Robot.walk`), so this is the ordered tree edit distance.

:func:`tree_edit_distance_zss` is the reference (``zss``, pure Python, with every cost function
passed explicitly: zss's default label distance depends on whether ``editdist`` is installed).
:func:`tree_edit_distance`, :func:`pairwise_distances` and :func:`diversity` use the exact
compiled Zhang-Shasha of ``evolution._treedit``; tests check both agree on random trees.

Brain-aware distance (optional, not the paper's): :func:`brain_aware_distance` is the body tree
edit distance plus ``weight`` times :func:`neural_distance`, which matches parts by their slot
path from the core (the same path in both bodies is the same part) and neurons of a part by
layer, activation and order. Its unit is one edit: each neuron present in one brain only costs 1,
each matched neuron the summed absolute differences of its parameters (bias, gain, oscillator
period in seconds, phase offset, amplitude), and each connection between matched neurons the
absolute difference of its weights
(dimensionless; a connection present in one brain only counts its whole weight). With
``weight = 1`` (:data:`BRAIN_WEIGHT`) one missing neuron costs as much as one missing part.
:func:`brain_aware_diversity` is its population mean, as :func:`diversity` is the body one.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import zss
from numpy.typing import NDArray

from evolution import _treedit
from revolve_env.body.robot import PartType, Robot

__all__ = [
    "BRAIN_WEIGHT",
    "TreeArrays",
    "brain_aware_distance",
    "brain_aware_diversity",
    "diversity",
    "neural_distance",
    "pairwise_distances",
    "tree_arrays",
    "tree_edit_distance",
    "tree_edit_distance_zss",
    "zss_distance_arrays",
]

PART_TYPE_IDS: dict[PartType, int] = {t: i for i, t in enumerate(PartType)}
ROOT_SLOT = -1
"""The slot label of a root (it hangs from no parent)."""


@dataclass(frozen=True)
class TreeArrays:
    """A body tree in pre-order: part type id, slot on the parent, parent index (-1: root)."""

    types: NDArray[np.int32]
    slots: NDArray[np.int32]
    parents: NDArray[np.int32]

    def __len__(self) -> int:
        return len(self.types)


def tree_arrays(robot: Robot) -> TreeArrays:
    """The body of ``robot`` as pre-order arrays (children in slot order)."""
    index: dict[tuple[int, ...], int] = {}
    types: list[int] = []
    slots: list[int] = []
    parents: list[int] = []
    for path, node in robot.walk():
        index[path] = len(types)
        types.append(PART_TYPE_IDS[node.type])
        slots.append(path[-1] if path else ROOT_SLOT)
        parents.append(index[path[:-1]] if path else -1)
    return TreeArrays(_i32(types), _i32(slots), _i32(parents))


def _i32(values: Sequence[int] | NDArray[np.int32]) -> NDArray[np.int32]:
    return np.ascontiguousarray(values, dtype=np.int32)


# -- reference: zss -----------------------------------------------------------------------------

class _ZNode:
    __slots__ = ("children", "slot", "type")

    def __init__(self, type_: int, slot: int) -> None:
        self.type = type_
        self.slot = slot
        self.children: list[_ZNode] = []


def _to_znodes(tree: TreeArrays) -> _ZNode:
    nodes = [_ZNode(int(t), int(s)) for t, s in zip(tree.types, tree.slots, strict=True)]
    for k in range(1, len(nodes)):
        nodes[int(tree.parents[k])].children.append(nodes[k])
    return nodes[0]


def _get_children(node: _ZNode) -> list[_ZNode]:
    return node.children


def _insert_cost(node: _ZNode) -> int:
    return 1


def _remove_cost(node: _ZNode) -> int:
    return 1


def _update_cost(a: _ZNode, b: _ZNode) -> int:
    return int(a.type != b.type) + int(a.slot != b.slot)


def zss_distance_arrays(a: TreeArrays, b: TreeArrays) -> float:
    """Reference tree edit distance of two non-empty pre-order trees, computed by ``zss``."""
    if len(a) == 0 or len(b) == 0:
        raise ValueError("trees must have at least one node")
    return float(zss.distance(
        _to_znodes(a), _to_znodes(b), get_children=_get_children, insert_cost=_insert_cost,
        remove_cost=_remove_cost, update_cost=_update_cost,
    ))


def tree_edit_distance_zss(a: Robot, b: Robot) -> float:
    """Tree edit distance between two robot bodies by the pure-Python ``zss`` reference."""
    return zss_distance_arrays(tree_arrays(a), tree_arrays(b))


# -- fast path: compiled Zhang-Shasha -----------------------------------------------------------

def tree_edit_distance(a: Robot, b: Robot) -> int:
    """Tree edit distance between two robot bodies (compiled, exact; equals the zss reference)."""
    ta, tb = tree_arrays(a), tree_arrays(b)
    return int(_treedit.distance(ta.types, ta.slots, ta.parents, tb.types, tb.slots, tb.parents))


def pairwise_distances(robots: Sequence[Robot]) -> NDArray[np.int32]:
    """Symmetric ``(n, n)`` matrix of tree edit distances between the robots' bodies."""
    trees = [tree_arrays(r) for r in robots]
    offsets = np.zeros(len(trees) + 1, dtype=np.int32)
    offsets[1:] = np.cumsum([len(t) for t in trees])
    def cat(parts: list[NDArray[np.int32]]) -> NDArray[np.int32]:
        return _i32(np.concatenate(parts) if parts else [])

    return np.asarray(_treedit.pairwise(
        cat([t.types for t in trees]), cat([t.slots for t in trees]),
        cat([t.parents for t in trees]), offsets,
    ))


def diversity(robots: Sequence[Robot]) -> float:
    """Mean pairwise tree edit distance of a population (0 for fewer than two robots)."""
    n = len(robots)
    if n < 2:
        return 0.0
    d = pairwise_distances(robots)
    return float(d[np.triu_indices(n, k=1)].mean())


# -- brain-aware distance -----------------------------------------------------------------------

BRAIN_WEIGHT = 1.0
"""Default weight of the neural distance in :func:`brain_aware_distance` (edits per unit)."""

_NeuronKey = tuple[tuple[int, ...], str, str, int]
_Weights = dict[tuple[_NeuronKey, _NeuronKey], float]


def _brain(robot: Robot) -> tuple[dict[_NeuronKey, tuple[float, ...]], _Weights]:
    """A brain's neurons with their parameters, and its connections' weights.

    Neurons are keyed by (part path, layer, activation, rank on the part) and carry (bias, gain,
    period, phase offset, amplitude); connections are keyed by their neurons' keys.
    """
    keys: dict[str, _NeuronKey] = {}
    neurons: dict[_NeuronKey, tuple[float, ...]] = {}
    for path, node in robot.walk():
        seen: dict[tuple[str, str], int] = {}
        for neuron in node.neurons:
            kind = (neuron.layer.value, neuron.activation.value)
            rank = seen.get(kind, 0)
            seen[kind] = rank + 1
            keys[neuron.id] = (path, kind[0], kind[1], rank)
            neurons[keys[neuron.id]] = (neuron.bias, neuron.gain, neuron.period,
                                        neuron.phase_offset, neuron.amplitude)
    weights: _Weights = {}
    for c in robot.connections:
        key = (keys[c.src], keys[c.dst])
        weights[key] = weights.get(key, 0.0) + c.weight
    return neurons, weights


def neural_distance(a: Robot, b: Robot) -> float:
    """Distance between two brains over parts matched by slot path (see the module docstring).

    Returns:
        Neurons present in one brain only, plus the summed absolute differences of the
        parameters of matched neurons (bias, gain, period in seconds, phase offset, amplitude:
        a neuron's unused parameters keep their defaults), plus the summed absolute weight
        differences of the connections (a missing connection has weight 0). Non-negative,
        symmetric, 0 for equal brains on equal bodies.
    """
    neurons_a, weights_a = _brain(a)
    neurons_b, weights_b = _brain(b)
    unmatched = len(neurons_a.keys() ^ neurons_b.keys())
    params = sum(abs(p - q) for k in sorted(neurons_a.keys() & neurons_b.keys())
                 for p, q in zip(neurons_a[k], neurons_b[k], strict=True))
    keys = sorted(weights_a.keys() | weights_b.keys())
    delta = sum(abs(weights_a.get(k, 0.0) - weights_b.get(k, 0.0)) for k in keys)
    return float(unmatched + params + delta)


def _check_weight(weight: float) -> None:
    if not (weight >= 0.0 and np.isfinite(weight)):
        raise ValueError(f"brain weight must be finite and >= 0, got {weight}")


def brain_aware_distance(a: Robot, b: Robot, weight: float = BRAIN_WEIGHT) -> float:
    """Body tree edit distance plus ``weight`` times :func:`neural_distance`. Edits.

    Raises:
        ValueError: a negative or non-finite ``weight``.
    """
    _check_weight(weight)
    body = float(tree_edit_distance(a, b))
    return body + weight * neural_distance(a, b) if weight > 0.0 else body


def brain_aware_diversity(robots: Sequence[Robot], weight: float = BRAIN_WEIGHT) -> float:
    """Mean pairwise :func:`brain_aware_distance` of a population (0 for fewer than two).

    Raises:
        ValueError: a negative or non-finite ``weight``.
    """
    _check_weight(weight)
    n = len(robots)
    if n < 2:
        return 0.0
    body = pairwise_distances(robots)
    total = 0.0
    for i in range(n):
        for j in range(i + 1, n):
            total += float(body[i, j]) + weight * neural_distance(robots[i], robots[j])
    return total / (n * (n - 1) / 2)
