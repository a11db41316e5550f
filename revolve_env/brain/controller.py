"""The compiled batched neural controller (wraps the C++ module ``revolve_env._controller``).

Same maths and API as :class:`~revolve_env.brain.reference.ReferenceBatchController` (see that
module for the equations); this one steps every network in one C++ call over the caller's arrays,
without copies, and releases the GIL when the batch is large.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from revolve_env import _controller
from revolve_env.body.robot import Robot
from revolve_env.brain._registry import (
    Registry,
    RegistryViews,
    as_spec,
    check_dt,
    check_step_arrays,
)
from revolve_env.brain.spec import NetworkSpec

__all__ = ["BatchController"]


class BatchController(RegistryViews):
    """Steps the networks of many robots (of different sizes) at once.

    Networks are laid out in the flat input and output arrays in order of addition; use
    :meth:`input_slice` / :meth:`output_slice` to find a robot's part. Within a robot, inputs follow
    ``robot.neurons_of(Layer.INPUT)`` and outputs ``robot.neurons_of(Layer.OUTPUT)``.

    Args:
        dt: Control period. Seconds.
    """

    def __init__(self, dt: float) -> None:
        self.dt = check_dt(dt)
        self._impl = _controller.BatchController(self.dt)
        self._reg = Registry()

    # -- population ----------------------------------------------------------------------------
    def add(self, robot_or_spec: Robot | NetworkSpec) -> int:
        """Add a network (state 0, time 0); returns its handle, never reused.

        Raises:
            ValueError: the robot's network is invalid (see ``NetworkSpec.from_robot``).
        """
        spec = as_spec(robot_or_spec)
        handle = int(
            self._impl.add(
                spec.kinds, spec.neuron_params, spec.src, spec.dst, spec.weight,
                spec.n_inputs, spec.n_outputs,
            )
        )
        return self._reg.add(spec, handle)

    def remove(self, handle: int) -> None:
        """Remove a live network. Raises KeyError for an unknown handle."""
        self._reg.spec(handle)
        self._impl.remove(handle)
        self._reg.remove(handle)

    def reset(self, handle: int | None = None) -> None:
        """Set the state to 0 and the time to 0 of one network, or of all if ``handle`` is None."""
        if handle is not None:
            self._reg.spec(handle)
        self._impl.reset(handle)

    def get_state(self, handle: int) -> np.ndarray:
        """A copy of the neuron values of one network, in spec order."""
        self._reg.spec(handle)
        return np.asarray(self._impl.state(handle), dtype=np.float64)

    def time(self, handle: int) -> float:
        """The time the next tick of this network will use. Seconds."""
        self._reg.spec(handle)
        return float(self._impl.time(handle))

    def set_state(self, handle: int, values: npt.ArrayLike, time: float) -> None:
        """Overwrite the neuron values and the time of one network.

        The values are in spec order, as :meth:`get_state` gives them.

        With the values and time of a saved network, the next tick is bit for bit the one the
        saved network would have made (a checkpoint's controller state).

        Args:
            handle: A live network.
            values: One value per neuron, in spec order.
            time: The time of the next tick. Seconds.

        Raises:
            KeyError: unknown handle.
            ValueError: wrong length, or a non-finite time.
        """
        self._reg.spec(handle)
        v = np.ascontiguousarray(values, dtype=np.float64).reshape(-1)
        self._impl.set_state(handle, v, float(time))

    # -- parameters ----------------------------------------------------------------------------
    def set_params(self, handle: int, params: npt.ArrayLike) -> None:
        """Replace the learnable parameters of a network; its state and time are kept.

        Raises:
            ValueError: wrong length, a non-finite value or a non-positive oscillator period.
        """
        spec = self._reg.spec(handle).with_params(params)
        self._impl.set_params(handle, spec.neuron_params, spec.weight)
        self._reg.specs[handle] = spec

    # -- stepping ------------------------------------------------------------------------------
    def step(self, inputs: npt.NDArray[np.float64], outputs: npt.NDArray[np.float64]) -> None:
        """Advance every network one tick; writes normalised hinge targets into ``outputs``.

        Args:
            inputs: ``(n_inputs,)`` C-contiguous float64 sensor values, networks in order of
                addition.
            outputs: ``(n_outputs,)`` C-contiguous writeable float64, overwritten in place with
                targets in [-1, 1] (multiply by the servo range to get angles).

        Raises:
            ValueError: wrong dtype, shape, contiguity, or read-only ``outputs``.
        """
        try:
            self._impl.step(inputs, outputs)
        except TypeError:  # not an ndarray, or read-only outputs: explain precisely
            check_step_arrays(inputs, outputs, self.n_inputs, self.n_outputs)
            raise
