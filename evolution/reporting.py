"""Reports over results directories: the paper's figures and a summary table with significance tests.

``report(path)`` finds every experiment below ``path`` (a directory holding ``results.sqlite``,
as written by :func:`evolution.experiment.run`; ``revolve run`` writes ``OUT/<name>/``), reads
them through :class:`~evolution.store.Store`, and writes into ``path/report/`` (or ``out``):

==================================== ==============================================================
file                                  content
==================================== ==============================================================
``fitness_over_births.{png,pdf}``     population mean and best fitness over births, per
                                      experiment: mean over runs, band = +-1 standard deviation
``final_fitness.{png,pdf}``           box plots of the fitness of the final populations (all
                                      robots of all runs pooled), baselines included
``diversity_over_births.{png,pdf}``   population diversity (mean pairwise tree edit distance)
                                      over births: mean over runs, band = +-1 standard deviation
``final_diversity.{png,pdf}``         box plots of the diversity of each run's final population
``summary.csv``                       one row per experiment (see :func:`summary_rows`)
``mann_whitney.csv``                  two-sided Mann-Whitney U tests between every pair of
                                      experiments on three samples (see :func:`mann_whitney_rows`)
``summary.md``                        both tables in Markdown
``learning_gain.{png,pdf}``           only when an experiment learns (a ``[learning]`` table):
                                      the learner's inborn vs learned fitness of every infant
==================================== ==============================================================

With infancy learning, ``summary.csv`` gains the columns of :data:`LEARNING_COLUMNS` (mean
inborn and learned fitness as the learner measured them, and the learner failures), so runs with
and without learning compare side by side.

Unfinished runs are included with what they committed; ``summary.csv`` says how many finished.
Reading needs only the standard library and NumPy; the figures use matplotlib (Agg, no display)
and the tests SciPy, both dependencies of the package.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from itertools import combinations
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from evolution.store import DB_NAME, FitnessSeries, Store, StoreError

__all__ = [
    "LEARNING_COLUMNS",
    "PAPER_ORDER",
    "TESTED_SAMPLES",
    "ExperimentData",
    "Report",
    "RunData",
    "find_experiments",
    "load_experiment",
    "mann_whitney_rows",
    "report",
    "step_on_grid",
    "summary_rows",
    "write_tables",
]

PAPER_ORDER = ("scenario1", "scenario2", "scenario3", "baseline_a", "baseline_b")
"""Experiments named like this are listed in this order, the others after them by name."""

REPORT_DIR = "report"
"""Default output folder inside the reported directory."""


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
        values = np.array([r.final_diversity for r in self.runs], dtype=float)
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


@dataclass(frozen=True, slots=True)
class Report:
    """What :func:`report` wrote.

    Attributes:
        out_dir: The output folder.
        experiments: The experiments compared, in report order.
        figures: Every figure file written.
        tables: Every table file written.
    """

    out_dir: Path
    experiments: tuple[ExperimentData, ...]
    figures: tuple[Path, ...]
    tables: tuple[Path, ...]


# --------------------------------------------------------------------------------------------
# Reading


def _final_diversity(store: Store, run_id: int, members: Sequence[int]) -> float:
    from evolution.diversity import diversity
    from revolve_env.body.serialize import from_json

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
    values = np.array([step_on_grid(x, y, grid) for x, y in zip(xs, ys)]).reshape(len(xs), -1)
    return grid.astype(np.int64), values


def _describe(values: NDArray[np.float64]) -> tuple[float, float, float, float]:
    """Mean, median, standard deviation (n - 1; 0 for one value) and maximum; nan when empty."""
    if values.size == 0:
        return math.nan, math.nan, math.nan, math.nan
    sd = float(values.std(ddof=1)) if values.size > 1 else 0.0
    return float(values.mean()), float(np.median(values)), sd, float(values.max())


SUMMARY_COLUMNS = (
    "experiment", "engine", "runs", "runs_in_database", "finished_runs", "births_mean",
    "final_population_size_mean", "final_fitness_mean", "final_fitness_median",
    "final_fitness_sd", "final_fitness_max", "run_mean_fitness_mean", "run_mean_fitness_sd",
    "final_diversity_mean", "final_diversity_sd",
)
"""Columns of ``summary.csv``."""

LEARNING_COLUMNS = (
    "learning", "infants_learned", "learner_failures", "inborn_fitness_mean",
    "learned_fitness_mean", "learning_gain_mean",
)
"""Columns appended to ``summary.csv`` when an experiment learns: the learner and inheritance
(``none`` without learning), infancies recorded, learner failures, and the mean inborn and
learned fitness and their difference as the learners measured them (their own evaluation
window, not the robots' fitness in the run)."""


def _learning_cells(e: ExperimentData) -> dict[str, Any]:
    table = e.config.get("learning")
    inborn, learned = e.learning_fitness()
    mean = (lambda x: float(x.mean()) if x.size else math.nan)
    return {
        "learning": (f"{table.get('learner', '?')} {table.get('inheritance', 'darwinian')}"
                     if isinstance(table, dict) else ("yes" if e.learns else "none")),
        "infants_learned": int(inborn.size),
        "learner_failures": sum(r.learner_failures for r in e.runs),
        "inborn_fitness_mean": mean(inborn),
        "learned_fitness_mean": mean(learned),
        "learning_gain_mean": mean(learned - inborn),
    }


def summary_columns(experiments: Sequence[ExperimentData]) -> tuple[str, ...]:
    """Columns of ``summary.csv``: :data:`SUMMARY_COLUMNS`, plus :data:`LEARNING_COLUMNS` when
    an experiment learns."""
    return SUMMARY_COLUMNS + (LEARNING_COLUMNS if any(e.learns for e in experiments) else ())


def summary_rows(experiments: Sequence[ExperimentData]) -> list[dict[str, Any]]:
    """One row per experiment (columns :func:`summary_columns`: :data:`SUMMARY_COLUMNS`, and
    :data:`LEARNING_COLUMNS` when an experiment learns).

    ``runs`` counts the runs with at least one commit point (the ones described), of
    ``runs_in_database``; ``births_mean`` is over those runs.

    ``final_fitness_*`` describe the pooled final populations, ``run_mean_fitness_*`` the
    per-run means of the final populations, ``final_diversity_*`` the per-run final diversity.
    """
    rows = []
    for e in experiments:
        pooled = _describe(e.final_fitness())
        run_means = _describe(e.final_run_means())
        div = _describe(e.final_diversities())
        rows.append({
            "experiment": e.label,
            "engine": e.config.get("engine", ""),
            "runs": len(e.runs),
            "runs_in_database": e.registered_runs,
            "finished_runs": sum(r.status == "finished" for r in e.runs),
            "births_mean": float(np.mean([r.births for r in e.runs])) if e.runs else math.nan,
            "final_population_size_mean": (
                float(np.mean([r.fitness.size[-1] for r in e.runs])) if e.runs else math.nan),
            "final_fitness_mean": pooled[0],
            "final_fitness_median": pooled[1],
            "final_fitness_sd": pooled[2],
            "final_fitness_max": pooled[3],
            "run_mean_fitness_mean": run_means[0],
            "run_mean_fitness_sd": run_means[2],
            "final_diversity_mean": div[0],
            "final_diversity_sd": div[2],
        })
    if any(e.learns for e in experiments):
        for row, e in zip(rows, experiments):
            row.update(_learning_cells(e))
    return rows


TESTED_SAMPLES: dict[str, str] = {
    "final_fitness": "fitness of every robot of the final populations, all runs pooled",
    "run_mean_fitness": "mean fitness of each run's final population (one value per run)",
    "final_diversity": "diversity of each run's final population (one value per run)",
}
"""The samples compared by :func:`mann_whitney_rows`. The pooled one follows the paper's figure
(robots of one run are not independent, so read its p-values as descriptive); the per-run ones
are independent samples but need several runs (with 3 runs each, p >= 0.1)."""

MANN_WHITNEY_COLUMNS = ("sample", "experiment_a", "experiment_b", "n_a", "n_b", "median_a",
                        "median_b", "u_statistic", "p_value", "p_holm")
"""Columns of ``mann_whitney.csv``."""


def _samples(e: ExperimentData) -> dict[str, NDArray[np.float64]]:
    return {"final_fitness": e.final_fitness(), "run_mean_fitness": e.final_run_means(),
            "final_diversity": e.final_diversities()}


def _holm(p: Sequence[float]) -> list[float]:
    """Holm-Bonferroni adjusted p-values (step-down, monotone, capped at 1)."""
    order = np.argsort(p)
    m = len(p)
    adjusted = np.empty(m)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * p[i]))
        adjusted[i] = running
    return adjusted.tolist()


def mann_whitney_rows(experiments: Sequence[ExperimentData]) -> list[dict[str, Any]]:
    """Two-sided Mann-Whitney U tests between every pair of experiments, per sample.

    Samples are described in :data:`TESTED_SAMPLES`; a pair is left out when either side has
    no value. ``p_holm`` is Holm's correction over the pairs of the same sample.
    """
    from scipy.stats import mannwhitneyu

    rows: list[dict[str, Any]] = []
    samples = {e.label: _samples(e) for e in experiments}
    for sample in TESTED_SAMPLES:
        block: list[dict[str, Any]] = []
        for a, b in combinations([e.label for e in experiments], 2):
            xa, xb = samples[a][sample], samples[b][sample]
            if xa.size == 0 or xb.size == 0:
                continue
            if np.ptp(np.concatenate([xa, xb])) == 0:
                u, p = xa.size * xb.size / 2.0, 1.0  # all tied: no evidence of a difference
            else:
                result = mannwhitneyu(xa, xb, alternative="two-sided")
                u, p = float(result.statistic), float(result.pvalue)
            block.append({"sample": sample, "experiment_a": a, "experiment_b": b,
                          "n_a": int(xa.size), "n_b": int(xb.size),
                          "median_a": float(np.median(xa)), "median_b": float(np.median(xb)),
                          "u_statistic": u, "p_value": min(1.0, max(0.0, p))})
        for row, adjusted in zip(block, _holm([float(r["p_value"]) for r in block])):
            row["p_holm"] = adjusted
        rows += block
    return rows


# --------------------------------------------------------------------------------------------
# Writing


def _cell(value: Any) -> str:
    if isinstance(value, float):
        return "" if math.isnan(value) else f"{value:.6g}"
    return str(value)


def _write_csv(path: Path, columns: Sequence[str], rows: Sequence[dict[str, Any]]) -> None:
    with open(path, "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow(columns)
        for row in rows:
            writer.writerow([_cell(row[c]) for c in columns])


def _markdown(columns: Sequence[str], rows: Sequence[dict[str, Any]]) -> list[str]:
    def short(value: Any) -> str:
        if isinstance(value, float):
            return "-" if math.isnan(value) else f"{value:.4g}"
        return str(value)

    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(short(r[c]) for c in columns) + " |" for r in rows]
    return lines


def write_tables(experiments: Sequence[ExperimentData], out_dir: Path) -> tuple[Path, ...]:
    """Write ``summary.csv``, ``mann_whitney.csv`` and ``summary.md`` into ``out_dir``."""
    summary = summary_rows(experiments)
    tests = mann_whitney_rows(experiments)
    paths = (out_dir / "summary.csv", out_dir / "mann_whitney.csv", out_dir / "summary.md")
    columns = summary_columns(experiments)
    _write_csv(paths[0], columns, summary)
    _write_csv(paths[1], MANN_WHITNEY_COLUMNS, tests)
    lines = ["# Summary", "", ("Fitness in metres (f = v + 5 s); diversity = mean pairwise "
                               "tree edit distance of the bodies."), ""]
    lines += _markdown(columns, summary)
    if columns != SUMMARY_COLUMNS:
        lines += ["", ("Learning: `inborn_fitness_mean` and `learned_fitness_mean` are the "
                       "infants' fitness with their inborn and learned controllers as the "
                       "learner measured them (its own evaluation window); "
                       "`learning_gain_mean` is their mean difference; `learner_failures` "
                       "counts infants that kept their inborn controller because the learner "
                       "failed.")]
    lines += ["", "## Mann-Whitney U tests (two-sided)", ""]
    lines += [f"- `{name}`: {text}" for name, text in TESTED_SAMPLES.items()]
    lines += ["- `p_holm`: Holm-corrected over the pairs of one sample", ""]
    lines += _markdown(MANN_WHITNEY_COLUMNS, tests) if tests else ["(fewer than two experiments)"]
    paths[2].write_text("\n".join(lines) + "\n", encoding="utf-8")
    return paths


def report(
    path: str | os.PathLike[str],
    out: str | os.PathLike[str] | None = None,
    formats: Sequence[str] = ("png", "pdf"),
) -> Report:
    """Compare every experiment at or below ``path``: figures and tables (see module docs).

    Args:
        path: A results directory (or a folder of them).
        out: Output folder; default ``path/report``. Existing report files are replaced (they
            are derived data; the results databases are only read).
        formats: Figure file formats.

    Returns:
        What was written.

    Raises:
        StoreError: no results below ``path``, or an unusable database.
        ValueError: an unknown figure format.
    """
    from evolution.plots import FIGURES, write_figures

    for fmt in formats:
        if fmt not in ("png", "pdf", "svg"):
            raise ValueError(f"unknown figure format {fmt!r}; use png, pdf or svg")
    experiments = find_experiments(path)
    root = Path(path)
    out_dir = Path(out) if out is not None else (
        root / REPORT_DIR if root.is_dir() else root.parent / REPORT_DIR)
    out_dir.mkdir(parents=True, exist_ok=True)
    figures = write_figures(experiments, out_dir, formats)
    assert len(figures) >= len(FIGURES) * len(formats)
    tables = write_tables(experiments, out_dir)
    return Report(out_dir, tuple(experiments), figures, tables)
