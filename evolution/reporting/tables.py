"""The summary table and the significance tests of a report (CSV and Markdown)."""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from itertools import combinations
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.stats import mannwhitneyu

from evolution.reporting.data import ExperimentData

__all__ = [
    "LEARNING_COLUMNS",
    "MANN_WHITNEY_COLUMNS",
    "SUMMARY_COLUMNS",
    "TESTED_SAMPLES",
    "mann_whitney_rows",
    "summary_columns",
    "summary_rows",
    "write_tables",
]

Cell = str | int | float
"""The value of one table cell."""


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


def _mean(values: NDArray[np.float64]) -> float:
    """The mean, ``nan`` when empty."""
    return float(values.mean()) if values.size else math.nan


def _learning_cells(e: ExperimentData) -> dict[str, Cell]:
    table = e.config.get("learning")
    inborn, learned = e.learning_fitness()
    return {
        "learning": (f"{table.get('learner', '?')} {table.get('inheritance', 'darwinian')}"
                     if isinstance(table, dict) else ("yes" if e.learns else "none")),
        "infants_learned": int(inborn.size),
        "learner_failures": sum(r.learner_failures for r in e.runs),
        "inborn_fitness_mean": _mean(inborn),
        "learned_fitness_mean": _mean(learned),
        "learning_gain_mean": _mean(learned - inborn),
    }


def summary_columns(experiments: Sequence[ExperimentData]) -> tuple[str, ...]:
    """Columns of ``summary.csv``.

    :data:`SUMMARY_COLUMNS`, plus :data:`LEARNING_COLUMNS` when an experiment learns.
    """
    return SUMMARY_COLUMNS + (LEARNING_COLUMNS if any(e.learns for e in experiments) else ())


def summary_rows(experiments: Sequence[ExperimentData]) -> list[dict[str, Cell]]:
    """One row per experiment, with the columns of :func:`summary_columns`.

    Those are :data:`SUMMARY_COLUMNS`, and :data:`LEARNING_COLUMNS` when an experiment learns.
    ``runs`` counts the runs with at least one commit point (the ones described), of
    ``runs_in_database``; ``births_mean`` is over those runs.

    ``final_fitness_*`` describe the pooled final populations, ``run_mean_fitness_*`` the
    per-run means of the final populations, ``final_diversity_*`` the per-run final diversity.
    """
    rows: list[dict[str, Cell]] = []
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
        for row, e in zip(rows, experiments, strict=True):
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


def mann_whitney_rows(experiments: Sequence[ExperimentData]) -> list[dict[str, Cell]]:
    """Two-sided Mann-Whitney U tests between every pair of experiments, per sample.

    Samples are described in :data:`TESTED_SAMPLES`; a pair is left out when either side has
    no value. ``p_holm`` is Holm's correction over the pairs of the same sample.
    """
    rows: list[dict[str, Cell]] = []
    samples = {e.label: _samples(e) for e in experiments}
    for sample in TESTED_SAMPLES:
        block: list[dict[str, Cell]] = []
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
        adjusted_p = _holm([float(r["p_value"]) for r in block])
        for row, adjusted in zip(block, adjusted_p, strict=True):
            row["p_holm"] = adjusted
        rows += block
    return rows


# --------------------------------------------------------------------------------------------
# Writing


def _cell(value: Cell) -> str:
    if isinstance(value, float):
        return "" if math.isnan(value) else f"{value:.6g}"
    return str(value)


def _write_csv(path: Path, columns: Sequence[str], rows: Sequence[dict[str, Cell]]) -> None:
    with open(path, "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow(columns)
        for row in rows:
            writer.writerow([_cell(row[c]) for c in columns])


def _markdown(columns: Sequence[str], rows: Sequence[dict[str, Cell]]) -> list[str]:
    def short(value: Cell) -> str:
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
