"""Reports over results directories: tables, statistics and figures of stored experiments.

Modules: :mod:`~evolution.reporting.data` (stored experiments read back, one set at a time,
populations at the births a pair is compared at), :mod:`~evolution.reporting.tables` (summary
table and significance tests, like with like), :mod:`~evolution.reporting.stats` (Mann-Whitney
U, A12 and its exact interval, Holm), :mod:`~evolution.reporting.style` and
:mod:`~evolution.reporting.figures` (the paper's figures), :mod:`~evolution.reporting.optimism`
(re-evaluations), :mod:`~evolution.reporting.reproduce` (the commands that make a report again),
:mod:`~evolution.reporting.page` (``index.html``) and :mod:`~evolution.reporting.report`
(:func:`report`, all of them written into one folder).
"""

from __future__ import annotations

from evolution.experiments.loop.registry import PAPER_SCENARIOS
from evolution.reporting.data import (
    FAILED_BIRTH_KINDS,
    LABELS,
    ExperimentData,
    Included,
    PopulationAt,
    RunData,
    births_axis,
    find_experiments,
    load_experiment,
    load_included,
    runs_on_grid,
    step_on_grid,
)
from evolution.reporting.report import REPORT_DIR, Report, report
from evolution.reporting.tables import (
    LEARNING_COLUMNS,
    TESTED_SAMPLES,
    curve_rows,
    mann_whitney_rows,
    pooled_rows,
    summary_rows,
    write_tables,
)

__all__ = [
    "FAILED_BIRTH_KINDS",
    "LABELS",
    "LEARNING_COLUMNS",
    "PAPER_SCENARIOS",
    "REPORT_DIR",
    "TESTED_SAMPLES",
    "ExperimentData",
    "Included",
    "PopulationAt",
    "Report",
    "RunData",
    "births_axis",
    "curve_rows",
    "find_experiments",
    "load_experiment",
    "load_included",
    "mann_whitney_rows",
    "pooled_rows",
    "report",
    "runs_on_grid",
    "step_on_grid",
    "summary_rows",
    "write_tables",
]
