"""The experiment application: the paper's scenarios run, stored and resumed.

Modules, bottom up: :mod:`~evolution.experiments.loop.errors`,
:mod:`~evolution.experiments.loop.registry` (the shipped TOML configs, the one scenario registry),
:mod:`~evolution.experiments.loop.config` (:class:`ExperimentConfig`),
:mod:`~evolution.experiments.store.database` (SQLite results, exact resume),
:mod:`~evolution.experiments.store.remote` (what a run needs from the store; under Ray a store actor
on the driver's node), :mod:`~evolution.experiments.loop.run` (the records and interfaces of a run),
:mod:`~evolution.experiments.loop.state` (a run's state and the steps both modes share),
:mod:`~evolution.experiments.loop.offline` and :mod:`~evolution.experiments.loop.online` (the two
modes), :mod:`~evolution.experiments.loop.online_world` (the population env as the online world),
:mod:`~evolution.experiments.loop.evolve` (:class:`Evolution`, the loop you can step, and its
observers), :mod:`~evolution.experiments.store.observer` (the results store as an observer; one run
in its results folder), :mod:`~evolution.experiments.app.api` (:func:`run` / :func:`resume` of a
whole experiment), :mod:`~evolution.experiments.app.study` (the paper's five experiments on one
pool), :mod:`~evolution.experiments.app.reevaluate` (re-evaluations of stored robots) and
:mod:`~evolution.experiments.app.callbacks` (progress callbacks: TensorBoard).
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
from evolution.experiments.loop.registry import learning_names, shipped_configs
from evolution.experiments.loop.run import (
    Birth,
    Member,
    OnlineWorld,
    ProgressEvent,
    ReplayError,
    RobotStatus,
    RunJob,
    RunSummary,
    Step,
    WorldFactory,
    run_seed,
    world_seed,
)
from evolution.experiments.store.database import DB_NAME, Store, StoreError
from evolution.experiments.store.observer import StoreObserver, execute_run

__all__ = [
    "DB_NAME",
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
