"""Stored experiments read back for reporting: runs, populations, fitness and diversity series.

Births. A birth is a robot conceived and delivered whose life produced a fitness or is still
going: a robot lost before its first fitness (a blow-up during its isolated evaluation or
before its first sample in the shared world, a body the engine could not build, a non-finite
fitness: the failure kinds of :data:`FAILED_BIRTH_KINDS`) is a *failed birth*. The engines count
failed births in their births counter (an offline generation 0 with two blow-ups ends at 17);
the report's axes do not: every births axis counts births as defined here (so generation 0 ends
at 15 and the next at 30 in scenario 1), and failed births are counted apart
(:attr:`RunData.failed_births`, the ``failed_births`` column). Robots lost after they had a
fitness (online blow-ups of living robots) stay births; every lost robot, failed births
included, is in :attr:`RunData.lost_ids` (the ``lost_robots`` column and figure). A lost robot
is recognised by its failure record, so databases written before lost robots were stored
without fitness (online blow-ups kept 0.0) report the same.

Budgets. A run's budget counts births as its engine does (``births`` of the config, failed
births included: a run that lost a robot still reached its budget). The tests compare runs at
equal *engine* births (:attr:`RunData.engine_births`, :meth:`ExperimentData.populations_at`):
each run's population at the last commit point at or before them.

Which experiments: :func:`load_included` takes one set of experiments below a folder (a study,
or the experiments outside any study; :mod:`evolution.experiments.store.folders`) and says what it
left out.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from evolution.diversity import brain_aware_diversity, diversity
from evolution.experiments.loop.registry import PAPER_SCENARIOS
from evolution.experiments.store.database import DB_NAME, FitnessSeries, RunRecord, Store
from evolution.experiments.store.folders import ResultSet, select_results
from evolution.experiments.store.integrity import verify
from evolution.experiments.store.schema import PopulationSnapshot
from revolve_env.body.robot import Robot
from revolve_env.body.serialize import from_json

__all__ = [
    "FAILED_BIRTH_KINDS",
    "LABELS",
    "ExperimentData",
    "Included",
    "PopulationAt",
    "RunData",
    "find_experiments",
    "births_axis",
    "common_births",
    "load_experiment",
    "load_included",
    "runs_on_grid",
    "step_on_grid",
]

LABELS: dict[str, str] = {
    "scenario1": "Scenario 1 (15+15)",
    "scenario2": "Scenario 2 (15+1)",
    "scenario3": "Scenario 3 (online)",
    "baseline_a": "Baseline A (random robots)",
    "baseline_b": "Baseline B (random survivors)",
}
"""Readable labels of the paper's experiments in figures and tables (others show their name)."""

FAILED_BIRTH_KINDS = ("evaluation", "blow-up", "birth")
"""Failure kinds that lose a robot: a failed evaluation offline (blow-up or non-finite fitness),
a blow-up in the shared world, a body the world could not build."""


def births_axis(engine_births: NDArray[Any], failed_ids: NDArray[Any]) -> NDArray[np.int64]:
    """Births as the report counts them, from the engine's counter and the failed births' ids.

    Robot ids are given in birth order from 0, so the engine's count ``b`` covers ids ``< b``;
    the failed births among them are taken off.
    """
    b = np.asarray(engine_births, dtype=np.int64)
    failed = np.sort(np.asarray(failed_ids, dtype=np.int64))
    return b - np.searchsorted(failed, b, side="left").astype(np.int64)

@dataclass(frozen=True, slots=True)
class PopulationAt:
    """One run's population at the last commit point at or before some engine births.

    Attributes:
        births: The engine's births at that commit point (failed births included).
        fitness: Finite fitness values of its members. Metres.
        diversity: Its body diversity (``nan`` with fewer than 2 robots).
        brain_diversity: Its brain-aware diversity (``nan`` unless asked for).
    """

    births: int
    fitness: NDArray[np.float64]
    diversity: float
    brain_diversity: float = math.nan


@dataclass(frozen=True, slots=True)
class RunData:
    """What a report needs from one run.

    Attributes:
        run_id: Repeat index.
        status: ``pending``, ``running``, ``interrupted`` or ``finished``.
        births: Births committed.
        fitness: Population fitness after each commit point.
        diversity_births: Births at which diversity was measured.
        diversity: Diversity at those births (mean pairwise tree edit distance).
        final_fitness: Finite fitness values of the last population snapshot. Metres.
        final_diversity: Diversity of the last population (``nan`` with fewer than 2 robots).
        inborn_fitness: Each infant's inborn-controller fitness as its learner measured it
            (learning records with a finite value). Metres.
        learned_fitness: Each infant's learned-controller fitness as its learner measured it
            (same records, same order). Metres.
        learner_failures: Infancies whose learner failed (the infant kept its inborn brain).
        failed_births: Ids of the robots lost before their first fitness (not births).
        lost_ids: Ids of every robot lost to a failure of :data:`FAILED_BIRTH_KINDS`, failed
            births and robots lost later in life together.
        brain_diversity: Brain-aware diversity at ``diversity_births`` (empty unless asked
            for; see :func:`evolution.diversity.brain_aware_diversity`).
        final_brain_diversity: Brain-aware diversity of the last population (``nan`` unless
            asked for or with fewer than 2 robots).
        engine_births: Births as the engine counts them (failed births included): what the
            run's budget counts.
        commit_births: The engine's births at each commit point (parallel to ``fitness``).
        at: Populations at engine births below ``engine_births`` that a report compares
            (filled by :func:`load_included`; see :meth:`population_at`).
        shaking: Every robot's shaking measure (its last fitness sample that has one: the
            path at every control period over the path at the pose rate,
            :func:`revolve_env.fitness.sampling.shaking`); robots without one left out.
        shaking_fitness: Those robots' fitness (same order). Metres.

    ``births``, ``fitness.births`` and ``diversity_births`` count births as the module
    docstring defines them (failed births left out).
    """

    run_id: int
    status: str
    births: int
    fitness: FitnessSeries
    diversity_births: NDArray[np.int64]
    diversity: NDArray[np.float64]
    final_fitness: NDArray[np.float64]
    final_diversity: float
    inborn_fitness: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    learned_fitness: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    learner_failures: int = 0
    failed_births: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64))
    lost_ids: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64))
    brain_diversity: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    final_brain_diversity: float = math.nan
    engine_births: int = 0
    commit_births: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64))
    at: Mapping[int, PopulationAt] = field(default_factory=dict)
    shaking: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    shaking_fitness: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))

    @property
    def lost_robots(self) -> int:
        """Robots lost to a failure, failed births included."""
        return int(self.lost_ids.size)

    def lost_before(self, births: int) -> int:
        """Robots lost among the run's first ``births`` births (engine count: robot ids)."""
        return int(np.sum(self.lost_ids < births))

    def population_at(self, births: int) -> PopulationAt:
        """The population at the last commit point at or before ``births`` engine births.

        The final population from ``engine_births`` on.

        Raises:
            KeyError: ``births`` was not prepared (:func:`load_included` prepares the births a
                report compares).
        """
        if births >= self.engine_births:
            return PopulationAt(self.engine_births, self.final_fitness, self.final_diversity,
                                self.final_brain_diversity)
        return self.at[births]

    def lost_over_births(self) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """Cumulative lost robots (y) against the report's births (x) at each robot's birth."""
        ids = np.sort(self.lost_ids)
        return births_axis(ids, self.failed_births), np.arange(1, ids.size + 1, dtype=np.int64)


@dataclass(frozen=True, slots=True)
class ExperimentData:
    """One experiment (one results database) as read for a report.

    Attributes:
        label: Name shown in figures and tables (the config's name; made unique with the path).
        path: The results directory (holding ``results.sqlite``).
        config: The stored experiment configuration.
        runs: Runs with at least one commit point, by id.
        registered_runs: Runs in the database (including those that never committed).
        study: The study folder it belongs to (``None``: outside any study).
    """

    label: str
    path: Path
    config: dict[str, Any]
    runs: tuple[RunData, ...]
    registered_runs: int = 0
    study: Path | None = None

    @property
    def budget(self) -> int:
        """Births per run the configuration asked for (engine count)."""
        return int(self.config.get("births", 0))

    @property
    def reached(self) -> int:
        """The fewest engine births a run reached (0 without runs): what every run reached."""
        return min((r.engine_births for r in self.runs), default=0)

    def populations_at(self, births: int) -> list[PopulationAt]:
        """Every run's population at ``births`` engine births (:meth:`RunData.population_at`)."""
        return [r.population_at(births) for r in self.runs]

    def lost_before(self, births: int) -> int:
        """Robots lost among the first ``births`` births of its runs, all runs together."""
        return sum(r.lost_before(births) for r in self.runs)

    @property
    def name(self) -> str:
        """The configuration's name."""
        return str(self.config.get("name", self.path.name))

    @property
    def title(self) -> str:
        """Readable label: :data:`LABELS` for the paper's five, else the label.

        A paper label gets the path label appended when two experiments share a name.
        """
        readable = LABELS.get(self.name)
        if readable is None:
            return self.label
        return readable if self.label == self.name else f"{readable} [{self.label}]"

    @property
    def online(self) -> bool:
        """True for online evolution (fitness is a sliding window in the shared world)."""
        return self.config.get("mode") == "online"

    def final_fitness(self) -> NDArray[np.float64]:
        """Fitness of every robot of every run's final population, pooled. Metres."""
        parts = [r.final_fitness for r in self.runs]
        return np.concatenate(parts) if parts else np.zeros(0)

    def final_run_means(self) -> NDArray[np.float64]:
        """Mean final-population fitness of each run (runs without fitness left out). Metres."""
        return np.array([r.final_fitness.mean() for r in self.runs if r.final_fitness.size])

    def final_diversities(self) -> NDArray[np.float64]:
        """Final-population diversity of each run (undefined ones left out)."""
        values = np.array([r.final_diversity for r in self.runs], dtype=np.float64)
        return values[np.isfinite(values)]

    def final_bests(self) -> NDArray[np.float64]:
        """Best fitness of each run's final population (runs without fitness left out). Metres."""
        return np.array([r.final_fitness.max() for r in self.runs if r.final_fitness.size])

    def final_brain_diversities(self) -> NDArray[np.float64]:
        """Final-population brain-aware diversity of each run (undefined ones left out)."""
        values = np.array([r.final_brain_diversity for r in self.runs], dtype=np.float64)
        return values[np.isfinite(values)]

    @property
    def learns(self) -> bool:
        """True when the experiment has infancy learning (a learning table, records or failures)."""
        return self.config.get("learning") is not None or any(
            r.inborn_fitness.size or r.learner_failures for r in self.runs)

    def shaking(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Every measured robot's shaking and fitness, all runs pooled (:attr:`RunData.shaking`)."""
        shaking = [r.shaking for r in self.runs]
        fitness = [r.shaking_fitness for r in self.runs]
        return (np.concatenate(shaking) if shaking else np.zeros(0),
                np.concatenate(fitness) if fitness else np.zeros(0))

    def learning_fitness(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Inborn and learned fitness of every infant of every run, pooled and paired. Metres."""
        inborn = [r.inborn_fitness for r in self.runs]
        learned = [r.learned_fitness for r in self.runs]
        return (np.concatenate(inborn) if inborn else np.zeros(0),
                np.concatenate(learned) if learned else np.zeros(0))


# --------------------------------------------------------------------------------------------
# Reading


def _robots(store: Store, run_id: int, members: Sequence[int]) -> list[Robot]:
    # Stored genomes were validated when they were born; the overlap check is the slow part.
    return [from_json(r.genome, check=False) for r in store.robots(run_id, list(members))]


def _final_diversity(store: Store, run_id: int, members: Sequence[int]) -> float:
    if len(members) < 2:
        return math.nan
    return float(diversity(_robots(store, run_id, members)))


def _lost(store: Store, run_id: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Ids of the robots lost before their first fitness, and of every lost robot.

    A lost robot has a failure record of :data:`FAILED_BIRTH_KINDS`; it is a failed birth when
    it never had a fitness sample (its stored fitness says nothing: older databases kept 0.0
    for robots lost in the shared world).
    """
    lost = sorted({f.robot_id for f in store.failures(run_id)
                   if f.kind in FAILED_BIRTH_KINDS and f.robot_id is not None})
    failed = [i for i in lost if not store.fitness_samples(run_id, i)]
    return np.array(failed, dtype=np.int64), np.array(lost, dtype=np.int64)


def _brain_diversity(store: Store, run_id: int, engine_births: NDArray[np.int64]
                     ) -> tuple[NDArray[np.float64], float]:
    """Brain-aware diversity of the stored populations at ``engine_births``, and of the last."""
    snapshots = {b: [rid for rid, _ in members]
                 for b, _, members in store.population_snapshots(run_id)}

    def of(members: Sequence[int]) -> float:
        if len(members) < 2:
            return math.nan
        return brain_aware_diversity(_robots(store, run_id, members))

    series = np.array([of(snapshots.get(int(b), [])) for b in engine_births], dtype=float)
    final = of(snapshots[max(snapshots)]) if snapshots else math.nan
    return series, final


def _load_run(store: Store, record: RunRecord, brain_aware: bool) -> RunData | None:
    """One run read back, births counted as the module docstring says.

    ``None`` for a run that never reached its first commit point (nothing to show).
    """
    run_id = record.run_id
    series = store.fitness_over_births(run_id)
    if series.births.size == 0:
        return None
    failed, lost = _lost(store, run_id)
    final = store.final_population(run_id)
    final_fitness = np.array(
        [f for _, f in final if f is not None and math.isfinite(f)], dtype=float)
    points = store.diversity_over_births(run_id)
    engine_births = np.array([p.births for p in points], dtype=np.int64)
    pairs = [(x.inborn_fitness, x.learned_fitness) for x in store.learning(run_id)
             if x.inborn_fitness is not None and x.learned_fitness is not None
             and math.isfinite(x.inborn_fitness) and math.isfinite(x.learned_fitness)]
    brain, final_brain = (_brain_diversity(store, run_id, engine_births) if brain_aware
                          else (np.zeros(0), math.nan))
    last: dict[int, tuple[float, float]] = {}  # robot -> its last (shaking, fitness)
    for sample in store.fitness_samples(run_id):
        if sample.shaking is not None and not math.isnan(sample.shaking):
            last[sample.robot_id] = (sample.shaking, sample.fitness)
    shaking = np.array(list(last.values()), dtype=float).reshape(-1, 2)
    return RunData(
        run_id, record.status, int(births_axis(np.array([record.births]), failed)[0]),
        replace(series, births=births_axis(series.births, failed)),
        births_axis(engine_births, failed),
        np.array([p.value for p in points], dtype=float),
        final_fitness,
        _final_diversity(store, run_id, [rid for rid, _ in final]),
        np.array([a for a, _ in pairs], dtype=float),
        np.array([b for _, b in pairs], dtype=float),
        len(store.failures(run_id, "learner")),
        failed, lost, brain, final_brain, record.births, series.births,
        shaking=shaking[:, 0].copy(), shaking_fitness=shaking[:, 1].copy(),
    )


def load_experiment(path: str | os.PathLike[str], label: str | None = None,
                    brain_aware: bool = False) -> ExperimentData:
    """Read one experiment from a results directory (or its ``results.sqlite``).

    Args:
        path: The results directory or database.
        label: Its label; default the configuration's name.
        brain_aware: Also compute the brain-aware diversity of the stored populations at each
            diversity point (slower: every stored genome of those populations is decoded).

    Raises:
        StoreError: no usable database there (missing, corrupt, newer schema).
    """
    path = Path(path)
    db = path if path.name == DB_NAME else path / DB_NAME
    with Store.open(db) as store:
        verify(store)
        config = store.config
        records = store.runs()
        loaded = [_load_run(store, record, brain_aware) for record in records]
    runs = tuple(r for r in loaded if r is not None)
    name = str(config.get("name", db.parent.name))
    return ExperimentData(label or name, db.parent, config, runs, len(records))


def _order_key(experiment: ExperimentData) -> tuple[int, str]:
    name = experiment.name
    rank = PAPER_SCENARIOS.index(name) if name in PAPER_SCENARIOS else len(PAPER_SCENARIOS)
    return rank, experiment.label


@dataclass(frozen=True, slots=True)
class Included:
    """The experiments a report compares, and what it left out.

    Attributes:
        root: The folder (or database) given.
        experiments: The experiments, in report order (:func:`find_experiments`).
        left_out: Sets of experiments below ``root`` not included
            (:func:`evolution.experiments.store.folders.select_results`).
    """

    root: Path
    experiments: tuple[ExperimentData, ...]
    left_out: tuple[ResultSet, ...] = ()

    @property
    def budgets_differ(self) -> bool:
        """True when the experiments' runs did not all reach the same engine births."""
        return len({r.engine_births for e in self.experiments for r in e.runs}) > 1

    @property
    def common_births(self) -> int:
        """The most engine births every run of every experiment reached."""
        return common_births(self.experiments)


def common_births(experiments: Sequence[ExperimentData]) -> int:
    """The most engine births every run of every experiment reached (0 without runs)."""
    return min((e.reached for e in experiments if e.runs), default=0)


def load_included(root: str | os.PathLike[str], brain_aware: bool = False,
                  every_set: bool = False) -> Included:
    """Every experiment of one set at or below ``root``, ready to compare like with like.

    The set is :func:`evolution.experiments.store.folders.select_results`'s (every set with
    ``every_set``). Labels are the experiments' names; where two databases share a name, their
    paths relative to ``root`` are used instead. Each run's population is read at every engine
    births a pair of experiments is compared at (the fewest either reached), so
    :meth:`ExperimentData.populations_at` answers for them. ``brain_aware`` is passed to
    :func:`load_experiment`.

    Raises:
        StoreError: ``root`` is missing, holds no results database, holds several studies and
            nothing else (without ``every_set``), or one database is unusable (named).
    """
    root = Path(root)
    selection = select_results(root, every_set)
    experiments = [replace(load_experiment(p, brain_aware=brain_aware),
                           study=selection.study_of(p)) for p in selection.databases]
    counts: dict[str, int] = {}
    for e in experiments:
        counts[e.label] = counts.get(e.label, 0) + 1
    base = root if root.is_dir() else root.parent
    relabelled = []
    for e in experiments:
        if counts[e.label] > 1:
            relative = e.path.relative_to(base).as_posix() if e.path != base else e.path.name
            e = replace(e, label=relative or e.label)
        relabelled.append(e)
    reached = {e.reached for e in relabelled if e.runs}
    prepared = [_with_populations_at(e, reached, brain_aware) for e in relabelled]
    return Included(root, tuple(sorted(prepared, key=_order_key)), selection.left_out)


def find_experiments(root: str | os.PathLike[str], brain_aware: bool = False,
                     every_set: bool = False) -> list[ExperimentData]:
    """The experiments of :func:`load_included`, in report order (the paper's five first)."""
    return list(load_included(root, brain_aware, every_set).experiments)


def _with_populations_at(e: ExperimentData, births: set[int], brain_aware: bool
                         ) -> ExperimentData:
    """``e`` with each run's population at every ``births`` below the run's own end."""
    wanted = {r.run_id: sorted(b for b in births if b < r.engine_births) for r in e.runs}
    if not any(wanted.values()):
        return e
    runs = []
    with Store.open(e.path / DB_NAME) as store:
        for r in e.runs:
            snapshots = store.population_snapshots(r.run_id) if wanted[r.run_id] else []
            at = {b: _population(store, r.run_id, snapshots, b, brain_aware)
                  for b in wanted[r.run_id]}
            runs.append(replace(r, at=at))
    return replace(e, runs=tuple(runs))


def _population(store: Store, run_id: int, snapshots: Sequence[PopulationSnapshot],
                births: int, brain_aware: bool) -> PopulationAt:
    """The population of the last snapshot at or before ``births`` engine births."""
    before = [snap for snap in snapshots if snap[0] <= births]
    if not before:  # not committed yet: nothing to compare
        return PopulationAt(births, np.zeros(0), math.nan, math.nan)
    at, _, members = before[-1]
    ids = [rid for rid, _ in members]
    fitness = np.array([f for _, f in members if f is not None and math.isfinite(f)],
                       dtype=float)
    robots = _robots(store, run_id, ids) if len(ids) >= 2 else []
    return PopulationAt(
        int(at), fitness, float(diversity(robots)) if robots else math.nan,
        brain_aware_diversity(robots) if robots and brain_aware else math.nan)


# --------------------------------------------------------------------------------------------
# Statistics


def step_on_grid(x: NDArray[Any], y: NDArray[Any], grid: NDArray[Any]) -> NDArray[np.float64]:
    """The step function through ``(x, y)`` (value of the last ``x <= g``) on ``grid``.

    ``nan`` before the first ``x`` and after the last one: a run says nothing about births it
    has not reached.
    """
    x = np.asarray(x)
    y = np.asarray(y, dtype=float)
    grid = np.asarray(grid)
    out = np.full(grid.shape, np.nan)
    if x.size == 0:
        return out
    index = np.searchsorted(x, grid, side="right") - 1
    inside = (index >= 0) & (grid <= x[-1])
    out[inside] = y[index[inside]]
    return out


def runs_on_grid(
    xs: Sequence[NDArray[Any]], ys: Sequence[NDArray[Any]]
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Several runs' step series on the union of their x values: ``(grid, values[run, grid])``."""
    grid = np.unique(np.concatenate([np.asarray(x) for x in xs])) if xs else np.zeros(0, np.int64)
    steps = [step_on_grid(x, y, grid) for x, y in zip(xs, ys, strict=True)]
    values = np.array(steps).reshape(len(xs), -1)
    return grid.astype(np.int64), values


