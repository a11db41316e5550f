"""Reports over results directories: the paper's figures, a summary table, significance tests.

``report(path)`` finds every experiment below ``path`` (a directory holding ``results.sqlite``,
as written by :func:`evolution.experiments.api.run`; ``revolve run`` writes ``OUT/<name>/``),
reads them through :class:`~evolution.experiments.store.Store`, and writes into
``path/report/`` (or ``out``):

====================================== ============================================================
file                                    content
====================================== ============================================================
``fitness_over_births.{png,pdf}``       population mean and best fitness over births, per
                                        experiment: median over runs, band = interquartile range;
                                        offline as steps per generation, online apart (a
                                        different measurement)
``final_fitness.{png,pdf}``             box plots of the final populations' fitness (robots
                                        pooled) with each run's mean as a point
``diversity_over_births.{png,pdf}``     body diversity (mean pairwise tree edit distance) over
                                        births, median and interquartile range over runs; with
                                        ``brain_aware`` a second panel, body + neural distance
``final_diversity.{png,pdf}``           box plots of each run's final diversity (brain-aware too)
``failed_births.{png,pdf}``             robots lost before their first fitness (blow-ups,
                                        failed evaluations) over births, one line per run
``curve_tests.{png,pdf}``               every pair at equal births: A12 and significance
``summary.csv``                         one row per experiment (see :func:`summary_rows`)
``tests_per_run.csv``                   the primary tests: one value per run, two-sided
                                        Mann-Whitney U, A12 with a 95 % bootstrap interval,
                                        Holm-Bonferroni (see :func:`mann_whitney_rows`)
``tests_pooled_descriptive.csv``        the same on pooled robots, descriptive only
``curve_tests.csv``                     whole curves at equal births (see :func:`curve_rows`)
``summary.md``                          the tables in Markdown, with what each means
``learning_gain.{png,pdf}``             only when an experiment learns (a ``[learning]`` table):
                                        the learner's inborn vs learned fitness of every infant
``optimism.{png,pdf}``                  only after ``revolve reevaluate``: stored vs re-evaluated
                                        fitness, and the optimism of a single evaluation with
                                        its 95 % bootstrap CI over runs
``optimism.csv``                        one row per experiment and re-evaluation setting
                                        (:mod:`evolution.reporting.optimism`)
====================================== ============================================================

Births are counted the same way in every experiment and figure: failed births (robots lost
before their first fitness) are left out and shown apart (:mod:`evolution.reporting.data`).
Statistics: :mod:`evolution.reporting.stats`.

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
    brain_aware: bool = False,
) -> Report:
    """Compare every experiment at or below ``path``: figures and tables (see module docs).

    Args:
        path: A results directory (or a folder of them).
        out: Output folder; default ``path/report``. Existing report files are replaced (they
            are derived data; the results databases are only read).
        formats: Figure file formats.
        brain_aware: Also compute the brain-aware diversity
            (:func:`evolution.diversity.brain_aware_diversity`) of the stored populations at
            every diversity point and of the final ones (slower: their genomes are decoded).

    Returns:
        What was written.

    Raises:
        StoreError: no results below ``path``, or an unusable database.
        ValueError: an unknown figure format.
    """
    for fmt in formats:
        if fmt not in ("png", "pdf", "svg"):
            raise ValueError(f"unknown figure format {fmt!r}; use png, pdf or svg")
    experiments = find_experiments(path, brain_aware=brain_aware)
    root = Path(path)
    out_dir = Path(out) if out is not None else (
        root / REPORT_DIR if root.is_dir() else root.parent / REPORT_DIR)
    out_dir.mkdir(parents=True, exist_ok=True)
    figures = write_figures(experiments, out_dir, formats)
    assert len(figures) >= len(FIGURES) * len(formats)
    tables = write_tables(experiments, out_dir)
    figures, tables = with_optimism(experiments, out_dir, formats, figures, tables)
    return Report(out_dir, tuple(experiments), figures, tables)
