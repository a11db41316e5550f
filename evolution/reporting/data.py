"""Stored experiments read back for reporting: runs, populations, fitness and diversity series."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from evolution.diversity import diversity
from evolution.experiments.integrity import verify
from evolution.experiments.store import DB_NAME, FitnessSeries, Store, StoreError
from revolve_env.body.serialize import from_json

__all__ = [
    "PAPER_ORDER",
    "ExperimentData",
    "RunData",
    "find_experiments",
    "load_experiment",
    "runs_on_grid",
    "step_on_grid",
]

PAPER_ORDER = ("scenario1", "scenario2", "scenario3", "baseline_a", "baseline_b")
"""Experiments named like this are listed in this order, the others after them by name."""

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


@dataclass(frozen=True, slots=True)
class ExperimentData:
    """One experiment (one results database) as read for a report.

    Attributes:
        label: Name shown in figures and tables (the config's name; made unique with the path).
        path: The results directory (holding ``results.sqlite``).
        config: The stored experiment configuration.
        runs: Runs with at least one commit point, by id.
        registered_runs: Runs in the database (including those that never committed).
    """

    label: str
    path: Path
    config: dict[str, Any]
    runs: tuple[RunData, ...]
    registered_runs: int = 0

    @property
    def name(self) -> str:
        """The configuration's name."""
        return str(self.config.get("name", self.path.name))

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

    @property
    def learns(self) -> bool:
        """True when the experiment has infancy learning (a learning table, records or failures)."""
        return self.config.get("learning") is not None or any(
            r.inborn_fitness.size or r.learner_failures for r in self.runs)

    def learning_fitness(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Inborn and learned fitness of every infant of every run, pooled and paired. Metres."""
        inborn = [r.inborn_fitness for r in self.runs]
        learned = [r.learned_fitness for r in self.runs]
        return (np.concatenate(inborn) if inborn else np.zeros(0),
                np.concatenate(learned) if learned else np.zeros(0))


# --------------------------------------------------------------------------------------------
# Reading


def _final_diversity(store: Store, run_id: int, members: Sequence[int]) -> float:

    if len(members) < 2:
        return math.nan
    # Stored genomes were validated when they were born; the overlap check is the slow part.
    robots = [from_json(r.genome, check=False) for r in store.robots(run_id, list(members))]
    return float(diversity(robots))


def load_experiment(path: str | os.PathLike[str], label: str | None = None) -> ExperimentData:
    """Read one experiment from a results directory (or its ``results.sqlite``).

    Raises:
        StoreError: no usable database there (missing, corrupt, newer schema).
    """
    path = Path(path)
    db = path if path.name == DB_NAME else path / DB_NAME
    runs: list[RunData] = []
    with Store.open(db) as store:
        verify(store)
        config = store.config
        records = store.runs()
        for record in records:
            series = store.fitness_over_births(record.run_id)
            if series.births.size == 0:
                continue  # never reached its first commit point: nothing to show
            final = store.final_population(record.run_id)
            final_fitness = np.array(
                [f for _, f in final if f is not None and math.isfinite(f)], dtype=float)
            points = store.diversity_over_births(record.run_id)
            pairs = [(x.inborn_fitness, x.learned_fitness) for x in store.learning(record.run_id)
                     if x.inborn_fitness is not None and x.learned_fitness is not None
                     and math.isfinite(x.inborn_fitness) and math.isfinite(x.learned_fitness)]
            runs.append(RunData(
                record.run_id, record.status, record.births, series,
                np.array([p.births for p in points], dtype=np.int64),
                np.array([p.value for p in points], dtype=float),
                final_fitness,
                _final_diversity(store, record.run_id, [rid for rid, _ in final]),
                np.array([a for a, _ in pairs], dtype=float),
                np.array([b for _, b in pairs], dtype=float),
                len(store.failures(record.run_id, "learner")),
            ))
    name = str(config.get("name", db.parent.name))
    return ExperimentData(label or name, db.parent, config, tuple(runs), len(records))


def _order_key(experiment: ExperimentData) -> tuple[int, str]:
    name = experiment.name
    rank = PAPER_ORDER.index(name) if name in PAPER_ORDER else len(PAPER_ORDER)
    return rank, experiment.label


def find_experiments(root: str | os.PathLike[str]) -> list[ExperimentData]:
    """Every experiment at or below ``root``, in report order (the paper's five first).

    Labels are the experiments' names; where two databases share a name, their paths relative
    to ``root`` are used instead.

    Raises:
        StoreError: ``root`` is missing, holds no results database, or one of them is unusable
            (its path is named).
    """
    root = Path(root)
    if not root.exists():
        raise StoreError(f"no such results directory: {root}")
    if root.is_file():
        paths = [root] if root.name == DB_NAME else []
    else:
        paths = sorted(root.rglob(DB_NAME))
    if not paths:
        raise StoreError(f"no results database ({DB_NAME}) at or below {root}")
    experiments = [load_experiment(p) for p in paths]
    counts: dict[str, int] = {}
    for e in experiments:
        counts[e.label] = counts.get(e.label, 0) + 1
    base = root if root.is_dir() else root.parent
    relabelled = []
    for e in experiments:
        if counts[e.label] > 1:
            relative = e.path.relative_to(base).as_posix() if e.path != base else e.path.name
            e = ExperimentData(relative or e.label, e.path, e.config, e.runs, e.registered_runs)
        relabelled.append(e)
    return sorted(relabelled, key=_order_key)


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


