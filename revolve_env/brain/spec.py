"""Flat, validated description of a robot's neural network, and its learnable parameters.

:class:`NetworkSpec` turns the neurons and connections carried by a :class:`~revolve_env.body.Robot`
into flat arrays that both controllers (the compiled one and the NumPy reference) consume.

Neuron order inside a spec (``NetworkSpec.ids``): the input neurons in controller-input order
(``robot.neurons_of(Layer.INPUT)``), then the output neurons in controller-output order
(``robot.neurons_of(Layer.OUTPUT)``), then the hidden neurons in traversal order. Connections keep
the order of ``robot.connections``.

Parameter vector layout (``get_params``, ``set_params``, ``param_names``, ``param_bounds``):
first one weight per connection, in connection order; then, for every non-input neuron in spec
order (outputs, then hidden), the parameters of its activation in ``ACTIVATION_PARAMS`` order
(linear and sigmoid: bias, gain; oscillator: period, phase_offset, amplitude).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Final

import numpy as np
import numpy.typing as npt

from revolve_env.body.robot import (
    ACTIVATION_PARAMS,
    NEURON_PARAM_BOUNDS,
    WEIGHT_BOUNDS,
    Activation,
    Connection,
    Layer,
    Node,
    Robot,
)

__all__ = [
    "KIND_INPUT",
    "KIND_LINEAR",
    "KIND_OSCILLATOR",
    "KIND_SIGMOID",
    "NEURON_PARAM_COLUMNS",
    "NetworkSpec",
    "get_params",
    "param_bounds",
    "param_names",
    "set_params",
]

KIND_INPUT: Final = 0
KIND_LINEAR: Final = 1
KIND_SIGMOID: Final = 2
KIND_OSCILLATOR: Final = 3
_KIND_OF: Final = {
    Activation.INPUT: KIND_INPUT,
    Activation.LINEAR: KIND_LINEAR,
    Activation.SIGMOID: KIND_SIGMOID,
    Activation.OSCILLATOR: KIND_OSCILLATOR,
}
_ACTIVATION_OF: Final = {v: k for k, v in _KIND_OF.items()}

NEURON_PARAM_COLUMNS: Final[tuple[str, ...]] = (
    "bias", "gain", "period", "phase_offset", "amplitude"
)
"""Columns of :attr:`NetworkSpec.neuron_params`."""


def _frozen(a: npt.ArrayLike, dtype: type) -> np.ndarray:
    out: np.ndarray = np.array(a, dtype=dtype)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, slots=True, eq=False)
class NetworkSpec:
    """A robot's network as flat read-only arrays (see the module docstring for the orders).

    Build it with :meth:`from_robot` (or :meth:`from_arrays`); both validate everything a
    controller relies on, so a spec that exists can be stepped safely.

    Attributes:
        ids: Neuron ids in spec order (inputs, outputs, hidden).
        kinds: ``int8`` per neuron: ``KIND_INPUT``, ``KIND_LINEAR``, ``KIND_SIGMOID`` or
            ``KIND_OSCILLATOR``.
        neuron_params: ``(n_neurons, 5)`` float64, columns ``NEURON_PARAM_COLUMNS``: bias, gain
            (dimensionless), period (seconds), phase_offset (fraction of the period), amplitude.
        src: ``int32`` source neuron index of each connection.
        dst: ``int32`` destination neuron index of each connection (never an input neuron).
        weight: float64 weight of each connection.
        n_inputs: Number of input neurons (the first ``n_inputs`` neurons).
        n_outputs: Number of output neurons (the next ``n_outputs`` neurons).
        param_cells: ``int64`` flat indices into ``neuron_params`` of the learnable neuron
            parameters, in parameter-vector order (after the weights).
    """

    ids: tuple[str, ...]
    kinds: np.ndarray
    neuron_params: np.ndarray
    src: np.ndarray
    dst: np.ndarray
    weight: np.ndarray
    n_inputs: int
    n_outputs: int
    param_cells: np.ndarray

    # -- construction --------------------------------------------------------------------------
    @classmethod
    def from_robot(cls, robot: Robot) -> NetworkSpec:
        """The network carried by ``robot``.

        Raises:
            ValueError: duplicate neuron ids, an input neuron whose activation is not ``INPUT``
                (or a non-input neuron whose activation is), a connection naming a missing neuron
                or ending in an input neuron, a non-finite weight or neuron parameter, or a
                non-positive oscillator period.
        """
        inputs = robot.neurons_of(Layer.INPUT)
        outputs = robot.neurons_of(Layer.OUTPUT)
        hidden = robot.neurons_of(Layer.HIDDEN)
        neurons = [*inputs, *outputs, *hidden]
        index: dict[str, int] = {}
        for i, nr in enumerate(neurons):
            if nr.id in index:
                raise ValueError(f"duplicate neuron id {nr.id!r}")
            index[nr.id] = i
        for nr in neurons:
            if (nr.layer == Layer.INPUT) != (nr.activation == Activation.INPUT):
                raise ValueError(
                    f"neuron {nr.id!r}: layer {nr.layer.value} cannot have activation "
                    f"{nr.activation.value} (input neurons, and only they, use 'input')"
                )
        src: list[int] = []
        dst: list[int] = []
        for c in robot.connections:
            for end in (c.src, c.dst):
                if end not in index:
                    raise ValueError(
                        f"connection {c.src!r} -> {c.dst!r} refers to missing neuron {end!r}"
                    )
            src.append(index[c.src])
            dst.append(index[c.dst])
        params = [[getattr(nr, col) for col in NEURON_PARAM_COLUMNS] for nr in neurons]
        return cls.from_arrays(
            ids=[nr.id for nr in neurons],
            kinds=[_KIND_OF[nr.activation] for nr in neurons],
            neuron_params=np.array(params, dtype=np.float64).reshape(len(neurons), 5),
            src=src,
            dst=dst,
            weight=[c.weight for c in robot.connections],
            n_inputs=len(inputs),
            n_outputs=len(outputs),
        )

    @classmethod
    def from_arrays(
        cls,
        *,
        ids: list[str] | tuple[str, ...],
        kinds: npt.ArrayLike,
        neuron_params: npt.ArrayLike,
        src: npt.ArrayLike,
        dst: npt.ArrayLike,
        weight: npt.ArrayLike,
        n_inputs: int,
        n_outputs: int,
    ) -> NetworkSpec:
        """A spec from raw arrays in spec order, validated (see :meth:`from_robot`)."""
        ids_t = tuple(str(i) for i in ids)
        n = len(ids_t)
        if len(set(ids_t)) != n:
            raise ValueError("duplicate neuron ids")
        # Kinds and indices are range-checked as int64, before the narrowing casts, which would
        # wrap out-of-range values (kind 257 -> 1, index 2**32 -> 0) into valid-looking ones.
        kinds_64 = np.asarray(kinds, dtype=np.int64).reshape(-1)
        src_64 = np.asarray(src, dtype=np.int64).reshape(-1)
        dst_64 = np.asarray(dst, dtype=np.int64).reshape(-1)
        weight_a = _frozen(np.asarray(weight, dtype=np.float64).reshape(-1), np.float64)
        params_a = _frozen(neuron_params, np.float64)
        if not (n_inputs >= 0 and n_outputs >= 0 and n_inputs + n_outputs <= n):
            raise ValueError(f"n_inputs={n_inputs}, n_outputs={n_outputs} do not fit {n} neurons")
        if kinds_64.shape != (n,):
            raise ValueError(f"kinds has shape {kinds_64.shape}, expected ({n},)")
        if params_a.shape != (n, 5):
            raise ValueError(f"neuron_params has shape {params_a.shape}, expected ({n}, 5)")
        if not (src_64.shape == dst_64.shape == weight_a.shape):
            raise ValueError("src, dst and weight must have the same length")
        bad_kind = ~np.isin(kinds_64, [KIND_INPUT, KIND_LINEAR, KIND_SIGMOID, KIND_OSCILLATOR])
        if bad_kind.any():
            raise ValueError(f"neuron {ids_t[int(np.argmax(bad_kind))]!r} has an unknown kind")
        for arr, name in ((src_64, "source"), (dst_64, "destination")):
            out = (arr < 0) | (arr >= n)
            if out.any():
                raise ValueError(
                    f"connection {int(np.argmax(out))} has a {name} index out of range"
                )
        kinds_a = _frozen(kinds_64, np.int8)
        src_a = _frozen(src_64, np.int32)
        dst_a = _frozen(dst_64, np.int32)
        is_input = kinds_a == KIND_INPUT
        if not (is_input[:n_inputs].all() and not is_input[n_inputs:].any()):
            raise ValueError("the first n_inputs neurons, and only they, must be input neurons")
        into_input = dst_a < n_inputs
        if into_input.any():
            k = int(np.argmax(into_input))
            raise ValueError(
                f"connection {ids_t[src_a[k]]!r} -> {ids_t[dst_a[k]]!r} ends in an input neuron"
            )
        bad_w = ~np.isfinite(weight_a)
        if bad_w.any():
            k = int(np.argmax(bad_w))
            raise ValueError(
                f"connection {ids_t[src_a[k]]!r} -> {ids_t[dst_a[k]]!r} has weight {weight_a[k]}"
            )
        bad_p = ~np.isfinite(params_a)
        if bad_p.any():
            i, col = (int(v) for v in np.argwhere(bad_p)[0])
            raise ValueError(
                f"neuron {ids_t[i]!r} has {NEURON_PARAM_COLUMNS[col]} = {params_a[i, col]}"
            )
        bad_period = (kinds_a == KIND_OSCILLATOR) & (params_a[:, 2] <= 0.0)
        if bad_period.any():
            i = int(np.argmax(bad_period))
            raise ValueError(
                f"oscillator {ids_t[i]!r} has period {params_a[i, 2]} s; it must be > 0"
            )
        cells: list[int] = []
        for i in range(n_inputs, n):
            for name in ACTIVATION_PARAMS[_ACTIVATION_OF[int(kinds_a[i])].value]:
                cells.append(i * 5 + NEURON_PARAM_COLUMNS.index(name))
        return cls(
            ids_t, kinds_a, params_a, src_a, dst_a, weight_a, int(n_inputs), int(n_outputs),
            _frozen(cells, np.int64),
        )

    # -- sizes ---------------------------------------------------------------------------------
    @property
    def n_neurons(self) -> int:
        """Number of neurons."""
        return len(self.ids)

    @property
    def n_connections(self) -> int:
        """Number of connections."""
        return int(self.weight.shape[0])

    @property
    def n_params(self) -> int:
        """Length of the learnable parameter vector."""
        return self.n_connections + int(self.param_cells.shape[0])

    # -- learnable parameters ------------------------------------------------------------------
    def params(self) -> np.ndarray:
        """The learnable parameters as a new flat float64 vector (layout: module docstring)."""
        return np.concatenate([self.weight, self.neuron_params.reshape(-1)[self.param_cells]])

    def with_params(self, params: npt.ArrayLike) -> NetworkSpec:
        """A copy with the learnable parameters replaced by ``params``.

        Raises:
            ValueError: wrong length, a non-finite value, or a non-positive oscillator period.
        """
        p = np.asarray(params, dtype=np.float64)
        if p.ndim != 1 or p.shape[0] != self.n_params:
            raise ValueError(f"params has shape {p.shape}, expected ({self.n_params},)")
        if not np.isfinite(p).all():
            k = int(np.argmax(~np.isfinite(p)))
            raise ValueError(f"params[{k}] ({self.param_names()[k]}) is {p[k]}")
        m = self.n_connections
        neuron_params = np.array(self.neuron_params)
        neuron_params.reshape(-1)[self.param_cells] = p[m:]
        return NetworkSpec.from_arrays(
            ids=self.ids,
            kinds=self.kinds,
            neuron_params=neuron_params,
            src=self.src,
            dst=self.dst,
            weight=p[:m],
            n_inputs=self.n_inputs,
            n_outputs=self.n_outputs,
        )

    def param_names(self) -> list[str]:
        """One unique name per learnable parameter.

        ``weight:<src>-><dst>`` (``#2``, ``#3``... appended for repeated parallel connections) or
        ``<param>:<neuron id>``.
        """
        names: list[str] = []
        seen: dict[tuple[int, int], int] = {}
        for s, d in zip(self.src.tolist(), self.dst.tolist(), strict=True):
            seen[s, d] = seen.get((s, d), 0) + 1
            repeat = f"#{seen[s, d]}" if seen[s, d] > 1 else ""  # parallel connections
            names.append(f"weight:{self.ids[s]}->{self.ids[d]}{repeat}")
        for cell in self.param_cells:
            i, col = divmod(int(cell), 5)
            names.append(f"{NEURON_PARAM_COLUMNS[col]}:{self.ids[i]}")
        return names

    def param_bounds(self) -> np.ndarray:
        """``(n_params, 2)`` float64 lower/upper bounds, in :meth:`param_names` order.

        The rows come from ``WEIGHT_BOUNDS`` and ``NEURON_PARAM_BOUNDS``.
        """
        rows = [WEIGHT_BOUNDS] * self.n_connections
        rows += [NEURON_PARAM_BOUNDS[NEURON_PARAM_COLUMNS[int(c) % 5]] for c in self.param_cells]
        return np.array(rows, dtype=np.float64).reshape(-1, 2)


# -- functions on robots -----------------------------------------------------------------------
def _spec(robot: Robot | NetworkSpec) -> NetworkSpec:
    return robot if isinstance(robot, NetworkSpec) else NetworkSpec.from_robot(robot)


def param_names(robot: Robot | NetworkSpec) -> list[str]:
    """Names of the robot's learnable parameters (layout: module docstring)."""
    return _spec(robot).param_names()


def param_bounds(robot: Robot | NetworkSpec) -> np.ndarray:
    """``(n_params, 2)`` lower/upper bounds of the robot's learnable parameters."""
    return _spec(robot).param_bounds()


def get_params(robot: Robot | NetworkSpec) -> np.ndarray:
    """The robot's learnable parameters as a flat float64 vector (layout: module docstring)."""
    return _spec(robot).params()


def set_params(robot: Robot, params: npt.ArrayLike) -> Robot:
    """A copy of ``robot`` with its learnable parameters replaced by ``params``.

    Raises:
        ValueError: wrong length, a non-finite value, a non-positive oscillator period, or a
            robot whose network is invalid (see :meth:`NetworkSpec.from_robot`).
    """
    new = NetworkSpec.from_robot(robot).with_params(params)
    weights = new.weight.tolist()
    connections = tuple(
        Connection(c.src, c.dst, w) for c, w in zip(robot.connections, weights, strict=True)
    )
    updated: dict[str, dict[str, Any]] = {}
    for cell in new.param_cells:
        i, col = divmod(int(cell), 5)
        updated.setdefault(new.ids[i], {})[NEURON_PARAM_COLUMNS[col]] = float(
            new.neuron_params[i, col]
        )

    def rebuild(node: Node) -> Node:
        neurons = tuple(
            replace(nr, **updated[nr.id]) if nr.id in updated else nr for nr in node.neurons
        )
        children = tuple((slot, rebuild(child)) for slot, child in node.children)
        return replace(node, neurons=neurons, children=children)

    return replace(robot, body=rebuild(robot.body), connections=connections)

