"""The neural reproduction operators: brain structure and parameter mutation, as pure functions.

:func:`mutate_brain_structure` and :func:`mutate_parameters` are steps 5 and 6 of
:func:`evolution.operators.reproduce` (which re-exports them; see that module for the whole
reproduction). :func:`mutate_parameters` perturbs the parts' continuous parameters too, together
with the neurons' and the weights.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import replace

import numpy as np

from evolution.config import EvolutionConfig
from evolution.operator_base import OperatorOutcome, pick
from evolution.random_robot import IdAllocator, add_neurons, constructible_assembly, random_neuron
from revolve_env.body.parts import PART_SPECS
from revolve_env.body.robot import (
    ACTIVATION_PARAMS,
    NEURON_PARAM_BOUNDS,
    WEIGHT_BOUNDS,
    Connection,
    Layer,
    Neuron,
    Node,
    Robot,
)

__all__ = ["mutate_brain_structure", "mutate_parameters"]


def _map_nodes(node: Node, fn: Callable[[Node], Node]) -> Node:
    children = tuple((s, _map_nodes(c, fn)) for s, c in node.children)
    return fn(replace(node, children=children))


def mutate_brain_structure(
    robot: Robot, rng: np.random.Generator, config: EvolutionConfig
) -> OperatorOutcome:
    """Remove hidden neurons and connections at random, then add new ones so size does not drift.

    Each hidden neuron goes with ``p_remove_hidden_neuron`` (taking its connections along) and each
    connection with ``p_remove_connection``. Then ``Poisson(p_remove_hidden_neuron *
    initial_hidden_mean)`` hidden neurons are added on random parts (capped by ``max_hidden``) and
    ``Poisson(p_remove_connection * initial_connection_density * pairs)`` connections between
    random unconnected pairs (``pairs``: allowed ``src -> dst`` pairs of this robot).

    So on average as many are added as are removed when the brain has the size of a random
    robot's, and the stationary sizes are those of random robots (for hidden neurons exactly the
    Poisson of :func:`random_robot`). Adding ``Binomial(n_removed_before, p)`` instead would match
    each step's expected removals but makes 0 absorbing: measured, the mean hidden count fell from
    2.6 to 0 and the connections from 20 to 0 within 500 generations of mutation. The body is
    untouched.
    """
    hidden = robot.neurons_of(Layer.HIDDEN)
    drop = {nr.id for nr, r in zip(hidden, rng.random(len(hidden)), strict=True)
            if r < config.p_remove_hidden_neuron}
    conn_keep = rng.random(len(robot.connections)) >= config.p_remove_connection
    body = _map_nodes(robot.body, lambda n: replace(
        n, neurons=tuple(nr for nr in n.neurons if nr.id not in drop)))
    kept = tuple(c for c, k in zip(robot.connections, conn_keep, strict=True) if k)
    child = Robot(body, kept, robot.name).prune_connections()
    n_conn_removed = len(robot.connections) - len(child.connections)

    n_hidden_now = len(hidden) - len(drop)
    n_add = min(int(rng.poisson(config.p_remove_hidden_neuron * config.initial_hidden_mean)),
                config.max_hidden - n_hidden_now)
    ids = IdAllocator(nr.id for nr in robot.neurons())
    paths = [p for p, _ in child.walk()]
    for _ in range(n_add):
        path = pick(rng, paths)
        child = child.replace_node(path, add_neurons(child.node(path), [
            random_neuron(rng, ids.fresh(), Layer.HIDDEN)]))

    neurons = child.neurons()
    targets = [nr for nr in neurons if nr.layer != Layer.INPUT]
    existing = {(c.src, c.dst) for c in child.connections}
    free_pairs = len(neurons) * len(targets) - len(existing)
    n_conn_add = min(int(rng.poisson(config.p_remove_connection * config.initial_connection_density
                                     * len(neurons) * len(targets))), free_pairs)
    new: list[Connection] = []
    for _ in range(n_conn_add):
        for _ in range(config.operator_attempts):
            src, dst = pick(rng, neurons).id, pick(rng, targets).id
            if (src, dst) not in existing:
                existing.add((src, dst))
                new.append(Connection(src, dst, float(rng.uniform(*WEIGHT_BOUNDS))))
                break
    child = replace(child, connections=(*child.connections, *new))
    changed = bool(drop) or n_conn_removed > 0 or n_add > 0 or bool(new)
    return OperatorOutcome(
        child, changed,
        f"hidden neurons -{len(drop)} +{n_add}, connections -{n_conn_removed} +{len(new)}",
    )


def _perturb(
    rng: np.random.Generator, value: float, low: float, high: float, sigma: float
) -> float:
    """``value`` plus Gaussian noise of ``sigma`` times the range, clipped to the range."""
    return float(np.clip(value + rng.normal(0.0, sigma * (high - low)), low, high))


def _with_neuron_params(nr: Neuron, values: Mapping[str, float]) -> Neuron:
    """A copy of ``nr`` with the parameters named in ``values`` replaced (the others kept)."""
    unknown = set(values) - set(NEURON_PARAM_BOUNDS)
    if unknown:
        raise ValueError(f"unknown neuron parameters {sorted(unknown)}")
    return replace(
        nr,
        bias=values.get("bias", nr.bias),
        gain=values.get("gain", nr.gain),
        period=values.get("period", nr.period),
        phase_offset=values.get("phase_offset", nr.phase_offset),
        amplitude=values.get("amplitude", nr.amplitude),
    )


def mutate_parameters(
    robot: Robot, rng: np.random.Generator, config: EvolutionConfig
) -> OperatorOutcome:
    """Perturb every continuous parameter by a Gaussian and clip it to its range.

    The standard deviation is ``mutation_sigma`` times the parameter's range. Part parameters
    (parametric bars) are changed together; if the body would no longer be constructible they
    are all restored and only the neural changes (neuron parameters, weights) are kept.
    """
    sigma = config.mutation_sigma
    if sigma == 0.0:
        return OperatorOutcome(robot, False, "mutation_sigma is 0")

    def neural(n: Node) -> Node:
        neurons = []
        for nr in n.neurons:
            changes = {name: _perturb(rng, getattr(nr, name), *NEURON_PARAM_BOUNDS[name], sigma)
                       for name in ACTIVATION_PARAMS[nr.activation.value]}
            neurons.append(_with_neuron_params(nr, changes) if changes else nr)
        return replace(n, neurons=tuple(neurons))

    def body(n: Node) -> Node:
        spec = PART_SPECS[n.type]
        if not spec.params:
            return n
        # Not strict: validate() checks that a node has its spec's parameters; an unvalidated
        # robot keeps the shorter of the two, as it always has.
        pairs = zip(n.params, spec.params, strict=False)
        params = tuple(_perturb(rng, v, p.low, p.high, sigma) for v, p in pairs)
        return replace(n, params=params)

    with_neural = Robot(_map_nodes(robot.body, neural), tuple(
        replace(c, weight=_perturb(rng, c.weight, *WEIGHT_BOUNDS, sigma)) for c in robot.connections
    ), robot.name)
    with_body = replace(with_neural, body=_map_nodes(with_neural.body, body))
    if with_body.body == with_neural.body:
        return OperatorOutcome(with_body, True, "perturbed part, neuron and weight parameters")
    assembly = constructible_assembly(with_body, config.limits)
    if assembly is not None:
        return OperatorOutcome(with_body, True, "perturbed part, neuron and weight parameters",
                               assembly=assembly)
    return OperatorOutcome(with_neural, True, "perturbed neuron and weight parameters; the part "
                                              "parameter change would overlap and was undone")
