"""Reports over results directories: the paper's figures, a summary table, significance tests.

``report(path)`` finds every experiment below ``path`` (a directory holding ``results.sqlite``,
as written by :func:`evolution.experiments.app.api.run`; ``revolve run`` writes ``OUT/<name>/``),
reads them through :class:`~evolution.experiments.store.database.Store`, and writes into
``path/report/`` (or ``out``):

====================================== ============================================================
file                                    content
====================================== ============================================================
``index.html``                          the whole report on one page: what is compared,
                                        every figure and table, how to reproduce it, the
                                        run settings (:mod:`evolution.reporting.page`)
``fitness_over_births.{png,pdf}``       population mean and best fitness over births, per
                                        experiment: every run and the median over runs;
                                        offline as steps per generation, online in its own
                                        panels on the same y-scale
``final_fitness.{png,pdf}``             every robot of the compared populations over a box per
                                        experiment, each run's mean as a diamond
``diversity_over_births.{png,pdf}``     body diversity (mean pairwise tree edit distance) over
                                        births, every run and the median; with
                                        ``brain_aware`` a second panel, body + neural distance
``final_diversity.{png,pdf}``           each run's diversity in the compared populations
``lost_robots.{png,pdf}``               robots lost to blow-ups, unbuildable bodies and failed
                                        evaluations over births, one line per run
``curve_tests.{png,pdf}``               every pair at equal births: A12 and significance
``summary.csv``                         one row per experiment (see :func:`summary_rows`)
``tests_per_run.csv``                   the primary tests: one value per run, each pair at the
                                        births both reached, two-sided Mann-Whitney U, A12
                                        with its 95 % interval, Holm-Bonferroni (see
                                        :func:`mann_whitney_rows`)
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

Which experiments: one set below ``path``, a study or the experiments outside any study
(:mod:`evolution.experiments.store.folders`); the report says what it left out, and ``every_set``
compares every set. Like with like: every pair is compared at the most births both reached
(:mod:`evolution.reporting.tables`), and robots lost to blow-ups are counted apart, never as
0 m. Births are counted the same way in every experiment and figure: failed births (robots lost
before their first fitness) are left out and shown apart (:mod:`evolution.reporting.data`).
Statistics: :mod:`evolution.reporting.stats`. The reader's guide: ``docs/reports.md``.

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

from evolution.experiments.store.folders import ResultSet
from evolution.experiments.store.results_folder import output_folder
from evolution.reporting.data import ExperimentData, load_included
from evolution.reporting.figures import FIGURES, write_figures
from evolution.reporting.optimism import with_optimism
from evolution.reporting.page import write_page
from evolution.reporting.reproduce import commands
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
        page: The report's page (``index.html``).
        left_out: Sets of experiments below the path that were not compared.
    """

    out_dir: Path
    experiments: tuple[ExperimentData, ...]
    figures: tuple[Path, ...]
    tables: tuple[Path, ...]
    page: Path
    left_out: tuple[ResultSet, ...] = ()


def report(
    path: str | os.PathLike[str],
    out: str | os.PathLike[str] | None = None,
    formats: Sequence[str] = ("png", "pdf"),
    brain_aware: bool = False,
    every_set: bool = False,
) -> Report:
    """Compare the experiments at or below ``path``: figures, tables and a page (module docs).

    Args:
        path: A results directory (or a folder of them).
        out: Output folder; default ``path/report``. Existing report files are replaced (they
            are derived data; the results databases are only read).
        formats: Figure file formats.
        brain_aware: Also compute the brain-aware diversity
            (:func:`evolution.diversity.brain_aware_diversity`) of the stored populations at
            every diversity point and of the compared ones (slower: their genomes are decoded).
        every_set: Compare every set of experiments below ``path`` (studies and lone
            experiments together), not only the one
            :func:`~evolution.experiments.store.folders.select_results` takes.

    Returns:
        What was written.

    Raises:
        StoreError: no results below ``path``, several studies and nothing else without
            ``every_set``, or an unusable database.
        ValueError: an unknown figure format.
    """
    for fmt in formats:
        if fmt not in ("png", "pdf", "svg"):
            raise ValueError(f"unknown figure format {fmt!r}; use png, pdf or svg")
    included = load_included(path, brain_aware, every_set)
    experiments = list(included.experiments)
    root = Path(path)
    # The default is inside the results folder: no link in it may lead the writing elsewhere.
    out_dir = Path(out) if out is not None else output_folder(
        root if root.is_dir() else root.parent, REPORT_DIR)
    out_dir.mkdir(parents=True, exist_ok=True)
    figures = write_figures(experiments, out_dir, formats)
    assert len(figures) >= len(FIGURES) * len(formats)
    tables, parts = write_tables(included, out_dir)
    figures, tables, optimism = with_optimism(experiments, out_dir, formats, figures, tables)
    if optimism is not None:
        parts.append(optimism)
    page = write_page(included, out_dir, figures, tables, parts,
                      commands(included, every_set, brain_aware, formats,
                               None if out is None else str(out)))
    return Report(out_dir, included.experiments, figures, tables, page, included.left_out)
