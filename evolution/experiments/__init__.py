"""The experiment application: the paper's scenarios run, stored and resumed.

Three rooms, bottom up; each imports only its own and the ones below it
(``tests/test_import_graph.py``):

:mod:`~evolution.experiments.loop` (the run)
    The scenarios (:mod:`~evolution.experiments.loop.registry`, the shipped TOML files;
    :mod:`~evolution.experiments.loop.config`, :class:`ExperimentConfig`), the records a run makes
    (:mod:`~evolution.experiments.loop.records`) and what crosses between the loop, its worlds and
    observers (:mod:`~evolution.experiments.loop.run`), a run's state
    (:mod:`~evolution.experiments.loop.state`), the two modes
    (:mod:`~evolution.experiments.loop.offline`, :mod:`~evolution.experiments.loop.online`, the
    population env as the online world: :mod:`~evolution.experiments.loop.online_world`) and
    :class:`Evolution`, the loop you can step, with its observers
    (:mod:`~evolution.experiments.loop.evolve`). It writes nothing: it reads a stored run through
    its own protocol (:class:`~evolution.experiments.loop.run.StoredRun`) and imports nothing of the
    store.
:mod:`~evolution.experiments.store` (the results store)
    The SQLite database (:mod:`~evolution.experiments.store.database`; its tables and upgrades:
    :mod:`~evolution.experiments.store.schema`) and its checks
    (:mod:`~evolution.experiments.store.integrity`), the files beside it
    (:mod:`~evolution.experiments.store.results_folder`,
    :mod:`~evolution.experiments.store.snapshot`), results folders found
    (:mod:`~evolution.experiments.store.folders`), the store under Ray
    (:mod:`~evolution.experiments.store.remote`) and the store as the loop's observer, one run in
    its folder (:mod:`~evolution.experiments.store.observer`).
:mod:`~evolution.experiments.app` (the application)
    :func:`run` / :func:`resume` of a whole experiment
    (:mod:`~evolution.experiments.app.api`), the paper's study
    (:mod:`~evolution.experiments.app.study`) and its time estimate
    (:mod:`~evolution.experiments.app.estimate`), re-evaluations of stored robots
    (:mod:`~evolution.experiments.app.reevaluate`) and progress callbacks
    (:mod:`~evolution.experiments.app.callbacks`: TensorBoard).

This package re-exports the public names.
"""

from __future__ import annotations

from evolution.experiments.app.api import ExperimentSummary, ProgressCallback, resume, run
from evolution.experiments.loop.config import ConfigError, ExperimentConfig, load_config, preset
from evolution.experiments.loop.evolve import (
    EventObserver,
    Evolution,
    Observer,
    ProgressObserver,
    default_world,
)
from evolution.experiments.loop.registry import PAPER_SCENARIOS, learning_names, shipped_configs
from evolution.experiments.loop.run import (
    Birth,
    Member,
    OnlineWorld,
    ProgressEvent,
    ReplayError,
    RobotStatus,
    RunSummary,
    Step,
    WorldFactory,
    run_seed,
    world_seed,
)
from evolution.experiments.store.database import DB_NAME, Store, StoreError
from evolution.experiments.store.observer import RunJob, StoreObserver, execute_run

__all__ = [
    "DB_NAME",
    "PAPER_SCENARIOS",
    "Birth",
    "ConfigError",
    "EventObserver",
    "Evolution",
    "ExperimentConfig",
    "ExperimentSummary",
    "Member",
    "Observer",
    "OnlineWorld",
    "ProgressCallback",
    "ProgressEvent",
    "ProgressObserver",
    "ReplayError",
    "RobotStatus",
    "RunJob",
    "RunSummary",
    "Step",
    "Store",
    "StoreError",
    "StoreObserver",
    "WorldFactory",
    "default_world",
    "execute_run",
    "learning_names",
    "load_config",
    "preset",
    "resume",
    "run",
    "run_seed",
    "world_seed",
    "shipped_configs",
]
