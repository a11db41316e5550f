"""Genetic diversity: tree edit distance between robot bodies with the Revolve paper's costs.

Costs: inserting or removing a node 1; changing a node's part type 1; attaching it to a different
slot of its parent 1 (a relabel that changes both costs 2, the same as removing and inserting).
Orientations, parameters, colours and all neural differences are ignored. Children are ordered by
slot (the order of :meth:`Robot.walk`), so this is the ordered tree edit distance.

:func:`tree_edit_distance_zss` is the reference (``zss``, pure Python, with every cost function
passed explicitly: zss's default label distance depends on whether ``editdist`` is installed).
:func:`tree_edit_distance`, :func:`pairwise_distances` and :func:`diversity` use the exact
compiled Zhang-Shasha of ``evolution._treedit``; tests check both agree on random trees.
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
    "TreeArrays",
    "diversity",
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
