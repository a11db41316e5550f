"""NumPy reference implementation of the batched neural controller.

The maths (RoboGen ``NeuralNetwork.c``, double-buffered): every tick the input neurons take the
sensor values; every other neuron ``i`` computes ``a_i = sum_j w_ji * x_j`` over its incoming
connections, where ``x_j`` is the current tick's value for an input neuron and the previous tick's
value for any other neuron (recurrent connections included); then

* linear: ``clip(gain * (a - bias), 0, 1)``
* sigmoid: ``1 / (1 + exp(-gain * (a - bias)))``
* oscillator: ``0.5 - amplitude/2 + amplitude * (sin(2 pi / period * (t - period * phase_offset))
  + 1) / 2``, inputs ignored, ``t`` the network's own time (0 on the first tick after add or
  reset, then ``+dt`` per tick).

All neurons start at 0. Each output value ``o`` becomes a normalised hinge target
``clip(2 o - 1, -1, 1)`` (the world multiplies it by the servo's range).

Why linear neurons saturate at [0, 1]: RoboGen's own network (``src/brain/NeuralNetwork.c`` in
lis-epfl/robogen) leaves its linear ("SIMPLE") neurons unbounded; what keeps its robots' commands
bounded is the motor, whose ``ServoMotor::setPosition`` and ``setVelocity``
(``src/model/motors/ServoMotor.cpp``) clamp the command to [0, 1] before mapping it to an angle or a
speed, while its sigmoid and oscillator neurons lie in [0, 1] by their formulas. An unbounded
linear neuron in a recurrent loop with ``gain * weight > 1`` grows without limit (here to inf and
then NaN, which the world reports as a blow-up). So the motor's [0, 1] clamp is applied to the
value of every linear neuron as well: every non-input value then lies in [0, 1] (oscillator
amplitudes are at most 1), and with finite sensor values and weights whose sums stay finite
(any weights within ``WEIGHT_BOUNDS``) no network can diverge. An output's hinge target is the
same as with the clamp at the motor alone; only what other neurons read from a linear neuron
changes. NaN (a NaN sensor value) passes through, as in ``np.clip``.

The compiled :class:`~revolve_env.brain.controller.BatchController` computes the same thing with
the same floating-point operations in the same order (its exp and sin differ from NumPy's by at
most an ulp or two); tests compare the two. This class is vectorised over all
networks (one ``bincount`` per tick) and is the benchmark baseline.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from revolve_env.body.robot import Robot
from revolve_env.brain._registry import (
    Registry,
    RegistryViews,
    as_spec,
    check_dt,
    check_step_arrays,
)
from revolve_env.brain.spec import KIND_LINEAR, KIND_OSCILLATOR, KIND_SIGMOID, NetworkSpec

__all__ = ["ReferenceBatchController"]


@dataclass(slots=True)
class _Layout:
    """Concatenated arrays of all live networks (rebuilt when the population changes)."""

    state: np.ndarray  # all neuron values, networks in order of addition
    time: np.ndarray  # seconds, one per network
    bases: dict[int, tuple[int, int]]  # handle -> (first neuron index, network index)
    in_idx: np.ndarray
    out_idx: np.ndarray
    src: np.ndarray  # connections sorted (stably) by destination
    dst: np.ndarray
    weight: np.ndarray
    lin_idx: np.ndarray
    lin_gain: np.ndarray
    lin_bias: np.ndarray
    sig_idx: np.ndarray
    sig_gain: np.ndarray
    sig_bias: np.ndarray
    osc_idx: np.ndarray
    osc_net: np.ndarray
    osc_omega: np.ndarray  # 2 pi / period, radians per second
    osc_shift: np.ndarray  # period * phase_offset, seconds
    osc_amp: np.ndarray


class ReferenceBatchController(RegistryViews):
    """Steps the networks of many robots at once with NumPy (same API as ``BatchController``).

    Args:
        dt: Control period. Seconds.
    """

    def __init__(self, dt: float) -> None:
        self.dt = check_dt(dt)
        self._reg = Registry()
        self._state: dict[int, np.ndarray] = {}  # valid while self._layout is None
        self._time: dict[int, float] = {}
        self._layout: _Layout | None = None

    # -- population ----------------------------------------------------------------------------
    def add(self, robot_or_spec: Robot | NetworkSpec) -> int:
        """Add a network (state 0, time 0); returns its handle, never reused."""
        spec = as_spec(robot_or_spec)
        self._unpack()
        h = self._reg.add(spec)
        self._state[h] = np.zeros(spec.n_neurons)
        self._time[h] = 0.0
        return h

    def remove(self, handle: int) -> None:
        """Remove a live network. Raises KeyError for an unknown handle."""
        self._reg.spec(handle)
        self._unpack()
        self._reg.remove(handle)
        del self._state[handle], self._time[handle]

    def reset(self, handle: int | None = None) -> None:
        """Set the state to 0 and the time to 0 of one network, or of all if ``handle`` is None."""
        handles = list(self._reg.specs) if handle is None else [handle]
        for h in handles:
            self._reg.spec(h)
        self._unpack()
        for h in handles:
            self._state[h][:] = 0.0
            self._time[h] = 0.0

    def get_state(self, handle: int) -> np.ndarray:
        """A copy of the neuron values of one network, in spec order."""
        spec = self._reg.spec(handle)
        if self._layout is None:
            return self._state[handle].copy()
        base = self._layout.bases[handle][0]
        return self._layout.state[base : base + spec.n_neurons].copy()

    def time(self, handle: int) -> float:
        """The time the next tick of this network will use. Seconds."""
        self._reg.spec(handle)
        if self._layout is None:
            return self._time[handle]
        return float(self._layout.time[self._layout.bases[handle][1]])

    def set_state(self, handle: int, values: npt.ArrayLike, time: float) -> None:
        """Overwrite the neuron values (spec order) and the time of one network (seconds).

        Raises:
            KeyError: unknown handle.
            ValueError: wrong length, or a non-finite time.
        """
        spec = self._reg.spec(handle)
        v = np.asarray(values, dtype=np.float64).reshape(-1)
        if v.shape[0] != spec.n_neurons:
            raise ValueError(f"set_state expects {spec.n_neurons} neuron values, got {v.shape[0]}")
        if not math.isfinite(float(time)):
            raise ValueError("set_state: the time must be finite")
        self._unpack()
        self._state[handle][:] = v
        self._time[handle] = float(time)

    # -- parameters ----------------------------------------------------------------------------
    def set_params(self, handle: int, params: npt.ArrayLike) -> None:
        """Replace the learnable parameters of a network; its state and time are kept."""
        spec = self._reg.spec(handle).with_params(params)
        self._unpack()
        self._reg.specs[handle] = spec

    # -- stepping ------------------------------------------------------------------------------
    def step(self, inputs: npt.NDArray[np.float64], outputs: npt.NDArray[np.float64]) -> None:
        """Advance every network one tick; writes normalised hinge targets into ``outputs``.

        Args:
            inputs: ``(n_inputs,)`` float64 sensor values, networks in order of addition.
            outputs: ``(n_outputs,)`` float64, written in place with targets in [-1, 1].
        """
        check_step_arrays(inputs, outputs, self.n_inputs, self.n_outputs)
        lay = self._layout if self._layout is not None else self._pack()
        s = lay.state
        s[lay.in_idx] = inputs
        # Saturating sigmoids overflow exp to inf (giving 0), as in C; no warning for that.
        with np.errstate(over="ignore", invalid="ignore"):
            a = np.bincount(lay.dst, weights=lay.weight * s[lay.src], minlength=s.shape[0])
            lin = lay.lin_gain * (a[lay.lin_idx] - lay.lin_bias)
            sig = 1.0 / (1.0 + np.exp(-(lay.sig_gain * (a[lay.sig_idx] - lay.sig_bias))))
        t = lay.time[lay.osc_net]
        amp = lay.osc_amp
        osc = 0.5 - amp / 2.0 + amp * (np.sin(lay.osc_omega * (t - lay.osc_shift)) + 1.0) / 2.0
        # Linear neurons saturate at [0, 1] (module docstring). minimum/maximum rather than
        # np.clip: the same values (NaN passes through), less overhead per tick.
        np.minimum(np.maximum(lin, 0.0, out=lin), 1.0, out=lin)
        s[lay.lin_idx] = lin
        s[lay.sig_idx] = sig
        s[lay.osc_idx] = osc
        np.multiply(s[lay.out_idx], 2.0, out=outputs)
        outputs -= 1.0
        np.clip(outputs, -1.0, 1.0, out=outputs)
        lay.time += self.dt

    # -- layout --------------------------------------------------------------------------------
    def _unpack(self) -> None:
        """Copy the packed state back to the per-network arrays and drop the layout."""
        lay = self._layout
        if lay is None:
            return
        for h, (base, k) in lay.bases.items():
            n = self._reg.specs[h].n_neurons
            self._state[h] = lay.state[base : base + n].copy()
            self._time[h] = float(lay.time[k])
        self._layout = None

    def _pack(self) -> _Layout:
        specs = self._reg.specs
        bases: dict[int, tuple[int, int]] = {}
        base = 0
        for k, (h, sp) in enumerate(specs.items()):
            bases[h] = (base, k)
            base += sp.n_neurons

        def cat(parts: list[np.ndarray], dtype: type) -> np.ndarray:
            return np.concatenate(parts).astype(dtype) if parts else np.zeros(0, dtype)

        items = list(specs.items())
        offs = [bases[h][0] for h, _ in items]
        kinds = cat([sp.kinds for _, sp in items], np.int8)
        params = (
            np.concatenate([sp.neuron_params for _, sp in items]) if items else np.zeros((0, 5))
        )
        net_of = cat([np.full(sp.n_neurons, k) for k, (_, sp) in enumerate(items)], np.int64)
        pairs = list(zip(items, offs, strict=True))
        src = cat([sp.src.astype(np.int64) + o for (_, sp), o in pairs], np.int64)
        dst = cat([sp.dst.astype(np.int64) + o for (_, sp), o in pairs], np.int64)
        weight = cat([sp.weight for _, sp in items], np.float64)
        order = np.argsort(dst, kind="stable")
        lin_idx = np.flatnonzero(kinds == KIND_LINEAR)
        sig_idx = np.flatnonzero(kinds == KIND_SIGMOID)
        osc_idx = np.flatnonzero(kinds == KIND_OSCILLATOR)
        period = params[osc_idx, 2]
        self._layout = _Layout(
            state=cat([self._state[h] for h, _ in items], np.float64),
            time=np.array([self._time[h] for h, _ in items], dtype=np.float64),
            bases=bases,
            in_idx=cat([o + np.arange(sp.n_inputs) for (_, sp), o in pairs], np.int64),
            out_idx=cat(
                [o + sp.n_inputs + np.arange(sp.n_outputs) for (_, sp), o in pairs],
                np.int64,
            ),
            src=src[order],
            dst=dst[order],
            weight=weight[order],
            lin_idx=lin_idx,
            lin_gain=params[lin_idx, 1],
            lin_bias=params[lin_idx, 0],
            sig_idx=sig_idx,
            sig_gain=params[sig_idx, 1],
            sig_bias=params[sig_idx, 0],
            osc_idx=osc_idx,
            osc_net=net_of[osc_idx],
            osc_omega=2.0 * np.pi / period,
            osc_shift=period * params[osc_idx, 3],
            osc_amp=params[osc_idx, 4],
        )
        return self._layout
