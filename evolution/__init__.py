"""Evolution of modular robots: configuration, random robots, operators, selection, diversity.

The package itself is the pure evolutionary library (pure Python over the robot descriptions of
:mod:`revolve_env.body`; it never imports a physics engine). The application around it lives in
its own subpackages, each importing only the layers below it:

* :mod:`evolution.evaluation`: isolated evaluations and worker pools;
* :mod:`evolution.learning`: infancy learning (the Training Center);
* :mod:`evolution.experiments`: the scenarios, both engines, the results store;
* :mod:`evolution.reporting`: tables, statistics and figures of stored results;
* :mod:`evolution.cli`: the ``revolve`` command, a thin layer over the Python API.

Every name is served lazily (PEP 562): importing :mod:`evolution` (or one of its subpackages,
as ``revolve --help`` imports :mod:`evolution.cli`) loads nothing until a name is used; the
library's names come from its modules, and for convenience ``evolution.Evolution`` (the loop you
can step), ``evolution.run``, ``evolution.resume``, ``evolution.study``,
``evolution.reevaluate``, ``evolution.report`` and the experiment types from those subpackages.
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
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

# The library's names, by module: imported when first used.
_LIBRARY = {
    "evolution.config": ("EvolutionConfig",),
    "evolution.diversity": ("diversity", "pairwise_distances", "tree_edit_distance"),
    "evolution.lifecycle": ("Lifecycle", "LifecycleError", "Stage"),
    "evolution.operators": (
        "OperatorOutcome", "OperatorRecord", "ReproductionResult", "add_part", "crossover",
        "duplicate_subtree", "mutate", "mutate_brain_structure", "mutate_parameters",
        "remove_leaf", "remove_subtree", "reproduce", "swap_subtrees"),
    "evolution.random_robot": (
        "RandomRobotError", "RandomRobotResult", "random_robot", "random_robot_with_report"),
    "evolution.selection": (
        "mu_plus_lambda", "online_survivors", "random_survivors", "select_parents", "tournament"),
}

# The application's public names, served lazily so that the library never imports them.
_LAZY = {
    "ConfigError": "evolution.experiments",
    "Evolution": "evolution.experiments",
    "ExperimentConfig": "evolution.experiments",
    "Observer": "evolution.experiments",
    "Store": "evolution.experiments",
    "StoreError": "evolution.experiments",
    "preset": "evolution.experiments",
    "reevaluate": "evolution.experiments.app.reevaluate",
    "resume": "evolution.experiments",
    "run": "evolution.experiments",
    "study": "evolution.experiments.app.study",
    "LocalEvaluator": "evolution.evaluation",
    "RayEvaluator": "evolution.evaluation",
    "report": "evolution.reporting",
}
_LAZY.update({name: module for module, names in _LIBRARY.items() for name in names})

_SHADOWED = frozenset({"diversity", "random_robot"})
"""Functions named as the modules that define them (``evolution.diversity.diversity``)."""


class _Package(types.ModuleType):
    """The ``evolution`` package object: its functions keep their names over submodules.

    Importing a submodule binds it on its package (``evolution.random_robot = <module>``);
    for :data:`_SHADOWED` that would hide the function ``from evolution import random_robot``
    means (as the eager imports of earlier versions left it), so that binding is skipped: the
    module stays in ``sys.modules`` and ``from evolution.random_robot import ...`` works as ever.
    """

    def __setattr__(self, name: str, value: Any) -> None:
        if name in _SHADOWED and isinstance(value, types.ModuleType):
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value  # found directly from now on
        return value
    raise AttributeError(f"module 'evolution' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(list(globals()) + list(_LAZY))
