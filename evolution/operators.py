"""The reproduction operators of the Revolve paper (Sect. 5.2), as pure functions.

:func:`reproduce` makes a child ``c`` of parents ``a`` and ``b`` by applying, in the paper's order:

1. :func:`crossover` (always; if no subtree of ``b`` fits, no child is made);
2. :func:`remove_subtree` with ``p_remove_subtree``;
3. :func:`duplicate_subtree` with ``p_duplicate_subtree``;
4. :func:`swap_subtrees` with ``p_swap_subtree``;
5. :func:`mutate_brain_structure`: hidden neurons and connections removed with their
   probabilities, then new ones added so that the brain's size does not drift;
6. :func:`mutate_parameters`: part parameters, neuron parameters and weights;
7. :func:`add_part` with the probability that keeps the expected body size constant
   (see ``EvolutionConfig.balance_by_removal`` for the case where that probability would be
   negative, which :func:`remove_leaf` handles).

Each operator takes the robot, a ``numpy.random.Generator`` and the configuration, applies itself
unconditionally (the probabilities are drawn by :func:`reproduce` and :func:`mutate`), and returns
an :class:`OperatorOutcome` that says whether it changed anything and why not. A choice whose result
would not be physically constructible is undone and another random choice is tried, up to
``config.operator_attempts``; the robot is never left invalid.

Neurons follow the body: a copied subtree carries its neurons under fresh ids and the connections
internal to it; a removed subtree takes its neurons and every connection touching them along.
Colours are inherited from the part that was copied (new parts take their parent's colour), so a
picture of a child shows which parts came from which parent.

The neural operators (steps 5 and 6) live in :mod:`evolution.brain_mutation` and the result types
in :mod:`evolution.operator_base`; this module re-exports both.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from evolution.brain_mutation import mutate_brain_structure, mutate_parameters
from evolution.config import EvolutionConfig
from evolution.operator_base import OperatorOutcome, OperatorRecord, ReproductionResult, pick
from evolution.random_robot import (
    IdAllocator,
    add_neurons,
    allowed_types,
    constructible_assembly,
    free_slots,
    random_connections,
    random_neuron,
    random_part,
    robot_counts,
    subtree_counts,
)
from revolve_env.body.geometry import Assembly
from revolve_env.body.robot import (
    Connection,
    Layer,
    Node,
    Path,
    Robot,
)
from revolve_env.body.validate import check, validate

__all__ = [
    "OperatorOutcome",
    "OperatorRecord",
    "ReproductionResult",
    "add_part",
    "crossover",
    "duplicate_subtree",
    "expected_duplicated_parts",
    "expected_removed_parts",
    "mutate",
    "mutate_brain_structure",
    "mutate_parameters",
    "remove_leaf",
    "remove_subtree",
    "reproduce",
    "swap_subtrees",
]

# -- tree helpers -------------------------------------------------------------------------------

def _fmt(path: Path) -> str:
    return "core" if not path else "core/" + "/".join(str(s) for s in path)


def _non_root_paths(robot: Robot) -> list[Path]:
    return [p for p, _ in robot.walk() if p]


def _is_prefix(a: Path, b: Path) -> bool:
    return len(a) <= len(b) and b[: len(a)] == a


def _neuron_ids(node: Node) -> list[str]:
    return [nr.id for _, n in node.walk() for nr in n.neurons]


def _copy_subtree(node: Node, ids: IdAllocator) -> tuple[Node, dict[str, str]]:
    """A copy of ``node``'s subtree with every neuron renamed to a fresh id, and the renaming."""
    mapping: dict[str, str] = {}

    def copy(n: Node) -> Node:
        neurons = []
        for nr in n.neurons:
            mapping[nr.id] = ids.fresh()
            neurons.append(replace(nr, id=mapping[nr.id]))
        children = tuple((s, copy(c)) for s, c in n.children)
        return replace(n, neurons=tuple(neurons), children=children)

    return copy(node), mapping


def _carried_connections(
    connections: tuple[Connection, ...], mapping: dict[str, str]
) -> list[Connection]:
    """Connections with both ends in a copied subtree, renamed to the copy's ids."""
    return [
        Connection(mapping[c.src], mapping[c.dst], c.weight)
        for c in connections
        if c.src in mapping and c.dst in mapping
    ]


def _check_parent(robot: Robot, config: EvolutionConfig) -> None:
    validate(robot, config.limits)


# -- crossover ----------------------------------------------------------------------------------

def crossover(
    a: Robot, b: Robot, rng: np.random.Generator, config: EvolutionConfig
) -> OperatorOutcome:
    """Replace a random non-root subtree of a copy of ``a`` by a random subtree of ``b`` that fits.

    The crossover point ``a_c`` is drawn once. The subtrees of ``b`` (non-root nodes) are tried in
    random order; the first whose insertion keeps every limit (parts between ``min_parts`` and
    ``max_parts``, inputs, outputs, hidden neurons) and leaves the robot constructible is used.
    The inserted subtree keeps its colours, orientations and parameters; its neurons get fresh ids
    and the connections internal to it in ``b`` come with it. Connections of ``a`` to the removed
    subtree are dropped.

    Returns:
        An outcome whose ``robot`` is None (with the reason in ``detail``) if nothing fits.

    Raises:
        RobotError: if a parent is invalid under ``config.limits``.
    """
    _check_parent(a, config)
    _check_parent(b, config)
    a_paths = _non_root_paths(a)
    if not a_paths:
        return OperatorOutcome(None, False, "parent a is a lone core: no crossover point")
    b_paths = _non_root_paths(b)
    if not b_paths:
        return OperatorOutcome(None, False, "parent b is a lone core: no subtree to insert")
    a_c = pick(rng, a_paths)
    removed = a.node(a_c)
    base = robot_counts(a) - subtree_counts(removed)
    gone = set(_neuron_ids(removed))
    kept = [c for c in a.connections if c.src not in gone and c.dst not in gone]
    a_ids = [nr.id for nr in a.neurons()]
    limits = config.limits
    n_limit = n_overlap = 0
    for i in rng.permutation(len(b_paths)):
        b_c = b_paths[int(i)]
        sub = b.node(b_c)
        if not (base + subtree_counts(sub)).within(config):
            n_limit += 1
            continue
        inserted, mapping = _copy_subtree(sub, IdAllocator(a_ids))
        child = a.replace_node(a_c, inserted)
        child = replace(child, connections=(*kept, *_carried_connections(b.connections, mapping)),
                        name="")
        assembly = constructible_assembly(child, limits)
        if assembly is not None:
            return OperatorOutcome(
                child, True,
                f"a's subtree at {_fmt(a_c)} ({removed.size()} parts) replaced by b's subtree at "
                f"{_fmt(b_c)} ({sub.size()} parts)", (a_c, b_c), assembly,
            )
        n_overlap += 1
    return OperatorOutcome(
        None, False,
        f"no subtree of b fits at {_fmt(a_c)} of a: {n_limit} of {len(b_paths)} would break a "
        f"limit, {n_overlap} would overlap",
    )


# -- body operators -----------------------------------------------------------------------------

def _removal_candidates(robot: Robot, config: EvolutionConfig) -> list[tuple[Path, int]]:
    n = robot.num_parts()
    out = []
    for p in _non_root_paths(robot):
        size = robot.node(p).size()
        if size <= n - config.min_parts:
            out.append((p, size))
    return out


def expected_removed_parts(robot: Robot, config: EvolutionConfig) -> float:
    """Expected parts removed by the subtree-removal step on ``robot`` (probability included)."""
    cands = _removal_candidates(robot, config)
    if not cands:
        return 0.0
    return config.p_remove_subtree * sum(s for _, s in cands) / len(cands)


def remove_subtree(
    robot: Robot, rng: np.random.Generator, config: EvolutionConfig
) -> OperatorOutcome:
    """Remove a random non-root subtree, chosen among those that leave at least ``min_parts``.

    Its neurons and every connection touching them go with it.
    """
    cands = _removal_candidates(robot, config)
    if not cands:
        return OperatorOutcome(robot, False, f"no subtree can go without leaving fewer than "
                                             f"{config.min_parts} parts")
    path, size = pick(rng, cands)
    child = robot.replace_node(path, None).prune_connections()
    return OperatorOutcome(child, True, f"removed the subtree at {_fmt(path)} ({size} parts)",
                           (path,))


def _duplication_candidates(robot: Robot, config: EvolutionConfig) -> list[tuple[Path, int]]:
    counts = robot_counts(robot)
    out = []
    for p in _non_root_paths(robot):
        sub = subtree_counts(robot.node(p))
        added = counts + sub
        if added.within(config):
            out.append((p, sub.parts))
    return out


def expected_duplicated_parts(robot: Robot, config: EvolutionConfig) -> float:
    """Expected parts added by the subtree-duplication step on ``robot`` (probability included).

    Counts the subtrees that fit the limits when a free slot exists; a placement that would
    overlap is not foreseen (it is retried, see ``operator_attempts``).
    """
    cands = _duplication_candidates(robot, config)
    if not cands or not free_slots(robot):
        return 0.0
    return config.p_duplicate_subtree * sum(s for _, s in cands) / len(cands)


def duplicate_subtree(
    robot: Robot, rng: np.random.Generator, config: EvolutionConfig
) -> OperatorOutcome:
    """Copy a random subtree that fits the limits onto a random free slot.

    The copy gets fresh neuron ids and the connections internal to the original. Up to
    ``operator_attempts`` (subtree, slot) pairs are tried until the result is constructible.
    """
    cands = _duplication_candidates(robot, config)
    if not cands:
        return OperatorOutcome(robot, False, "no subtree can be copied within the limits")
    slots = free_slots(robot)
    if not slots:
        return OperatorOutcome(robot, False, "no free slot")
    ids = [nr.id for nr in robot.neurons()]
    for _ in range(config.operator_attempts):
        src, size = pick(rng, cands)
        parent, slot = pick(rng, slots)
        copy, mapping = _copy_subtree(robot.node(src), IdAllocator(ids))
        child = robot.replace_node((*parent, slot), copy)
        child = replace(child, connections=(*robot.connections,
                                            *_carried_connections(robot.connections, mapping)))
        assembly = constructible_assembly(child, config.limits)
        if assembly is not None:
            return OperatorOutcome(child, True, f"copied the subtree at {_fmt(src)} ({size} parts) "
                                                f"to slot {slot} of {_fmt(parent)}",
                                   (src, (*parent, slot)), assembly)
    return OperatorOutcome(robot, False, f"every one of {config.operator_attempts} tried copies "
                                         "would overlap")


def swap_subtrees(
    robot: Robot, rng: np.random.Generator, config: EvolutionConfig
) -> OperatorOutcome:
    """Swap two random subtrees of which neither is an ancestor of the other.

    Each subtree keeps its neurons, so connections are unchanged. Up to ``operator_attempts``
    pairs are tried until the result is constructible.
    """
    paths = _non_root_paths(robot)
    for _ in range(config.operator_attempts):
        if not paths:
            break
        s1 = pick(rng, paths)
        unrelated = [p for p in paths if not _is_prefix(p, s1) and not _is_prefix(s1, p)]
        if not unrelated:
            continue
        s2 = pick(rng, unrelated)
        n1, n2 = robot.node(s1), robot.node(s2)
        child = robot.replace_node(s1, n2).replace_node(s2, n1)
        assembly = constructible_assembly(child, config.limits)
        if assembly is not None:
            detail = f"swapped the subtrees at {_fmt(s1)} and {_fmt(s2)}"
            return OperatorOutcome(child, True, detail, (s1, s2), assembly)
    if not any(
        not _is_prefix(p, q) and not _is_prefix(q, p) for p in paths for q in paths
    ):
        return OperatorOutcome(robot, False, "no two subtrees without ancestor relation")
    return OperatorOutcome(
        robot, False, f"no constructible swap in {config.operator_attempts} tries"
    )


def add_part(robot: Robot, rng: np.random.Generator, config: EvolutionConfig) -> OperatorOutcome:
    """Attach a random new part to a random free slot, skipped if no part fits the limits.

    The part gets random orientation, parameters and input/output neurons, hidden neurons at the
    per-part rate of random robots (``initial_hidden_mean / initial_parts_mean``) and random
    connections between its neurons and the rest (``initial_connection_density``); it takes the
    colour of the part it attaches to. Up to ``operator_attempts`` placements are tried.
    """
    counts = robot_counts(robot)
    types = allowed_types(counts, config)
    if not types:
        return OperatorOutcome(robot, False, "no part type fits the limits")
    slots = free_slots(robot)
    if not slots:
        return OperatorOutcome(robot, False, "no free slot")
    taken = [nr.id for nr in robot.neurons()]
    hidden_rate = config.initial_hidden_mean / max(config.initial_parts_mean, 1.0)
    for _ in range(config.operator_attempts):
        parent, slot = pick(rng, slots)
        part_type = pick(rng, types)
        ids = IdAllocator(taken)
        part = random_part(rng, part_type, robot.node(parent).color, ids)
        n_hidden = min(int(rng.poisson(hidden_rate)), config.max_hidden - counts.hidden)
        part = add_neurons(part, [random_neuron(rng, ids.fresh(), Layer.HIDDEN)
                                  for _ in range(n_hidden)])
        child = robot.replace_node((*parent, slot), part)
        new = random_connections(
            rng, child.neurons(), config.initial_connection_density,
            only_touching=frozenset(nr.id for nr in part.neurons), existing=robot.connections,
        )
        child = replace(child, connections=(*robot.connections, *new))
        assembly = constructible_assembly(child, config.limits)
        if assembly is not None:
            return OperatorOutcome(child, True, f"added a {part_type.value} at slot {slot} of "
                                                f"{_fmt(parent)}", ((*parent, slot),), assembly)
    return OperatorOutcome(robot, False, f"every one of {config.operator_attempts} tried parts "
                                         "would overlap")


def remove_leaf(robot: Robot, rng: np.random.Generator, config: EvolutionConfig) -> OperatorOutcome:
    """Remove a random childless non-root part, never going below ``min_parts``."""
    if robot.num_parts() <= config.min_parts:
        return OperatorOutcome(robot, False, f"already at the minimum of {config.min_parts} parts")
    leaves = [p for p, n in robot.walk() if p and not n.children]
    path = pick(rng, leaves)
    child = robot.replace_node(path, None).prune_connections()
    return OperatorOutcome(child, True, f"removed the leaf at {_fmt(path)}", (path,))


# -- whole reproduction -------------------------------------------------------------------------

def _record(records: list[OperatorRecord], name: str, outcome: OperatorOutcome,
            assembled: list[Assembly]) -> Robot:
    """The outcome's robot; its step recorded, and its assembly, if any, kept in ``assembled``."""
    records.append(OperatorRecord(name, outcome.applied, outcome.detail))
    if outcome.assembly is not None:
        assembled.append(outcome.assembly)
    assert outcome.robot is not None
    return outcome.robot


def _mutation_steps(
    robot: Robot, rng: np.random.Generator, config: EvolutionConfig, records: list[OperatorRecord],
    assembled: list[Assembly],
) -> Robot:
    steps = (
        ("remove_subtree", config.p_remove_subtree, remove_subtree),
        ("duplicate_subtree", config.p_duplicate_subtree, duplicate_subtree),
        ("swap_subtrees", config.p_swap_subtree, swap_subtrees),
    )
    expected_removed = expected_duplicated = 0.0
    for name, p, op in steps:
        if name == "remove_subtree":
            expected_removed = expected_removed_parts(robot, config)
        elif name == "duplicate_subtree":
            expected_duplicated = expected_duplicated_parts(robot, config)
        if rng.random() < p:
            robot = _record(records, name, op(robot, rng, config), assembled)
        else:
            records.append(OperatorRecord(name, False, f"not drawn (p={p})"))
    robot = _record(records, "brain_structure", mutate_brain_structure(robot, rng, config),
                    assembled)
    robot = _record(records, "parameters", mutate_parameters(robot, rng, config), assembled)

    # Keep the expected body size constant: the paper adds a part with an expected count equal to
    # the expected parts removed minus those added by duplication. The count is spread over
    # ceil(2 * |delta|) Bernoulli trials so that a delta above 1 can still be matched.
    delta = expected_removed - expected_duplicated
    if delta > 0:
        name, op = "add_part", add_part
    elif delta < 0 and config.balance_by_removal:
        name, op = "remove_leaf", remove_leaf
    else:
        records.append(OperatorRecord("add_part", False, f"expected change {delta:+.3f} parts "
                                                         "needs no added part"))
        return robot
    trials = math.ceil(2 * abs(delta))
    p = abs(delta) / trials
    for _ in range(trials):
        if rng.random() < p:
            robot = _record(records, name, op(robot, rng, config), assembled)
        else:
            records.append(OperatorRecord(name, False, f"not drawn (p={p:.3f}, to balance an "
                                                       f"expected {-delta:+.3f} parts)"))
    return robot


def _finish(
    child: Robot, records: list[OperatorRecord], config: EvolutionConfig,
    assembled: list[Assembly],
) -> ReproductionResult:
    # Every step keeps the child valid; this is the last guard, and a failure here is a bug.
    # The last body an operator assembled is the child's when no later step changed the body
    # (check() tells by identity); the child's record is what its evaluation then finds.
    try:
        check(child, config.limits, assembly=assembled[-1] if assembled else None)
    except ValueError as err:
        raise RuntimeError(f"reproduction produced an invalid child ({err}); steps: "
                           f"{[r.name for r in records if r.applied]}") from err
    return ReproductionResult(child, tuple(records))


def mutate(robot: Robot, rng: np.random.Generator, config: EvolutionConfig) -> ReproductionResult:
    """Apply steps 2-7 of reproduction (everything but crossover) to ``robot``.

    Raises:
        RobotError: if ``robot`` is invalid under ``config.limits``.
    """
    _check_parent(robot, config)
    records: list[OperatorRecord] = []
    assembled: list[Assembly] = []
    child = _mutation_steps(replace(robot, name=""), rng, config, records, assembled)
    return _finish(child, records, config, assembled)


def reproduce(
    a: Robot, b: Robot, rng: np.random.Generator, config: EvolutionConfig
) -> ReproductionResult:
    """Make a child of ``a`` and ``b`` with the paper's operators, in the paper's order.

    Returns:
        The child (valid within ``config.limits``) and the record of each step, or no child with
        ``failure`` naming why (crossover found no subtree of ``b`` that fits).

    Raises:
        RobotError: if a parent is invalid under ``config.limits``.
    """
    records: list[OperatorRecord] = []
    cx = crossover(a, b, rng, config)
    records.append(OperatorRecord("crossover", cx.applied, cx.detail))
    if cx.robot is None:
        return ReproductionResult(None, tuple(records), f"crossover failed: {cx.detail}")
    assembled = [] if cx.assembly is None else [cx.assembly]
    child = _mutation_steps(cx.robot, rng, config, records, assembled)
    return _finish(child, records, config, assembled)
