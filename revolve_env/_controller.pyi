"""Type stubs of the compiled controller (controller_cpp/src/bindings.cpp).

Use it through :class:`revolve_env.brain.BatchController`.
"""

from typing import Any

import numpy as np
import numpy.typing as npt

ABI_VERSION: int
KIND_INPUT: int
KIND_LINEAR: int
KIND_SIGMOID: int
KIND_OSCILLATOR: int

def exp_into(x: npt.NDArray[np.float64], out: npt.NDArray[np.float64]) -> None: ...
def sin_into(x: npt.NDArray[np.float64], out: npt.NDArray[np.float64]) -> None: ...
def step_reports(
    agents: list[str],
    templates: list[dict[str, Any]],
    keys: tuple[str, ...],
    ages: npt.NDArray[np.int64],
    dt: float,
    insertion_steps: int,
    maturity_steps: int,
    f: npt.NDArray[np.float64],
    v: npt.NDArray[np.float64],
    s: npt.NDArray[np.float64],
    rewards: npt.NDArray[np.float64],
    position: npt.NDArray[np.float64],
    trajectories: npt.NDArray[np.float64],
    trajectory_starts: npt.NDArray[np.intp],
    trajectory_stops: npt.NDArray[np.intp],
    view: npt.NDArray[np.float64],
    view_starts: npt.NDArray[np.intp],
    view_stops: npt.NDArray[np.intp],
) -> tuple[
    dict[str, npt.NDArray[np.float64]],
    dict[str, float],
    dict[str, dict[str, Any]],
    tuple[list[Any], ...],
]: ...

class BatchController:
    def __init__(self, dt: float) -> None: ...
    def add(
        self,
        kinds: npt.NDArray[np.int8],
        neuron_params: npt.NDArray[np.float64],
        src: npt.NDArray[np.int32],
        dst: npt.NDArray[np.int32],
        weight: npt.NDArray[np.float64],
        n_inputs: int,
        n_outputs: int,
    ) -> int: ...
    def remove(self, handle: int) -> None: ...
    def reset(self, handle: int | None = None) -> None: ...
    def set_params(
        self, handle: int, neuron_params: npt.NDArray[np.float64], weight: npt.NDArray[np.float64]
    ) -> None: ...
    def step(self, inputs: npt.NDArray[np.float64], outputs: npt.NDArray[np.float64]) -> None: ...
    @property
    def dt(self) -> float: ...
    @property
    def n_inputs(self) -> int: ...
    @property
    def n_outputs(self) -> int: ...
    def __len__(self) -> int: ...
    def handles(self) -> list[int]: ...
    def input_offset(self, handle: int) -> int: ...
    def output_offset(self, handle: int) -> int: ...
    def state(self, handle: int) -> list[float]: ...
    def time(self, handle: int) -> float: ...
    def set_state(self, handle: int, values: npt.NDArray[np.float64], time: float) -> None: ...
