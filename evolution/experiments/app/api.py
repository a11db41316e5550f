"""The Python API of the experiments: ``run(config, out_dir)`` and ``resume(out_dir)``."""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import revolve_env
from evolution.evaluation import Evaluator, make_evaluator
from evolution.experiments.loop.config import ConfigError, ExperimentConfig, as_config
from evolution.experiments.loop.evolve import infancy_for
from evolution.experiments.loop.run import (
    ProgressEvent,
    RunSummary,
    WorldFactory,
    check_infancy,
    run_seed,
)
from evolution.experiments.store.database import DB_NAME, Store, StoreError
from evolution.experiments.store.integrity import check_writable, verify
from evolution.experiments.store.observer import RunJob, execute_run
from evolution.experiments.store.results_folder import check_task_code, refuse_pickled
from evolution.experiments.store.schema import RunRecord
from evolution.lifecycle import InfancyHook

__all__ = [
    "ExperimentSummary",
    "ProgressCallback",
    "check_physics",
    "check_resumable",
    "check_task_code",
    "config_differences",
    "flat_keys",
    "pending_jobs",
    "resume",
    "run",
    "work_left",
]


@dataclass(frozen=True, slots=True)
class ExperimentSummary:
    """How an experiment's runs ended.

    Attributes:
        out_dir: The results directory.
        db_path: Its database.
        runs: One summary per run executed by this call, by run id.
    """

    out_dir: Path
    db_path: Path
    runs: tuple[RunSummary, ...]


ProgressCallback = Callable[[ProgressEvent], None]
"""Receives a :class:`~evolution.experiments.loop.run.ProgressEvent` after every commit point of
every run."""


def run(
    config: ExperimentConfig | str | os.PathLike[str] | Mapping[str, Any],
    out_dir: str | os.PathLike[str],
    progress: ProgressCallback | None = None,
    *,
    evaluator: Evaluator | None = None,
    world_factory: WorldFactory | None = None,
    infancy: InfancyHook | None = None,
) -> ExperimentSummary:
    """Run an experiment, writing its results to ``out_dir/results.sqlite``.

    Args:
        config: An :class:`ExperimentConfig`, a shipped config name (``"scenario1"``,
            ``"scenario1_learning"``, ...: the same file ``revolve run NAME`` reads), the path of
            a TOML config, or a dict.
        out_dir: Results directory; created if missing. It must not already hold results.
        progress: Called with a :class:`~evolution.experiments.ProgressEvent` after every
            commit point (raising from it stops the run after that commit point; ``resume``
            continues).
        evaluator: An :mod:`evolution.evaluation` evaluator; default from ``config.evaluator``
            and ``config.workers`` (closed at the end only if made here).
        world_factory: Makes the online world of a run (default: the population environment).
        infancy: The Training Center: an infancy hook, usually a
            :class:`~evolution.learning.TrainingCenter` (both modes; see
            :mod:`evolution.experiments.loop.evolve` for when it runs, how learning is recorded
            and what Lamarckian inheritance changes). Default: the one ``config.learning`` describes
            (stored with the results; :func:`resume` rebuilds it). A hook given here without
            ``config.learning`` is not stored: pass the same one to :func:`resume`.

    Returns:
        The summary of every run.

    Raises:
        ConfigError: invalid configuration, or an ``infancy`` other than the Training Center
            of ``config.learning``.
        TypeError: an infancy hook that is not callable
            (:func:`evolution.experiments.loop.run.check_infancy`).
        StoreError: ``out_dir`` already holds results (of this or another experiment).
        KeyboardInterrupt: Ctrl-C; what finished is committed, ``resume(out_dir)`` continues.
    """
    config = as_config(config)
    infancy = infancy_for(config, infancy)
    check_infancy(infancy)
    out = Path(out_dir)
    db_path = out / DB_NAME
    if db_path.exists() and not Store.is_empty(db_path):  # an empty one is replaced
        _refuse_existing(out, db_path, config)
    if out.exists() and not out.is_dir():
        raise StoreError(f"{out} exists and is not a directory")
    Store.create(db_path, config.to_dict(), config.seed).close()
    return _execute(config, db_path, progress, evaluator, world_factory, infancy)


def resume(
    out_dir: str | os.PathLike[str],
    progress: ProgressCallback | None = None,
    *,
    evaluator: Evaluator | None = None,
    world_factory: WorldFactory | None = None,
    infancy: InfancyHook | None = None,
    trust_pickled_policies: bool = False,
    trust_task_code: bool = False,
) -> ExperimentSummary:
    """Continue an interrupted experiment to the result an uninterrupted one would have given.

    Finished runs are left alone; the others continue from their last commit point. With a
    stored ``learning`` table the Training Center is rebuilt from it (``infancy`` may be given
    only if it is the same one).

    The database is checked before anything is written to it
    (:func:`~evolution.experiments.store.integrity.verify`): a damaged or read-only one is refused
    and left as it was. Runs that were never registered (a kill right after the database was
    created) are registered and run.

    ``trust_pickled_policies``: an online SB3 run may reload policies that older versions saved
    as pickles; unpickling can run code, so they are refused unless this is true (only for a
    results folder whose author you trust). ``trust_task_code``: a stored ``[task]`` that names a
    class of the user's own is imported (its module's code runs) only if this is true.

    Raises:
        StoreError: no usable results database in ``out_dir`` (missing, corrupt, empty, newer
            schema, damaged, its stored configuration invalid for this package version, or
            read-only), or a saved policy that cannot be used (a pickled one not trusted).
        ConfigError: ``infancy`` differs from the stored learning table's Training Center.
    """
    check_infancy(infancy)
    db_path = Path(out_dir) / DB_NAME
    config = check_resumable(db_path, trust_pickled_policies, trust_task_code)
    infancy = infancy_for(config, infancy)
    check_infancy(infancy)
    return _execute(config, db_path, progress, evaluator, world_factory, infancy,
                    trust_pickled_policies)


def _execute(
    config: ExperimentConfig,
    db_path: Path,
    progress: ProgressCallback | None,
    evaluator: Evaluator | None,
    world_factory: WorldFactory | None,
    infancy: InfancyHook | None,
    trust_pickled_policies: bool = False,
) -> ExperimentSummary:
    jobs = [replace(job, trust_pickled_policies=trust_pickled_policies)
            for job in pending_jobs(config, db_path, world_factory, infancy)]
    used = evaluator or make_evaluator(config.evaluator, config.workers, config.ray_address)
    try:
        summaries = used.run_jobs(execute_run, jobs, progress)
    finally:
        if evaluator is None:
            used.close()
    return ExperimentSummary(db_path.parent, db_path, tuple(summaries))


def check_resumable(db_path: Path, trust_pickled_policies: bool = False,
                    trust_task_code: bool = False) -> ExperimentConfig:
    """The stored configuration of a results database that can be continued.

    The database is checked before anything is written to it
    (:func:`~evolution.experiments.store.integrity.verify`), and, when a run is left to do, that it
    can be written and that the policies its online runs reload are not pickles (unless trusted).

    Raises:
        StoreError: missing, corrupt, newer, damaged or (with work left) read-only database,
            an unfinished online run that would load a pickled policy (not trusted), or a
            stored task class of the user's own that continuing would import (not trusted:
            :func:`~evolution.experiments.store.results_folder.check_task_code`).
    """
    with Store.open(db_path) as store:
        config = verify(store, resumable=True)
        runs = store.runs()
        # Continuing builds the stored task (resume does, through its Training Center, even
        # with no work left): a class it names is imported only when trusted.
        check_task_code(db_path, config, trust_task_code)
        if work_left(config, runs):
            check_physics(store, config)
            check_writable(store)
            if config.mode == "online":  # offline runs never reload a policy
                refuse_pickled(store, {r.run_id for r in runs if r.status != "finished"},
                               trust_pickled_policies)
    return config


def check_physics(store: Store, config: ExperimentConfig) -> None:
    """Refuse to continue results made with another revision of their engine's stepping.

    Raises:
        StoreError: the run's engine steps differently in this version
            (:data:`revolve_env.PHYSICS_REVISIONS`): its remaining births would live in other
            physics than its first ones.
    """
    engine = config.world.engine
    made, now = store.physics_revisions[engine], revolve_env.PHYSICS_REVISIONS[engine]
    if made != now:
        raise StoreError(
            f"{store.path}: made with {engine} physics revision {made}, and this version of "
            f"revolve-env steps {engine} as revision {now} (numbers differ), so its remaining "
            "births would live in other physics than its first; finish it with the version "
            "that made it, or run the experiment again")


def work_left(config: ExperimentConfig, runs: Sequence[RunRecord]) -> bool:
    """Whether an experiment has runs to do: unfinished, or never registered.

    A run killed between creating its database and registering its runs has none registered:
    that is work left (``resume`` registers and runs them), not a finished experiment.
    """
    return len(runs) < config.runs or any(r.status != "finished" for r in runs)


def pending_jobs(config: ExperimentConfig, db_path: Path, world_factory: WorldFactory | None,
                 infancy: InfancyHook | None) -> list[RunJob]:
    """Register every run of an experiment in its database and return the unfinished ones.

    Raises:
        EngineUnavailableError: the config's physics engine does not import.
    """
    # A missing engine package is an input error before anything runs (EngineUnavailableError).
    revolve_env.require_engine(config.world.engine)
    with Store.open(db_path) as store:
        # Registering is idempotent, so a run killed before all its runs were registered
        # resumes with every one of them.
        for run_id in range(config.runs):
            store.add_run(run_id, run_seed(config.seed, run_id))
        pending = [r.run_id for r in store.runs() if r.status != "finished"]
    return [RunJob(str(db_path), run_id, config, world_factory, infancy) for run_id in pending]


def _refuse_existing(out: Path, db_path: Path, config: ExperimentConfig) -> None:
    """Refuse to run into a folder that holds results, saying whose and what to do instead.

    Raises:
        StoreError: always; the message says whether the stored experiment is this one (then
            ``revolve resume`` continues it) or which settings differ.
    """
    try:
        with Store.open(db_path) as existing:
            stored = existing.config
    except StoreError as error:
        raise StoreError(
            f"{out} already holds a results database that cannot be used: {error}") from error
    name = stored.get("name", "?")
    try:  # compare settings, not text: a config stored by an older version lacks newer defaults
        differ = config_differences(ExperimentConfig.from_dict(stored), config)
    except ConfigError:
        differ = ["(the stored configuration is not valid for this version)"]
    if not differ:
        raise StoreError(
            f"{out} already holds results of this experiment ({name!r}); continue it with "
            f"`revolve resume {out}` (Python: evolution.resume({str(out)!r})), or choose another "
            "--out folder")
    raise StoreError(
        f"{out} holds results of experiment {name!r} with other settings "
        f"({'; '.join(differ[:4])}{'; ...' if len(differ) > 4 else ''}); refusing to overwrite "
        "them: choose another --out folder or --name")


def flat_keys(data: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested tables flattened to dotted keys (``evolution.max_parts``), as ``--set`` names them."""
    out: dict[str, Any] = {}
    for key, value in data.items():
        if isinstance(value, Mapping):
            out.update(flat_keys(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


def config_differences(stored: ExperimentConfig, wanted: ExperimentConfig) -> list[str]:
    """``key: stored vs wanted`` for every config value that differs (nested tables flattened)."""
    a, b = flat_keys(stored.to_dict()), flat_keys(wanted.to_dict())
    return [f"{k}: {a.get(k)!r} stored vs {b.get(k)!r}" for k in sorted(set(a) | set(b))
            if a.get(k) != b.get(k)]
