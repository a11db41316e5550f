"""The paper's study in one call: its five experiments, several runs each, in one folder.

``study(out_dir, runs=3, births=60)`` runs ``scenario1``, ``scenario2``, ``scenario3``,
``baseline_a`` and ``baseline_b`` (the shipped configs of
:mod:`~evolution.experiments.loop.registry`) with ``runs`` runs of ``births`` births each, and
writes each experiment as :func:`~evolution.experiments.app.api.run` would:
``out_dir/<name>/results.sqlite``. The same ``overrides`` (``--set KEY=VALUE`` of ``revolve run``)
and ``seed`` apply to every experiment; run ``i`` of every experiment uses ``SeedSequence([seed,
i])``, as ``revolve run NAME --seed``.

Parallel: the unfinished runs of *all* experiments are jobs of one evaluator
(:meth:`~evolution.evaluation.Evaluator.run_jobs`), so two cores run two runs at once whichever
experiment they belong to, and ``evaluator="ray"`` makes every run a Ray task on a local
instance or the cluster at ``ray_address``. Online runs (scenario 3) go first: one of them
simulates a whole world per birth and takes several times longer than an offline run.

Resumable: the study's settings (runs, births, seed, overrides) are stored in
``out_dir/study.json``. A second call with the same settings continues every unfinished run from
its last commit point and leaves finished experiments alone (the results are those of an
uninterrupted study); a call with other settings is refused, naming the differing setting, before
anything is written. A call may add experiments (``experiments=`` others, same settings): the
study then holds both. How the runs execute (``evaluator``, ``workers``, ``ray_address``) is no
setting of the study and may change between calls.

The figures and tables are one more call, ``evolution.report(out_dir)`` (``revolve study`` makes
it): this module sits below :mod:`evolution.reporting`.

Example::

    import evolution

    evolution.study("results/study", runs=3, births=60, overrides={"world": {"engine": "mujoco"}})
    evolution.report("results/study")      # figures and tables in results/study/report/
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from evolution.evaluation import Evaluator, make_evaluator
from evolution.experiments.app.api import (
    ExperimentSummary,
    check_resumable,
    config_differences,
    flat_keys,
    pending_jobs,
)
from evolution.experiments.loop.config import ConfigError, ExperimentConfig, check_name, load_config
from evolution.experiments.loop.registry import PAPER_SCENARIOS
from evolution.experiments.loop.run import (
    ProgressEvent,
    RunSummary,
    WorldFactory,
    check_infancy,
)
from evolution.experiments.store.database import DB_NAME, Store, StoreError
from evolution.experiments.store.folders import STUDY_FILE
from evolution.experiments.store.integrity import verify
from evolution.experiments.store.observer import RunJob, execute_run
from evolution.experiments.store.results_folder import inside, read_settings

__all__ = [
    "STUDY_FILE",
    "StudyEvent",
    "StudyExperiment",
    "StudyJob",
    "StudyPlan",
    "StudyProgress",
    "StudySummary",
    "execute_study_job",
    "prepare_study",
    "run_study",
    "study",
    "study_configs",
    "study_evaluator",
]


_STUDY_KEYS = ("runs", "births", "seed")
"""Settings given as arguments of :func:`study`, not as overrides."""
_EXECUTION_KEYS = ("workers", "evaluator", "ray_address")
"""Config keys that say how runs execute, not what they compute: free to change on resume."""

StudyProgress = Callable[[str, ProgressEvent], None]
"""Receives ``(experiment name, event)`` after every commit point of every run."""


@dataclass(frozen=True, slots=True)
class StudyExperiment:
    """One experiment of a study, ready to run.

    Attributes:
        name: Its name, the folder inside the study's folder.
        out_dir: Its results folder.
        config: Its configuration (as stored in its database).
        jobs: Its unfinished runs.
        done: Births already committed by each unfinished run, by run id.
    """

    name: str
    out_dir: Path
    config: ExperimentConfig
    jobs: tuple[RunJob, ...]
    done: Mapping[int, int]


@dataclass(frozen=True, slots=True)
class StudyPlan:
    """A study whose databases exist and whose runs are registered (:func:`prepare_study`).

    Attributes:
        out_dir: The study's folder.
        experiments: Its experiments, in the order given.
        evaluator: ``"local"`` or ``"ray"``: what :func:`run_study` makes by default.
        workers: Worker processes (0: all cores) or Ray CPUs of a local instance.
        ray_address: Ray cluster address (``None``: start or join a local instance).
    """

    out_dir: Path
    experiments: tuple[StudyExperiment, ...]
    evaluator: str = "local"
    workers: int = 0
    ray_address: str | None = None

    @property
    def pending(self) -> int:
        """Unfinished runs, all experiments together."""
        return sum(len(e.jobs) for e in self.experiments)


@dataclass(frozen=True, slots=True)
class StudySummary:
    """How a study's call ended.

    Attributes:
        out_dir: The study's folder (``evolution.report(out_dir)`` draws it).
        experiments: One summary per experiment, with the runs this call executed.
        wall_time: Seconds this call ran its runs. Seconds.
    """

    out_dir: Path
    experiments: tuple[ExperimentSummary, ...]
    wall_time: float


@dataclass(frozen=True, slots=True)
class StudyJob:
    """One run of a study's experiment: what an evaluator's worker executes."""

    experiment: str
    run: RunJob

    @contextmanager
    def for_remote_worker(self) -> Iterator[StudyJob]:
        """This job for a Ray worker on any node: the database stays on this one.

        See :meth:`evolution.experiments.RunJob.for_remote_worker`.
        """
        with self.run.for_remote_worker() as run:
            yield replace(self, run=run)


@dataclass(frozen=True, slots=True)
class StudyEvent:
    """A run's progress event, with the experiment it belongs to."""

    experiment: str
    event: ProgressEvent


def execute_study_job(job: StudyJob, evaluator: Evaluator,
                      emit: Callable[[StudyEvent], None]) -> RunSummary:
    """One run of a study (:func:`~evolution.experiments.execute_run`), events tagged.

    Its progress events reach ``emit`` as :class:`StudyEvent` with the experiment's name.
    """
    return execute_run(job.run, evaluator, lambda event: emit(StudyEvent(job.experiment, event)))


def study(
    out_dir: str | os.PathLike[str],
    *,
    runs: int = 3,
    births: int = 60,
    experiments: Sequence[str] = PAPER_SCENARIOS,
    overrides: Mapping[str, Any] | None = None,
    seed: int = 0,
    evaluator: str | Evaluator = "local",
    workers: int = 0,
    ray_address: str | None = None,
    progress: StudyProgress | None = None,
    world_factory: WorldFactory | None = None,
    trust_task_code: bool = False,
) -> StudySummary:
    """Run (or continue) the paper's study into ``out_dir`` (see the module docs).

    Args:
        out_dir: The study's folder; each experiment goes to ``out_dir/<name>/``.
        runs: Runs per experiment.
        births: Births per run (the initial robots count).
        experiments: Shipped config names (or TOML paths) of the experiments.
        overrides: Config keys changed in every experiment, as for ``load_config`` (nested
            ``evolution``, ``world``, ``learning`` tables); not ``runs``, ``births``, ``seed``,
            ``name`` or the execution keys, which are arguments here.
        seed: Experiment seed of every experiment.
        evaluator: ``"local"`` processes, ``"ray"``, or an evaluator object (kept open).
        workers: Worker processes, 0: all cores (Ray: CPUs of a local instance).
        ray_address: Ray cluster address (``None``: start or join a local instance).
        progress: Called with ``(experiment, event)`` after every commit point of every run
            (raising from it stops the runs after that commit point; a second call continues).
        world_factory: Makes the online world of a run (default: the population environment).
        trust_task_code: Continue an experiment already in ``out_dir`` whose stored ``[task]``
            names a class of the user's own (its module is imported, which runs its code: only
            for a folder whose author you trust). A new experiment needs no trust: its settings
            are the caller's.

    Returns:
        What this call ran, per experiment.

    Raises:
        ConfigError: an unknown experiment, a bad override or setting.
        StoreError: ``out_dir`` holds a study or an experiment with other settings, or a
            damaged database, or one whose stored task class is not trusted.
        KeyboardInterrupt: Ctrl-C; what was committed stays, the same call continues.
    """
    kind = evaluator if isinstance(evaluator, str) else "local"
    plan = prepare_study(out_dir, runs=runs, births=births, experiments=experiments,
                         overrides=overrides, seed=seed, evaluator=kind, workers=workers,
                         ray_address=ray_address, world_factory=world_factory,
                         trust_task_code=trust_task_code)
    return run_study(plan, progress, None if isinstance(evaluator, str) else evaluator)


def study_configs(
    *,
    runs: int = 3,
    births: int = 60,
    experiments: Sequence[str] = PAPER_SCENARIOS,
    overrides: Mapping[str, Any] | None = None,
    seed: int = 0,
    evaluator: str = "local",
    workers: int = 0,
    ray_address: str | None = None,
) -> list[ExperimentConfig]:
    """The configurations a study of these settings runs, checked; nothing is read or written.

    Arguments as for :func:`study` (what ``revolve study --estimate-only`` estimates).

    Raises:
        ConfigError: an unknown experiment, a bad override or setting.
    """
    execution = {"evaluator": evaluator, "workers": workers, "ray_address": ray_address}
    return _configs(experiments, _settings(runs, births, seed, overrides), execution)


def prepare_study(
    out_dir: str | os.PathLike[str],
    *,
    runs: int = 3,
    births: int = 60,
    experiments: Sequence[str] = PAPER_SCENARIOS,
    overrides: Mapping[str, Any] | None = None,
    seed: int = 0,
    evaluator: str = "local",
    workers: int = 0,
    ray_address: str | None = None,
    world_factory: WorldFactory | None = None,
    trust_task_code: bool = False,
) -> StudyPlan:
    """Check the study's settings against ``out_dir``, create what is missing, list what is left.

    Every setting and every existing database is checked before anything is written; the
    settings are compared as stored, without importing anything they name. Arguments as for
    :func:`study`.

    Raises:
        ConfigError: an unknown experiment, a bad override or setting.
        StoreError: ``out_dir`` holds a study or an experiment with other settings, or a
            damaged or read-only database, or one whose stored task class is a class of the
            user's own and ``trust_task_code`` is false.
    """
    out = Path(out_dir)
    settings = _settings(runs, births, seed, overrides)
    execution = {"evaluator": evaluator, "workers": workers, "ray_address": ray_address}
    configs = _configs(experiments, settings, execution)
    names = _check_study_file(out, settings, [c.name for c in configs])
    existing = {c.name: _check_existing(out, c, trust_task_code) for c in configs
                if os.path.lexists(out / c.name / DB_NAME)
                and not Store.is_empty(out / c.name / DB_NAME)}  # an empty one is replaced
    out.mkdir(parents=True, exist_ok=True)
    _write_json(out / STUDY_FILE, {**settings, "experiments": names})
    planned = []
    for config in configs:
        folder = out / config.name
        if config.name not in existing:
            Store.create(folder / DB_NAME, config.to_dict(), config.seed).close()
        stored = existing.get(config.name, config)
        infancy = stored.training_center()
        check_infancy(infancy)
        jobs = pending_jobs(stored, folder / DB_NAME, world_factory, infancy)
        with Store.open(folder / DB_NAME) as store:
            done = {r.run_id: r.births for r in store.runs()}
        planned.append(StudyExperiment(config.name, folder, stored, tuple(jobs),
                                       {j.run_id: done[j.run_id] for j in jobs}))
    return StudyPlan(out, tuple(planned), evaluator, workers, ray_address)


def study_evaluator(evaluator: str = "local", workers: int = 0,
                    ray_address: str | None = None) -> Evaluator:
    """Where a study's runs execute (:func:`run_study`'s default; close it after use).

    Its ``workers`` are the runs at once (a Ray cluster: its CPUs), which the study's time
    estimate (:mod:`evolution.experiments.app.estimate`) needs before the runs start.
    """
    return make_evaluator(evaluator, workers, ray_address)


def run_study(plan: StudyPlan, progress: StudyProgress | None = None,
              evaluator: Evaluator | None = None) -> StudySummary:
    """Execute every unfinished run of a prepared study on one evaluator.

    Args:
        plan: What :func:`prepare_study` returned.
        progress: Called with ``(experiment, event)`` after every commit point of every run.
        evaluator: Where the runs execute; default the plan's (made here and closed at the end).

    Raises:
        KeyboardInterrupt: Ctrl-C; what was committed stays.
    """
    # Longest first: an online run simulates a whole world per birth.
    order = sorted(plan.experiments, key=lambda e: e.config.mode != "online")
    jobs = [StudyJob(e.name, job) for e in order for job in e.jobs]
    started = time.perf_counter()
    summaries: list[RunSummary] = []
    if jobs:
        used = evaluator or study_evaluator(plan.evaluator, plan.workers, plan.ray_address)
        on_event = None if progress is None else (
            lambda tagged: progress(tagged.experiment, tagged.event))
        try:
            summaries = used.run_jobs(execute_study_job, jobs, on_event)
        finally:
            if evaluator is None:
                used.close()
    wall = time.perf_counter() - started
    by_name: dict[str, list[RunSummary]] = {e.name: [] for e in plan.experiments}
    for job, summary in zip(jobs, summaries, strict=True):
        by_name[job.experiment].append(summary)
    return StudySummary(plan.out_dir, tuple(
        ExperimentSummary(e.out_dir, e.out_dir / DB_NAME,
                          tuple(sorted(by_name[e.name], key=lambda r: r.run_id)))
        for e in plan.experiments), wall)


# -- settings ---------------------------------------------------------------------------------


def _settings(runs: int, births: int, seed: int,
              overrides: Mapping[str, Any] | None) -> dict[str, Any]:
    """The study's settings as plain JSON data (what ``study.json`` holds).

    Raises:
        ConfigError: a setting given as an override, or overrides that are not plain data.
    """
    data = dict(overrides or {})
    reserved = sorted(set(data) & {*_STUDY_KEYS, *_EXECUTION_KEYS, "name"})
    if reserved:
        key = reserved[0]
        hint = ("each experiment keeps its own name" if key == "name"
                else f"give it as {key}= (revolve study --{key.replace('_', '-')})")
        raise ConfigError(f"{key} is a setting of the study, not an override: {hint}")
    try:
        data = json.loads(json.dumps(data, sort_keys=True))
    except (TypeError, ValueError) as error:
        raise ConfigError(f"study overrides must be plain data: {error}") from None
    return {"runs": runs, "births": births, "seed": seed, "overrides": data}


def _configs(experiments: Sequence[str], settings: Mapping[str, Any],
             execution: Mapping[str, Any]) -> list[ExperimentConfig]:
    """Every experiment's configuration, checked, names unique.

    Raises:
        ConfigError: no experiment, an unknown one, a repeated name, or a bad value (named with
            its experiment).
    """
    if isinstance(experiments, str) or not experiments:
        raise ConfigError("a study needs a list of one or more experiments, e.g. "
                          f"{', '.join(PAPER_SCENARIOS)}")
    configs: list[ExperimentConfig] = []
    for name in experiments:
        changes = {**settings["overrides"], **execution,
                   **{k: settings[k] for k in _STUDY_KEYS}}
        try:
            config = load_config(name, changes)
        except ConfigError as error:  # name the experiment, unless the error does
            text = str(error)
            raise ConfigError(text if str(name) in text else f"{name}: {text}") from None
        if any(c.name == config.name for c in configs):
            raise ConfigError(f"experiment {config.name!r} is given twice")
        configs.append(config)
    return configs


def _check_study_file(out: Path, settings: Mapping[str, Any], names: list[str]) -> list[str]:
    """The study's experiments after this call (stored ones first).

    Raises:
        StoreError: ``out`` holds a study with other settings (named), or an unreadable
            ``study.json``.
    """
    path = out / STUDY_FILE
    if not os.path.lexists(path):
        return names
    try:
        stored = read_settings(out, STUDY_FILE)
        known = [check_name(n, "experiment name") for n in stored["experiments"]]
        differ = [f"{k}: {stored[k]!r} stored, {settings[k]!r} now" for k in _STUDY_KEYS
                  if stored[k] != settings[k]]
        differ += _flat_differences(stored["overrides"], settings["overrides"])
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise StoreError(f"{path} is not a study's settings file ({error!r}); choose another "
                         "folder") from None
    if differ:
        raise StoreError(
            f"{out} holds a study with other settings ({'; '.join(differ[:4])}"
            f"{'; ...' if len(differ) > 4 else ''}); give the same settings to continue it, or "
            "choose another folder")
    return known + [n for n in names if n not in known]


def _check_existing(out: Path, config: ExperimentConfig, trust_task_code: bool
                    ) -> ExperimentConfig:
    """The stored configuration of an experiment already in the study, if it is this one.

    The settings are compared as stored (a task class of the user's own by its name, nothing
    imported); only then is the database checked for continuing, which imports such a class
    only when trusted.

    Raises:
        StoreError: a damaged or read-only database, one of other settings (named), a folder
            that is a symbolic link, or a stored task class of the user's own not trusted.
    """
    folder = inside(out, config.name, "experiment folder")
    with Store.open(folder / DB_NAME) as store:
        stored = verify(store)
    how = {k: getattr(config, k) for k in _EXECUTION_KEYS}
    differ = config_differences(stored.replace(**how), config)
    if differ:
        raise StoreError(
            f"{folder} holds results of {stored.name!r} with other settings "
            f"({'; '.join(differ[:4])}{'; ...' if len(differ) > 4 else ''}); refusing to "
            "change them: give the settings it was made with, or choose another folder")
    return check_resumable(folder / DB_NAME, trust_task_code=trust_task_code)


def _flat_differences(stored: Mapping[str, Any], wanted: Mapping[str, Any]) -> list[str]:
    """``--set key: stored, now`` for every differing override (nested tables flattened)."""
    a, b = flat_keys(stored), flat_keys(wanted)
    return [f"--set {k}: {_shown(a, k)} stored, {_shown(b, k)} now" for k in sorted(set(a) | set(b))
            if a.get(k, _UNSET) != b.get(k, _UNSET)]


_UNSET = object()


def _shown(data: Mapping[str, Any], key: str) -> str:
    return repr(data[key]) if key in data else "not set"


def _write_json(path: Path, data: Mapping[str, Any]) -> None:
    """Write JSON atomically (a killed call leaves the old file or the new one)."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.unlink(missing_ok=True)  # a link planted there is replaced, never followed
    tmp.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    tmp.replace(path)
