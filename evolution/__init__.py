"""Evolution of modular robots: configuration, random robots, operators, selection, diversity.

Pure Python over the robot descriptions of :mod:`revolve_env.body`; never imports pybullet.
"""

from evolution.config import EvolutionConfig
from evolution.diversity import diversity, pairwise_distances, tree_edit_distance
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
]
from evolution.evaluators import LocalEvaluator, RayEvaluator
from evolution.experiment import ConfigError, ExperimentConfig, preset, resume, run
from evolution.lifecycle import Lifecycle, LifecycleError, Stage
from evolution.store import Store, StoreError

__all__ += [
    "ConfigError", "ExperimentConfig", "Lifecycle", "LifecycleError", "LocalEvaluator",
    "RayEvaluator", "Stage", "Store", "StoreError", "preset", "resume", "run",
]
from evolution.reporting import report

__all__ += ["report"]
