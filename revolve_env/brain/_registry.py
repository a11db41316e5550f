"""Bookkeeping shared by both batch controllers: handles, specs and the flat array layout."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from revolve_env.body.robot import Robot
from revolve_env.brain.spec import NetworkSpec


def as_spec(robot_or_spec: Robot | NetworkSpec) -> NetworkSpec:
    """A validated spec from a robot, or the spec itself."""
    if isinstance(robot_or_spec, NetworkSpec):
        return robot_or_spec
    if isinstance(robot_or_spec, Robot):
        return NetworkSpec.from_robot(robot_or_spec)
    raise TypeError(f"expected a Robot or a NetworkSpec, got {type(robot_or_spec).__name__}")


def check_dt(dt: float) -> float:
    """``dt`` as a float, or ValueError if it is not a positive finite number of seconds."""
    dt = float(dt)
    if not (math.isfinite(dt) and dt > 0.0):
        raise ValueError(f"dt must be a positive number of seconds, got {dt}")
    return dt


class Registry:
    """Live networks in order of addition, with their slices of the flat input/output arrays."""

    def __init__(self) -> None:
        self.specs: dict[int, NetworkSpec] = {}
        self._next = 0
        self._slices: dict[int, tuple[slice, slice]] | None = None
        self.n_inputs = 0
        self.n_outputs = 0

    def add(self, spec: NetworkSpec, handle: int | None = None) -> int:
        """Register ``spec``; a new handle (never reused) unless ``handle`` is given."""
        if handle is None:
            handle = self._next
        self._next = max(self._next, handle + 1)
        self.specs[handle] = spec
        self.n_inputs += spec.n_inputs
        self.n_outputs += spec.n_outputs
        self._slices = None
        return handle

    def spec(self, handle: int) -> NetworkSpec:
        """The spec of a live network. Raises KeyError for an unknown handle."""
        try:
            return self.specs[handle]
        except (KeyError, TypeError):
            raise KeyError(f"no live network with handle {handle!r}") from None

    def remove(self, handle: int) -> None:
        spec = self.spec(handle)
        del self.specs[handle]
        self.n_inputs -= spec.n_inputs
        self.n_outputs -= spec.n_outputs
        self._slices = None

    def slices(self, handle: int) -> tuple[slice, slice]:
        """``(input_slice, output_slice)`` of a live network."""
        self.spec(handle)
        if self._slices is None:
            self._slices = {}
            i = o = 0
            for h, s in self.specs.items():
                self._slices[h] = (slice(i, i + s.n_inputs), slice(o, o + s.n_outputs))
                i += s.n_inputs
                o += s.n_outputs
        return self._slices[handle]


def check_step_arrays(inputs: npt.NDArray[np.float64], outputs: npt.NDArray[np.float64],
                      n_inputs: int, n_outputs: int) -> None:
    """ValueError unless both are contiguous float64 vectors of the right length."""
    for name, a, n in (("inputs", inputs, n_inputs), ("outputs", outputs, n_outputs)):
        if not isinstance(a, np.ndarray) or a.dtype != np.float64 or a.shape != (n,):
            raise ValueError(
                f"{name} must be a float64 array of shape ({n},), got "
                f"{getattr(a, 'dtype', type(a).__name__)} {getattr(a, 'shape', '')}"
            )
        if not a.flags.c_contiguous:
            raise ValueError(f"{name} must be C-contiguous")
    if not outputs.flags.writeable:
        raise ValueError("outputs must be writeable")


class RegistryViews:
    """Read-only views of a :class:`Registry` (layout, specs, parameters).

    Shared by both batch controllers.
    """

    _reg: Registry

    @property
    def handles(self) -> list[int]:
        """Live handles in order of addition."""
        return list(self._reg.specs)

    @property
    def n_inputs(self) -> int:
        """Total inputs over the live networks."""
        return self._reg.n_inputs

    @property
    def n_outputs(self) -> int:
        """Total outputs over the live networks."""
        return self._reg.n_outputs

    def input_slice(self, handle: int) -> slice:
        """This network's part of the flat input array."""
        return self._reg.slices(handle)[0]

    def output_slice(self, handle: int) -> slice:
        """This network's part of the flat output array."""
        return self._reg.slices(handle)[1]

    def spec(self, handle: int) -> NetworkSpec:
        """The spec of a live network."""
        return self._reg.spec(handle)

    def get_params(self, handle: int) -> np.ndarray:
        """The learnable parameters of a network (layout: ``revolve_env.brain.spec``)."""
        return self._reg.spec(handle).params()

    def param_names(self, handle: int) -> list[str]:
        """Names of the learnable parameters of a network."""
        return self._reg.spec(handle).param_names()

    def param_bounds(self, handle: int) -> np.ndarray:
        """``(n_params, 2)`` bounds of the learnable parameters of a network."""
        return self._reg.spec(handle).param_bounds()
