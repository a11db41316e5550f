"""Reproduction operators: validity, determinism, and each operator on hand-built trees."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evolution.config import EvolutionConfig
from evolution.operators import (
    add_part,
    crossover,
    duplicate_subtree,
    mutate,
    mutate_brain_structure,
    mutate_parameters,
    remove_leaf,
    remove_subtree,
    reproduce,
    swap_subtrees,
)
from evolution.random_robot import random_robot, robot_counts
from revolve_env.body.parts import PART_SPECS
from revolve_env.body.robot import (
    Activation,
    Connection,
    Layer,
    Neuron,
    Node,
    PartType,
    Robot,
)
from revolve_env.body.serialize import from_json, to_json
from revolve_env.body.validate import RobotError, validate

CONFIG = EvolutionConfig()
SEEDS = st.integers(0, 2**32 - 1)
RED, BLUE, GREEN = (1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, 1.0, 0.0)


# -- hand-built robots --------------------------------------------------------------------------

def _inputs(prefix: str, n: int) -> tuple[Neuron, ...]:
    return tuple(Neuron(f"{prefix}{i}", Layer.INPUT, Activation.INPUT) for i in range(n))


def core(children: dict[int, Node] | None = None, hidden: int = 0) -> Node:
    neurons = _inputs("imu", 6) + tuple(
        Neuron(f"ch{i}", Layer.HIDDEN, Activation.LINEAR) for i in range(hidden))
    return Node(PartType.CORE, neurons=neurons, children=tuple(sorted((children or {}).items())))


def part(t: PartType, tag: str, children: dict[int, Node] | None = None,
         color: tuple[float, float, float] = RED, hidden: int = 0) -> Node:
    spec = PART_SPECS[t]
    neurons = _inputs(f"{tag}_in", spec.n_inputs)
    neurons += tuple(Neuron(f"{tag}_out{i}", Layer.OUTPUT, Activation.OSCILLATOR)
                     for i in range(spec.n_outputs))
    neurons += tuple(Neuron(f"{tag}_h{i}", Layer.HIDDEN, Activation.SIGMOID) for i in range(hidden))
    return Node(t, params=spec.default_params(), color=color, neurons=neurons,
                children=tuple(sorted((children or {}).items())))


def brick(tag: str, children: dict[int, Node] | None = None, **kw: object) -> Node:
    return part(PartType.BRICK, tag, children, **kw)  # type: ignore[arg-type]


def chain(n: int) -> Robot:
    """core -> brick -> brick ...: every pair of non-root parts is ancestor and descendant."""
    node: Node | None = None
    for i in reversed(range(n)):
        node = brick(f"b{i}", {1: node} if node is not None else None)
    assert node is not None
    return Robot(core({0: node}))


def two_legs() -> Robot:
    """A red brick at core slot 0 and a blue brick carrying a green bar at core slot 2."""
    bar = part(PartType.PARAMETRIC_BAR, "bar", color=GREEN)
    return Robot(core({0: brick("red"), 2: brick("blue", {1: bar}, color=BLUE)}))


# -- properties over random parents -------------------------------------------------------------

def _check_child(child: Robot, config: EvolutionConfig = CONFIG) -> None:
    validate(child, config.limits)
    c = robot_counts(child)
    assert config.min_parts <= c.parts <= config.max_parts
    assert from_json(to_json(child), config.limits) == child


@settings(max_examples=30, deadline=None)
@given(SEEDS)
def test_every_child_is_valid_within_limits_and_survives_json(seed: int) -> None:
    rng = np.random.default_rng(seed)
    a, b = random_robot(rng, CONFIG), random_robot(rng, CONFIG)
    result = reproduce(a, b, rng, CONFIG)
    assert result.records[0].name == "crossover"
    if result.child is None:
        assert result.failure and not result.records[0].applied
        return
    _check_child(result.child)
    # Every child's parts come from a or b (colours) or are new parts with a parent's colour.
    colours = {n.color for _, n in a.walk()} | {n.color for _, n in b.walk()}
    assert {n.color for _, n in result.child.walk()} <= colours


@settings(max_examples=15, deadline=None)
@given(SEEDS)
def test_every_single_operator_keeps_robots_valid(seed: int) -> None:
    rng = np.random.default_rng(seed)
    robot = random_robot(rng, CONFIG)
    for op in (remove_subtree, duplicate_subtree, swap_subtrees, mutate_brain_structure,
               mutate_parameters, add_part, remove_leaf):
        out = op(robot, rng, CONFIG)
        assert out.robot is not None
        if not out.applied:
            assert out.robot == robot or op is mutate_brain_structure
        _check_child(out.robot)
        robot = out.robot


@settings(max_examples=8, deadline=None)
@given(SEEDS)
def test_same_seed_same_child(seed: int) -> None:
    parents = random_robot(np.random.default_rng(seed), CONFIG), random_robot(
        np.random.default_rng(seed + 1), CONFIG)
    r1 = reproduce(*parents, np.random.default_rng(seed), CONFIG)
    r2 = reproduce(*parents, np.random.default_rng(seed), CONFIG)
    assert r1 == r2


def test_parents_from_other_sources_keep_neuron_ids_unique() -> None:
    # Hand-named neuron ids (no common scheme) still give unique fresh ids.
    rng = np.random.default_rng(5)
    config = EvolutionConfig(p_duplicate_subtree=1.0)
    for _ in range(10):
        result = reproduce(two_legs(), chain(4), rng, config)
        assert result.child is not None
        ids = [nr.id for nr in result.child.neurons()]
        assert len(ids) == len(set(ids))
        _check_child(result.child, config)


def test_invalid_parent_raises() -> None:
    broken = Robot(core({0: Node(PartType.ACTIVE_HINGE)}))  # hinge without its output neuron
    rng = np.random.default_rng(0)
    with pytest.raises(RobotError, match="output"):
        reproduce(broken, two_legs(), rng, CONFIG)
    with pytest.raises(RobotError):
        reproduce(two_legs(), broken, rng, CONFIG)
    with pytest.raises(RobotError):
        mutate(broken, rng, CONFIG)
    too_big = chain(5)
    with pytest.raises(RobotError, match="parts"):
        mutate(too_big, rng, EvolutionConfig(max_parts=4))


# -- crossover ----------------------------------------------------------------------------------

def test_crossover_fails_cleanly_when_no_subtree_fits() -> None:
    config = EvolutionConfig(max_hidden=1)
    a = Robot(core({0: brick("x", {1: brick("y")})}, hidden=1))  # its hidden neuron is on the core
    b = Robot(core({0: brick("z", hidden=1)}))  # b's only subtree carries a hidden neuron
    for seed in range(5):
        out = crossover(a, b, np.random.default_rng(seed), config)
        assert out.robot is None and not out.applied
        assert "1 of 1 would break a limit" in out.detail
        result = reproduce(a, b, np.random.default_rng(seed), config)
        assert result.child is None and "crossover" in (result.failure or "")


def test_crossover_of_a_lone_core_fails_with_a_reason() -> None:
    out = crossover(Robot(core()), two_legs(), np.random.default_rng(0), CONFIG)
    assert out.robot is None and "lone core" in out.detail


def test_crossover_inserts_a_subtree_of_b_with_its_internal_connections() -> None:
    hinge = part(PartType.ACTIVE_HINGE, "hg", color=BLUE, hidden=1)
    b = Robot(core({1: hinge}), connections=(
        Connection("hg_h0", "hg_out0", 0.5),  # internal to the hinge: travels with it
        Connection("imu0", "hg_out0", 1.0),  # from b's core: dropped
    ))
    a = Robot(core({0: brick("red")}, hidden=1), connections=(Connection("imu1", "ch0", 0.3),))
    out = crossover(a, b, np.random.default_rng(0), EvolutionConfig(min_parts=2))
    assert out.robot is not None and out.paths == ((0,), (1,))
    child = out.robot
    new = child.node((0,))
    assert new.type == PartType.ACTIVE_HINGE and new.color == BLUE
    renamed = {nr.layer: nr.id for nr in new.neurons}
    assert set(renamed.values()).isdisjoint(nr.id for nr in b.neurons())
    assert Connection(renamed[Layer.HIDDEN], renamed[Layer.OUTPUT], 0.5) in child.connections
    assert Connection("imu1", "ch0", 0.3) in child.connections  # a's own connection kept
    assert len(child.connections) == 2


# -- subtree removal ----------------------------------------------------------------------------

def test_remove_never_goes_below_min_parts() -> None:
    config = EvolutionConfig(min_parts=3)
    robot = chain(3)  # 4 parts: only the last brick may go
    for seed in range(20):
        out = remove_subtree(robot, np.random.default_rng(seed), config)
        assert out.applied and out.robot is not None
        assert out.robot.num_parts() == 3 and out.paths == ((0, 1, 1),)
    at_min = chain(2)
    out = remove_subtree(at_min, np.random.default_rng(0), config)
    assert not out.applied and out.robot == at_min
    assert not remove_leaf(at_min, np.random.default_rng(0), config).applied


def test_removed_subtree_takes_its_neurons_and_connections() -> None:
    robot = Robot(core({0: brick("a", hidden=1), 2: brick("b", hidden=1)}), connections=(
        Connection("a_h0", "b_h0", 1.0), Connection("imu0", "a_h0", 1.0),
        Connection("imu0", "b_h0", 1.0)))
    out = remove_subtree(robot, np.random.default_rng(1), EvolutionConfig(min_parts=1))
    assert out.robot is not None
    gone = out.paths[0]
    survivor = "b_h0" if gone == (0,) else "a_h0"
    assert [nr.id for nr in out.robot.neurons_of(Layer.HIDDEN)] == [survivor]
    assert out.robot.connections == (Connection("imu0", survivor, 1.0),)


# -- duplication --------------------------------------------------------------------------------

def test_duplicate_copies_internal_connections_under_fresh_ids() -> None:
    hinge = part(PartType.ACTIVE_HINGE, "hg", hidden=1)
    robot = Robot(core({0: hinge}), connections=(
        Connection("hg_h0", "hg_out0", 0.5), Connection("imu0", "hg_out0", 1.0)))
    for seed in range(10):
        out = duplicate_subtree(robot, np.random.default_rng(seed), CONFIG)
        assert out.applied and out.robot is not None
        src, dst = out.paths
        assert src == (0,)
        copy = out.robot.node(dst)
        ids = {nr.layer: nr.id for nr in copy.neurons}
        assert all(i.startswith("n") for i in ids.values())
        assert Connection(ids[Layer.HIDDEN], ids[Layer.OUTPUT], 0.5) in out.robot.connections
        assert len(out.robot.connections) == 3  # the external imu0 connection is not copied
        validate(out.robot, CONFIG.limits)


def test_duplicate_respects_limits() -> None:
    # At max parts nothing may be copied; one below only single parts may be.
    robot = chain(3)
    assert not duplicate_subtree(
        robot, np.random.default_rng(0), EvolutionConfig(max_parts=4)).applied
    config = EvolutionConfig(max_parts=5)
    for seed in range(10):
        out = duplicate_subtree(robot, np.random.default_rng(seed), config)
        assert out.applied and out.robot is not None and out.robot.num_parts() == 5
        assert out.paths[0] == (0, 1, 1)
    # Outputs: a second hinge would exceed max_outputs=1.
    hinge_robot = Robot(core({0: part(PartType.ACTIVE_HINGE, "hg")}))
    out = duplicate_subtree(hinge_robot, np.random.default_rng(0), EvolutionConfig(max_outputs=1))
    assert not out.applied and "limits" in out.detail


# -- swap -----------------------------------------------------------------------------------------

def test_swap_never_swaps_ancestor_and_descendant() -> None:
    robot = chain(4)
    out = swap_subtrees(robot, np.random.default_rng(0), CONFIG)
    assert not out.applied and out.robot == robot and "ancestor" in out.detail


@settings(max_examples=20, deadline=None)
@given(SEEDS)
def test_swapped_subtrees_are_unrelated_and_exchanged(seed: int) -> None:
    rng = np.random.default_rng(seed)
    robot = random_robot(rng, CONFIG)
    out = swap_subtrees(robot, rng, CONFIG)
    if not out.applied:
        return
    s1, s2 = out.paths
    assert s1[: len(s2)] != s2 and s2[: len(s1)] != s1
    assert out.robot is not None
    assert out.robot.node(s1) == robot.node(s2) and out.robot.node(s2) == robot.node(s1)
    assert out.robot.connections == robot.connections


def test_swap_exchanges_the_two_legs() -> None:
    robot = two_legs()
    seen = set()
    for seed in range(20):
        out = swap_subtrees(robot, np.random.default_rng(seed), CONFIG)
        assert out.applied and out.robot is not None
        seen.add(tuple(sorted(out.paths)))
    # Unrelated pairs: (red, blue) and (red, bar); blue and its bar are never swapped.
    assert seen <= {((0,), (2,)), ((0,), (2, 1))} and seen


# -- brain and parameters -----------------------------------------------------------------------

def test_brain_structure_respects_max_hidden_and_keeps_connections_unique() -> None:
    config = EvolutionConfig(p_remove_hidden_neuron=1.0, p_remove_connection=1.0, max_hidden=2,
                             initial_hidden_mean=10.0)
    rng = np.random.default_rng(0)
    robot = random_robot(rng, CONFIG)
    for _ in range(20):
        out = mutate_brain_structure(robot, rng, config)
        assert out.robot is not None
        assert robot_counts(out.robot).hidden <= 2
        pairs = [(c.src, c.dst) for c in out.robot.connections]
        assert len(pairs) == len(set(pairs))
        validate(out.robot, config.limits)
        # Everything that existed was removed (p = 1): survivors are new.
        old = {nr.id for nr in robot.neurons_of(Layer.HIDDEN)}
        assert old.isdisjoint(nr.id for nr in out.robot.neurons_of(Layer.HIDDEN))
        robot = out.robot


def test_parameter_mutation_changes_values_within_bounds() -> None:
    bar = part(PartType.PARAMETRIC_BAR, "bar")
    hinge = Node(PartType.ACTIVE_HINGE, neurons=(
        Neuron("o", Layer.OUTPUT, Activation.SIGMOID, bias=1.9, gain=0.1),))
    robot = Robot(core({0: bar, 2: hinge}), connections=(Connection("imu0", "o", 1.9),))
    config = EvolutionConfig(mutation_sigma=1.0)
    rng = np.random.default_rng(0)
    changed = 0
    for _ in range(10):
        out = mutate_parameters(robot, rng, config)
        assert out.robot is not None
        validate(out.robot, config.limits)  # clipped into every bound
        changed += out.robot.node((0,)).params != bar.params
        assert out.robot.neurons_of(Layer.OUTPUT)[0] != hinge.neurons[0]
        assert out.robot.connections[0].weight != 1.9
    assert changed > 0
    assert not mutate_parameters(robot, rng, EvolutionConfig(mutation_sigma=0.0)).applied


def test_add_part_attaches_a_new_part_with_its_parents_colour() -> None:
    robot = two_legs()
    for seed in range(10):
        out = add_part(robot, np.random.default_rng(seed), CONFIG)
        assert out.applied and out.robot is not None
        (path,) = out.paths
        assert out.robot.num_parts() == robot.num_parts() + 1
        assert out.robot.node(path).color == robot.node(path[:-1]).color
        validate(out.robot, CONFIG.limits)
    full = chain(3)
    assert not add_part(full, np.random.default_rng(0), EvolutionConfig(max_parts=4)).applied


# -- body size over many generations ------------------------------------------------------------

def _size_drift(generations: int, n_robots: int, seed: int) -> tuple[float, float, float]:
    rng = np.random.default_rng(seed)
    pop = [random_robot(rng, CONFIG) for _ in range(n_robots)]
    start = float(np.mean([r.num_parts() for r in pop]))
    hidden0 = float(np.mean([robot_counts(r).hidden for r in pop]))
    means = []
    for _ in range(generations):
        pop = [mutate(r, rng, CONFIG).child for r in pop]  # type: ignore[misc]
        means.append(np.mean([r.num_parts() for r in pop]))
    hidden = float(np.mean([robot_counts(r).hidden for r in pop]))
    return start, float(np.mean(means[generations // 2:])), hidden - hidden0


def test_body_size_stays_roughly_constant_under_mutation_short() -> None:
    start, late, _ = _size_drift(generations=40, n_robots=6, seed=1)
    # Without the balancing removal duplication alone would add ~0.1 parts per generation.
    assert abs(late - start) < 4.0


@pytest.mark.slow
def test_body_size_stays_roughly_constant_over_1000_generations() -> None:
    start, late, hidden_change = _size_drift(generations=1000, n_robots=12, seed=2)
    assert abs(late - start) < 3.0
    assert abs(hidden_change) < 2.0


def test_children_build_and_step_in_the_simulator() -> None:
    from revolve_env.world import World  # the evolution package itself never imports pybullet

    rng = np.random.default_rng(11)
    parents = [random_robot(rng, CONFIG) for _ in range(4)]
    children = [c for c in (reproduce(parents[i], parents[(i + 1) % 4], rng, CONFIG).child
                            for i in range(4)) if c is not None]
    assert children
    with World() as world:
        for k, child in enumerate(children):
            h = world.add_robot(child, position=(1.5 * k, 0.0))
            assert world.n_inputs(h) == len(child.neurons_of(Layer.INPUT))
            assert world.n_outputs(h) == len(child.neurons_of(Layer.OUTPUT))
        world.step(20)
        assert all(world.blow_up(h) is None for h in world.handles)
