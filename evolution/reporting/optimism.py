"""How optimistic is a single evaluation? The reevaluations of stored robots, summarised.

A run selects robots on one evaluation each; ``revolve reevaluate``
(:mod:`evolution.experiments.app.reevaluate`) evaluates the robots it kept ``K`` times more under
fresh conditions. For every experiment and every reevaluation *setting* (which robots, the
conditions, the window, alone or in a shared world) this module computes:

* **optimism** of a robot: its stored fitness minus the mean of its reevaluated fitness (failed
  reevaluations, i.e. blow-ups, left out of the mean and counted). A run's value is the mean over
  its robots, and the experiment's the mean over runs (the run is the unit: its robots share a
  history), with a 95 % percentile bootstrap confidence interval over runs
  (:func:`scipy.stats.bootstrap`, 9,999 resamples, a seeded generator: the same stored data give
  the same interval). Relative optimism: the experiment's optimism over its mean stored fitness,
  in %;
* **rank stability**: per run, Spearman's rank correlation between the stored fitness and the
  mean reevaluated fitness of its robots (runs with fewer than three robots, or constant values,
  left out), mean over runs with the same bootstrap interval; and the fraction of runs whose
  stored best robot is still the best on reevaluation (*best stays best*).

Fitness is ``f = v + 5 s`` over the evaluation window (metres; 12 s in the shipped configs).
:func:`write_optimism` writes ``optimism.csv``, a section of ``summary.md`` and the figure
``optimism.{png,pdf}``; :func:`evolution.reporting.report` calls it, and it writes nothing when
no experiment has reevaluations. Pure NumPy and SciPy; matplotlib for the figure.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray
from scipy.stats import bootstrap, spearmanr

from evolution.experiments.store.database import DB_NAME, Store
from evolution.experiments.store.schema import ReevaluationRecord
from evolution.reporting.data import ExperimentData
from evolution.reporting.figures import save_figure
from evolution.reporting.style import colors, legend_below, styled
from evolution.reporting.tables import Section, markdown_table, write_csv
from evolution.reporting.tables import markdown as section_markdown

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "OPTIMISM_COLUMNS",
    "OptimismRow",
    "RobotOptimism",
    "MARKDOWN_COLUMNS",
    "bootstrap_ci",
    "display_rows",
    "markdown",
    "optimism_rows",
    "robot_optimism",
    "section",
    "with_optimism",
    "write_optimism",
]

OPTIMISM_COLUMNS = (
    "experiment", "setting", "controller", "runs", "robots", "k", "failures", "stored_mean",
    "reevaluated_mean", "optimism", "optimism_low", "optimism_high", "optimism_percent",
    "spearman", "spearman_low", "spearman_high", "best_stays_best",
)
"""Columns of ``optimism.csv`` (fitness in metres; ``_low``/``_high``: 95 % bootstrap CI)."""

_RESAMPLES = 9999
_SEED = 20180404
"""Seeds the bootstrap (the same data always give the same interval)."""


@dataclass(frozen=True, slots=True)
class RobotOptimism:
    """One reevaluated robot of one setting.

    Attributes:
        run_id: Its run.
        robot_id: The robot.
        stored: The fitness its run stored. Metres.
        reevaluated: Mean fitness of its successful reevaluations (``nan`` without any). Metres.
        repeats: Reevaluations stored.
        failures: Of those, how many failed (blow-ups).
        controller: How it was driven (``"inborn"``, ``"learned"``, ...).
        seconds: The fitness window of its reevaluations. Seconds.
    """

    run_id: int
    robot_id: int
    stored: float
    reevaluated: float
    repeats: int
    failures: int
    controller: str
    seconds: float

    @property
    def optimism(self) -> float:
        """``stored - reevaluated``. Metres."""
        return self.stored - self.reevaluated


@dataclass(frozen=True, slots=True)
class OptimismRow:
    """One line of the optimism table (see :data:`OPTIMISM_COLUMNS`)."""

    experiment: str
    setting: str
    controller: str
    runs: int
    robots: int
    k: int
    failures: int
    stored_mean: float
    reevaluated_mean: float
    optimism: float
    optimism_low: float
    optimism_high: float
    optimism_percent: float
    spearman: float
    spearman_low: float
    spearman_high: float
    best_stays_best: float
    robots_of: tuple[RobotOptimism, ...] = ()

    def cells(self) -> dict[str, str | int | float]:
        """The row as table cells."""
        return {c: getattr(self, c) for c in OPTIMISM_COLUMNS}


def _setting_label(record: ReevaluationRecord) -> str:
    conditions = json.loads(record.conditions)
    parts = [f"heading {conditions.get('heading')}"]
    parts += [f"{name.split('_')[0]} {value:g}" for name, value in sorted(conditions.items())
              if name != "heading" and isinstance(value, (int, float)) and value]
    where = "shared world" if record.shared_world else "alone"
    return (f"{record.kind}, window {record.insertion:g}-{record.insertion + record.seconds:g} s,"
            f" {where}, {', '.join(parts)}")


def robot_optimism(records: Sequence[ReevaluationRecord]
                   ) -> dict[str, list[RobotOptimism]]:
    """Group reevaluations by setting (label) and robot: one :class:`RobotOptimism` each."""
    grouped: dict[str, dict[tuple[int, int], list[ReevaluationRecord]]] = {}
    for r in records:
        if r.stored_fitness is None or not math.isfinite(r.stored_fitness):
            continue
        grouped.setdefault(_setting_label(r), {}).setdefault((r.run_id, r.robot_id), []).append(r)
    out: dict[str, list[RobotOptimism]] = {}
    for label, robots in grouped.items():
        rows = []
        for (run_id, robot_id), rs in sorted(robots.items()):
            values = [r.fitness for r in rs if r.fitness is not None and math.isfinite(r.fitness)]
            stored = rs[0].stored_fitness
            assert stored is not None
            rows.append(RobotOptimism(run_id, robot_id, stored,
                                      float(np.mean(values)) if values else math.nan, len(rs),
                                      len(rs) - len(values), rs[0].controller, rs[0].seconds))
        out[label] = rows
    return out


def bootstrap_ci(values: NDArray[np.float64], seed: int = _SEED) -> tuple[float, float]:
    """95 % percentile bootstrap interval of the mean (``nan`` with fewer than two values)."""
    values = np.asarray(values, dtype=float)
    if values.size < 2:
        return math.nan, math.nan
    result = bootstrap((values,), np.mean, n_resamples=_RESAMPLES, method="percentile",
                       confidence_level=0.95, random_state=np.random.default_rng(seed))
    return float(result.confidence_interval.low), float(result.confidence_interval.high)


def _mean(values: Sequence[float]) -> float:
    return float(np.mean(values)) if len(values) else math.nan


def _row(experiment: str, setting: str, robots: Sequence[RobotOptimism]) -> OptimismRow:
    """Summarise one setting's robots (module docstring)."""
    valid = [r for r in robots if math.isfinite(r.reevaluated)]
    runs: dict[int, list[RobotOptimism]] = {}
    for r in valid:
        runs.setdefault(r.run_id, []).append(r)
    optimism = np.array([_mean([r.optimism for r in rs]) for rs in runs.values()])
    stored = np.array([_mean([r.stored for r in rs]) for rs in runs.values()])
    again = np.array([_mean([r.reevaluated for r in rs]) for rs in runs.values()])
    rhos, kept = [], []
    for rs in runs.values():
        x = np.array([r.stored for r in rs])
        y = np.array([r.reevaluated for r in rs])
        kept.append(float(np.argmax(y) == np.argmax(x)))
        if len(rs) >= 3 and np.ptp(x) > 0 and np.ptp(y) > 0:
            rhos.append(float(spearmanr(x, y).statistic))
    rho = np.array(rhos)
    mean_optimism = _mean(list(optimism))
    mean_stored = _mean(list(stored))
    controllers = sorted({r.controller for r in robots})
    return OptimismRow(
        experiment, setting, "+".join(controllers), len(runs), len(valid),
        max((r.repeats for r in robots), default=0), sum(r.failures for r in robots),
        mean_stored, _mean(list(again)), mean_optimism, *bootstrap_ci(optimism),
        100.0 * mean_optimism / mean_stored if mean_stored else math.nan,
        _mean(list(rho)), *bootstrap_ci(rho), _mean(kept), tuple(robots))


def optimism_rows(experiments: Sequence[tuple[str, Sequence[ReevaluationRecord]]]
                  ) -> list[OptimismRow]:
    """One row per experiment and setting, experiments in the given order."""
    rows = []
    for label, records in experiments:
        for setting, robots in sorted(robot_optimism(records).items()):
            rows.append(_row(label, setting, robots))
    return rows


def read_reevaluations(experiments: Sequence[ExperimentData]
                       ) -> list[tuple[str, list[ReevaluationRecord]]]:
    """Each experiment's title and stored reevaluations (experiments without any left out)."""
    out = []
    for e in experiments:
        with Store.open(e.path / DB_NAME) as store:
            records = store.reevaluations()
        if records:
            out.append((e.title, records))
    return out


MARKDOWN_COLUMNS = ("experiment", "setting", "controller", "runs", "robots", "K",
                    "failed reevaluations", "mean stored (m)", "mean reevaluated (m)",
                    "optimism (m) [95 % CI]", "optimism %", "Spearman [95 % CI]",
                    "best stays best")
"""Columns of the optimism table in ``summary.md``, ``index.html`` and the CLI (CIs in
brackets; ``failed reevaluations``: blow-ups, left out of the means)."""


def display_rows(rows: Sequence[OptimismRow]) -> list[dict[str, str | int | float]]:
    """The rows as cells of :data:`MARKDOWN_COLUMNS`, CIs in brackets."""
    def number(value: float, digits: int = 3) -> str:
        return "-" if not math.isfinite(value) else f"{value:.{digits}f}"

    def ci(value: float, low: float, high: float) -> str:
        bounds = "" if not math.isfinite(low) else f" [{number(low)}, {number(high)}]"
        return number(value) + bounds

    return [dict(zip(MARKDOWN_COLUMNS, (
        r.experiment, r.setting, r.controller, r.runs, r.robots, r.k, r.failures,
        number(r.stored_mean), number(r.reevaluated_mean),
        ci(r.optimism, r.optimism_low, r.optimism_high), number(r.optimism_percent, 1),
        ci(r.spearman, r.spearman_low, r.spearman_high),
        f"{number(100 * r.best_stays_best, 0)} %"), strict=True)) for r in rows]


def markdown(rows: Sequence[OptimismRow]) -> list[str]:
    """The table in Markdown, CIs in brackets."""
    return markdown_table(MARKDOWN_COLUMNS, display_rows(rows))


EXPLANATION = (
    "Optimism = stored fitness (the single evaluation that selected the robot) minus the mean "
    "of its K reevaluations under fresh conditions; per run the mean over its robots, then "
    "the mean over runs with a 95 % bootstrap CI over runs. Spearman: rank correlation of "
    "stored and reevaluated fitness within a run, mean over runs. Best stays best: runs whose "
    "stored best is also the best reevaluated. Fitness f = v + 5 s over the window, metres; "
    "failed reevaluations (blow-ups) are left out of the means.")
"""What the table's columns mean (the Markdown section and the CLI print it under the table)."""


@styled
def figure(rows: Sequence[OptimismRow], palette: Mapping[str, str] | None = None) -> Figure:
    """Stored vs reevaluated fitness of every robot (left), optimism with its CI (right).

    ``palette``: a colour per experiment title (the report's, so an experiment has one colour
    in every figure); default the report's colours in row order.
    """
    from matplotlib.figure import Figure

    # Two lines of tick label per row on the right.
    fig = Figure(figsize=(11.0, max(5.2, 0.36 * len(rows) + 2.4)), layout="constrained")
    left, right = fig.subplots(1, 2)
    fallback = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000")
    low, high = math.inf, -math.inf
    handles, labels = [], []
    for i, row in enumerate(rows):
        color = (palette or {}).get(row.experiment, fallback[i % len(fallback)])
        pts = [(r.stored, r.reevaluated) for r in row.robots_of if math.isfinite(r.reevaluated)]
        if pts:
            x, y = np.array(pts).T
            handles.append(left.scatter(x, y, s=12, alpha=0.7, color=color, lw=0))
            labels.append(f"{row.experiment}: {row.setting} ({row.failures} failed)")
            low, high = min(low, x.min(), y.min()), max(high, x.max(), y.max())
        err = ([[row.optimism - row.optimism_low], [row.optimism_high - row.optimism]]
               if math.isfinite(row.optimism_low) else None)
        right.errorbar([row.optimism], [i], xerr=err, fmt="o", capsize=4, color=color)
    if math.isfinite(low):
        (diagonal,) = left.plot([low, high], [low, high], color="black", lw=0.8, ls="--")
        handles.append(diagonal)
        labels.append("no optimism (y = x)")
    left.set_xlabel("stored fitness (single evaluation), m")
    left.set_ylabel("mean reevaluated fitness, m")
    left.grid(alpha=0.3)
    legend_below(fig, handles, labels, ncols=2)
    right.axvline(0.0, color="black", lw=0.8)
    right.set_yticks(range(len(rows)),
                     [f"{r.experiment}\n{r.setting}" for r in rows])
    right.invert_yaxis()
    right.set_xlabel("optimism = stored - mean reevaluated, m\n(mean over runs, 95 % bootstrap "
                     "CI over runs)")
    windows = sorted({r.seconds for row in rows for r in row.robots_of})
    fig.suptitle("Optimism of a single evaluation: stored fitness vs K reevaluations under fresh "
                 "conditions\n(fitness f = v + 5 s over "
                 f"{' / '.join(f'{w:g}' for w in windows)} s, metres; v: path length, s: "
                 "displacement; each point a robot)")
    return fig


def section(rows: Sequence[OptimismRow]) -> Section:
    """The optimism table with what it means, as a section of ``summary.md`` and the page."""
    return Section("Optimism of a single evaluation (revolve reevaluate)", (EXPLANATION,),
                   MARKDOWN_COLUMNS, tuple(display_rows(rows)), name="optimism")


def write_optimism(experiments: Sequence[ExperimentData], out_dir: Path,
                   formats: Sequence[str] = ("png", "pdf")
                   ) -> tuple[tuple[Path, ...], tuple[Path, ...], Section | None]:
    """Write ``optimism.csv``, its ``summary.md`` section and ``optimism.<fmt>`` figures.

    Nothing is written when no experiment has reevaluations. The section is appended to
    ``out_dir/summary.md`` (written just before by the report's tables).

    Returns:
        The figure paths, the new table path (``optimism.csv``) and the section (``None``
        when nothing was written).
    """
    rows = optimism_rows(read_reevaluations(experiments))
    if not rows:
        return (), (), None
    table = out_dir / "optimism.csv"
    write_csv(table, OPTIMISM_COLUMNS, [row.cells() for row in rows])
    part = section(rows)
    with open(out_dir / "summary.md", "a", encoding="utf-8") as f:
        f.write("\n".join(section_markdown(part)) + "\n")
    palette = colors(experiments)
    titles = {e.title: palette[e.label] for e in experiments}
    return (tuple(save_figure(figure(rows, titles), out_dir, "optimism", formats)), (table,),
            part)


def with_optimism(experiments: Sequence[ExperimentData], out_dir: Path, formats: Sequence[str],
                  figures: tuple[Path, ...], tables: tuple[Path, ...]
                  ) -> tuple[tuple[Path, ...], tuple[Path, ...], Section | None]:
    """:func:`write_optimism`, its files added to a report's ``figures`` and ``tables``."""
    more_figures, more_tables, part = write_optimism(experiments, out_dir, formats)
    return figures + more_figures, tables + more_tables, part
