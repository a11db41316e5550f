"""Robot brains: network spec, learnable parameters, compiled and NumPy batch controllers."""

from revolve_env.brain.controller import BatchController
from revolve_env.brain.reference import ReferenceBatchController
from revolve_env.brain.spec import (
    NetworkSpec,
    get_params,
    param_bounds,
    param_names,
    set_params,
)

__all__ = [
    "BatchController",
    "NetworkSpec",
    "ReferenceBatchController",
    "get_params",
    "param_bounds",
    "param_names",
    "set_params",
]
