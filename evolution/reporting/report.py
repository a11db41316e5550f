"""Reports over results directories: the paper's figures, a summary table, significance tests.

``report(path)`` finds every experiment below ``path`` (a directory holding ``results.sqlite``,
as written by :func:`evolution.experiments.api.run`; ``revolve run`` writes ``OUT/<name>/``),
reads them through :class:`~evolution.experiments.store.Store`, and writes into
``path/report/`` (or ``out``):

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

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from evolution.reporting.data import ExperimentData, find_experiments
from evolution.reporting.figures import FIGURES, write_figures
from evolution.reporting.optimism import with_optimism
from evolution.reporting.tables import write_tables

__all__ = ["REPORT_DIR", "Report", "report"]

REPORT_DIR = "report"
"""Default output folder inside the reported directory."""


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
    figures, tables = with_optimism(experiments, out_dir, formats, figures, tables)
    return Report(out_dir, tuple(experiments), figures, tables)
