"""Evolution of modular robots: configuration, random robots, operators, selection, diversity.

The package itself is the pure evolutionary library (pure Python over the robot descriptions of
:mod:`revolve_env.body`; it never imports a physics engine). The application around it lives in
its own subpackages, each importing only the layers below it:

* :mod:`evolution.evaluation`: isolated evaluations and worker pools;
* :mod:`evolution.learning`: infancy learning (the Training Center);
* :mod:`evolution.experiments`: the scenarios, both engines, the results store;
* :mod:`evolution.reporting`: tables, statistics and figures of stored results;
* :mod:`evolution.cli`: the ``revolve`` command, a thin layer over the Python API.

For convenience ``evolution.Evolution`` (the loop you can step), ``evolution.run``,
``evolution.resume``, ``evolution.study``, ``evolution.reevaluate``, ``evolution.report`` and the
experiment types are served lazily
(PEP 562) from those subpackages: importing :mod:`evolution` loads none of them.
"""

from __future__ import annotations

import importlib
from typing import Any

from evolution.config import EvolutionConfig
from evolution.diversity import diversity, pairwise_distances, tree_edit_distance
from evolution.lifecycle import Lifecycle, LifecycleError, Stage
from evolution.operators import (
    OperatorOutcome,
    OperatorRecord,
    ReproductionResult,
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
from evolution.random_robot import (
    RandomRobotError,
    RandomRobotResult,
    random_robot,
    random_robot_with_report,
)
from evolution.selection import (
    mu_plus_lambda,
    online_survivors,
    random_survivors,
    select_parents,
    tournament,
)

__all__ = [
    "EvolutionConfig",
    "OperatorOutcome",
    "OperatorRecord",
    "RandomRobotError",
    "RandomRobotResult",
    "ReproductionResult",
    "add_part",
    "crossover",
    "diversity",
    "duplicate_subtree",
    "mu_plus_lambda",
    "mutate",
    "mutate_brain_structure",
    "mutate_parameters",
    "online_survivors",
    "pairwise_distances",
    "random_robot",
    "random_robot_with_report",
    "random_survivors",
    "remove_leaf",
    "remove_subtree",
    "reproduce",
    "select_parents",
    "swap_subtrees",
    "tournament",
    "tree_edit_distance",
    "Lifecycle",
    "LifecycleError",
    "Stage",
]

# The application's public names, served lazily so that the library never imports them.
_LAZY = {
    "ConfigError": "evolution.experiments",
    "Evolution": "evolution.experiments",
    "ExperimentConfig": "evolution.experiments",
    "Observer": "evolution.experiments",
    "Store": "evolution.experiments",
    "StoreError": "evolution.experiments",
    "preset": "evolution.experiments",
    "reevaluate": "evolution.experiments.reevaluate",
    "resume": "evolution.experiments",
    "run": "evolution.experiments",
    "study": "evolution.experiments.study",
    "LocalEvaluator": "evolution.evaluation",
    "RayEvaluator": "evolution.evaluation",
    "report": "evolution.reporting",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'evolution' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(list(globals()) + list(_LAZY))
