"""The summary table and the significance tests of a report (CSV and Markdown).

Primary tests take one value per run (:func:`mann_whitney_rows`), whole curves are compared at
equal births (:func:`curve_rows`), and tests on pooled robots are kept only as a descriptive
table (:func:`pooled_rows`); the statistics are in :mod:`evolution.reporting.stats`.

Like with like: every pair of experiments is compared at the most births both reached (engine
births, failed births included: the runs' budgets count them), each run by its population at
the last commit point at or before them (:meth:`ExperimentData.populations_at
<evolution.reporting.data.ExperimentData.populations_at>`). With equal budgets that is every
run's final population; when budgets differ (runs stopped early, lone experiments of other
budgets) the ``births`` column says where each pair was compared and ``summary.md`` says that
budgets differ. Whole curves are compared over that common range only.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from itertools import combinations
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from evolution.reporting.data import ExperimentData, Included, PopulationAt, step_on_grid
from evolution.reporting.stats import ALPHA, CURVE_FRACTIONS, compare, curve_summary, holm

__all__ = [
    "CURVE_COLUMNS",
    "INCLUDED_COLUMNS",
    "TABLE_FILES",
    "CURVE_SUMMARY_COLUMNS",
    "LEARNING_COLUMNS",
    "MANN_WHITNEY_COLUMNS",
    "POOLED_SAMPLES",
    "POOLED_SHOWN_COLUMNS",
    "SHAKING_COLUMNS",
    "SUMMARY_COLUMNS",
    "TESTED_SAMPLES",
    "compared_births",
    "curve_rows",
    "curve_summary_rows",
    "included_rows",
    "mann_whitney_rows",
    "pooled_rows",
    "Section",
    "markdown",
    "markdown_table",
    "sections",
    "shaking_line",
    "shaking_rows",
    "summary_columns",
    "summary_rows",
    "write_csv",
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
    "experiment", "label", "mode", "runs", "runs_in_database", "finished_runs",
    "births_budget", "births_reached_min", "births_mean",
    "final_population_size_mean", "final_fitness_mean", "final_fitness_median",
    "final_fitness_sd", "final_fitness_max", "run_mean_fitness_mean", "run_mean_fitness_sd",
    "final_diversity_mean", "final_diversity_sd", "failed_births", "lost_robots",
)
"""Columns of ``summary.csv`` (see :func:`summary_rows`)."""

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
    ``births_budget`` is the configuration's births per run and ``births_reached_min`` the
    fewest a run reached (both as the engine counts, failed births included);
    ``births_mean`` counts births as :mod:`evolution.reporting.data` defines them;
    ``failed_births`` (robots lost before their first fitness, all runs) are not among them;
    ``lost_robots`` counts every robot lost to a failure (blow-ups and failed evaluations).
    """
    rows: list[dict[str, Cell]] = []
    for e in experiments:
        pooled = _describe(e.final_fitness())
        run_means = _describe(e.final_run_means())
        div = _describe(e.final_diversities())
        rows.append({
            "experiment": e.label,
            "label": e.title,
            "mode": e.config.get("mode", ""),
            "runs": len(e.runs),
            "runs_in_database": e.registered_runs,
            "finished_runs": sum(r.status == "finished" for r in e.runs),
            "births_budget": e.budget,
            "births_reached_min": e.reached,
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
            "failed_births": sum(int(r.failed_births.size) for r in e.runs),
            "lost_robots": sum(r.lost_robots for r in e.runs),
        })
    if any(e.learns for e in experiments):
        for row, e in zip(rows, experiments, strict=True):
            row.update(_learning_cells(e))
    return rows


TESTED_SAMPLES: dict[str, str] = {
    "run_mean_fitness": "mean fitness of each run's population (one value per run)",
    "run_best_fitness": "best fitness of each run's population (one value per run)",
    "run_diversity": "body diversity of each run's population (one value per run)",
    "run_brain_diversity": ("brain-aware diversity of each run's population (one value per "
                            "run; only with --brain-aware)"),
}
"""The primary samples of :func:`mann_whitney_rows`: one value per run, each run's population at
the births the pair is compared at (:func:`compared_births`)."""

POOLED_SAMPLES: dict[str, str] = {
    "pooled_fitness": "fitness of every robot of the runs' populations, all runs pooled",
}
"""The descriptive samples of :func:`pooled_rows`: robots of one run are not independent, so
their p-values describe the pooled populations and test nothing about the experiments."""

MANN_WHITNEY_COLUMNS = ("sample", "experiment_a", "experiment_b", "births", "n_a", "n_b",
                        "lost_a", "lost_b", "median_a", "median_b", "u_statistic", "p_value",
                        "p_min", "p_holm", "a12", "a12_ci_low", "a12_ci_high")
"""Columns of ``tests_per_run.csv`` and ``tests_pooled_descriptive.csv``: ``births`` where the
pair is compared (engine births, :func:`compared_births`), ``lost_a``/``lost_b`` the robots each
side's runs lost among those births, ``p_min`` the smallest p the group sizes allow, ``p_holm``
Holm-Bonferroni over the pairs of one sample, ``a12`` the Vargha-Delaney effect size of A over
B with its 95 % interval (:func:`evolution.reporting.stats.a12_interval`)."""

POOLED_SHOWN_COLUMNS = tuple(c for c in MANN_WHITNEY_COLUMNS
                             if c not in ("u_statistic", "p_value", "p_min", "p_holm"))
"""Columns of the pooled table on the page and in ``summary.md``: no p-values (they would look
stronger than the real, per-run tests); ``tests_pooled_descriptive.csv`` keeps every column."""

CURVE_COLUMNS = ("experiment_a", "experiment_b", "point", "births", "n_a", "n_b", "median_a",
                 "median_b", "p_value", "p_min", "p_holm", "a12")
"""Columns of ``curve_tests.csv``: per-run population mean fitness at equal births (engine
births), ``p_holm`` Holm-Bonferroni over the births of one pair; ``point`` indexes
:data:`CURVE_FRACTIONS`."""


SHAKING_COLUMNS = ("experiment", "pose_rate", "robots_measured", "shaking_median",
                   "shaking_p90", "fittest_robots", "fittest_shaking_median",
                   "share_shaking_over_2")
"""Columns of the report's shaking table (:func:`shaking_rows`)."""

FITTEST_SHARE = 0.1
"""The share of measured robots (the fittest) whose shaking the table shows apart."""


def _pose_rate(e: ExperimentData) -> str:
    task = e.config.get("task")
    rate = task.get("pose_rate") if isinstance(task, dict) else None
    return "default" if rate is None else str(rate)


def shaking_rows(experiments: Sequence[ExperimentData]) -> list[dict[str, Cell]]:
    """One row per experiment with measured robots: does evolution pay for shaking?

    The shaking measure of a robot is the path of its core summed at every control period over
    the path at its task's pose rate, over the same span (1: smooth; 2: half the path is motion
    between pose samples). ``fittest_*`` are the measured robots in the top
    :data:`FITTEST_SHARE` by fitness (at least one); ``share_shaking_over_2`` the share of all
    measured robots above 2. Offline evaluations are measured; online samples are not.
    """
    rows: list[dict[str, Cell]] = []
    for e in experiments:
        shaking, fitness = e.shaking()
        if not shaking.size:
            continue
        k = max(1, int(round(FITTEST_SHARE * shaking.size)))
        fittest = shaking[np.argsort(-fitness, kind="stable")[:k]]
        rows.append({
            "experiment": e.label,
            "pose_rate": _pose_rate(e),
            "robots_measured": int(shaking.size),
            "shaking_median": float(np.median(shaking)),
            "shaking_p90": float(np.percentile(shaking, 90)),
            "fittest_robots": k,
            "fittest_shaking_median": float(np.median(fittest)),
            "share_shaking_over_2": float(np.mean(shaking > 2.0)),
        })
    return rows


def shaking_line(row: Mapping[str, Cell]) -> str:
    """One row of :func:`shaking_rows` as a sentence (what ``revolve report`` prints)."""
    return (f"{row['experiment']}: shaking (path every control period / at pose rate "
            f"{row['pose_rate']}) median {_cell(row['shaking_median'])} over "
            f"{row['robots_measured']} robots, {_cell(row['fittest_shaking_median'])} among the "
            f"{row['fittest_robots']} fittest; {_cell(row['share_shaking_over_2'])} of robots "
            "above 2")


def compared_births(a: ExperimentData, b: ExperimentData) -> int:
    """Where a pair is compared: the most engine births every run of both reached."""
    return min(a.reached, b.reached)


def _samples(populations: Sequence[PopulationAt]) -> dict[str, NDArray[np.float64]]:
    """The values of every sample of one experiment's runs' populations."""
    def finite(values: list[float]) -> NDArray[np.float64]:
        array = np.array(values, dtype=np.float64)
        kept: NDArray[np.float64] = array[np.isfinite(array)]
        return kept

    fitted = [p.fitness for p in populations if p.fitness.size]
    return {"pooled_fitness": np.concatenate(fitted) if fitted else np.zeros(0),
            "run_mean_fitness": np.array([f.mean() for f in fitted]),
            "run_best_fitness": np.array([f.max() for f in fitted]),
            "run_diversity": finite([p.diversity for p in populations]),
            "run_brain_diversity": finite([p.brain_diversity for p in populations])}


def _holm_corrected(block: list[dict[str, Cell]]) -> list[dict[str, Cell]]:
    """``block``'s rows with ``p_holm``: Holm over the ``p_value`` of this block's tests."""
    for row, adjusted in zip(block, holm([float(r["p_value"]) for r in block]), strict=True):
        row["p_holm"] = adjusted
    return block


def _test_rows(experiments: Sequence[ExperimentData], names: Sequence[str]
               ) -> list[dict[str, Cell]]:
    pairs = []
    for a, b in combinations([e for e in experiments if e.runs], 2):
        births = compared_births(a, b)
        pairs.append((a, b, births, _samples(a.populations_at(births)),
                      _samples(b.populations_at(births))))
    rows: list[dict[str, Cell]] = []
    for sample in names:
        block: list[dict[str, Cell]] = []
        for a, b, births, values_a, values_b in pairs:
            xa, xb = values_a[sample], values_b[sample]
            if xa.size == 0 or xb.size == 0:
                continue
            c = compare(xa, xb)
            block.append({"sample": sample, "experiment_a": a.label, "experiment_b": b.label,
                          "births": births, "n_a": c.n_a, "n_b": c.n_b,
                          "lost_a": a.lost_before(births), "lost_b": b.lost_before(births),
                          "median_a": c.median_a, "median_b": c.median_b, "u_statistic": c.u,
                          "p_value": c.p, "p_min": c.p_floor, "a12": c.a12,
                          "a12_ci_low": c.a12_low, "a12_ci_high": c.a12_high})
        rows += _holm_corrected(block)
    return rows


def mann_whitney_rows(experiments: Sequence[ExperimentData]) -> list[dict[str, Cell]]:
    """The primary tests: one value per run, every pair, per sample of :data:`TESTED_SAMPLES`.

    Each pair at :func:`compared_births`; two-sided Mann-Whitney U, Holm-Bonferroni over the
    pairs of one sample, A12 with its 95 % interval. A pair is left out when either side has no
    value (e.g. brain-aware diversity when it was not computed).
    """
    return _test_rows(experiments, list(TESTED_SAMPLES))


def pooled_rows(experiments: Sequence[ExperimentData]) -> list[dict[str, Cell]]:
    """Descriptive tests on the pooled populations (:data:`POOLED_SAMPLES`), at the same births."""
    return _test_rows(experiments, list(POOLED_SAMPLES))


def _curve_values(e: ExperimentData, births: int) -> NDArray[np.float64]:
    values = np.array([step_on_grid(r.commit_births, r.fitness.mean, np.array([births]))[0]
                       for r in e.runs], dtype=np.float64)
    finite: NDArray[np.float64] = values[np.isfinite(values)]
    return finite


def curve_rows(experiments: Sequence[ExperimentData]) -> list[dict[str, Cell]]:
    """Whole-curve tests: each pair of one mode at :data:`CURVE_FRACTIONS` of the births.

    The births are :func:`compared_births`. Like with like: offline experiments with offline
    ones, online with online. An online curve is the sliding-window fitness of a shared world,
    an offline one the isolated evaluations of a population: the same births do not mean the
    same thing, so such a pair is not tested.
    Each run gives its population mean fitness at those engine births; a point where either
    side has no value (before the first commit point, or no fitness yet) is left out. Births
    beyond what both reached are never compared.
    """
    rows: list[dict[str, Cell]] = []
    for a, b in combinations(experiments, 2):
        if not a.runs or not b.runs or a.online != b.online:
            continue
        reached = compared_births(a, b)
        block: list[dict[str, Cell]] = []
        for point, fraction in enumerate(CURVE_FRACTIONS):
            births = round(fraction * reached)
            xa, xb = _curve_values(a, births), _curve_values(b, births)
            if xa.size == 0 or xb.size == 0:
                continue
            c = compare(xa, xb, interval=False)
            block.append({"experiment_a": a.label, "experiment_b": b.label, "point": point,
                          "births": births,
                          "n_a": c.n_a, "n_b": c.n_b, "median_a": c.median_a,
                          "median_b": c.median_b, "p_value": c.p, "p_min": c.p_floor,
                          "a12": c.a12})
        rows += _holm_corrected(block)
    return rows


def curve_summary_rows(rows: Sequence[dict[str, Cell]]) -> list[dict[str, Cell]]:
    """Per pair of :func:`curve_rows`: points tested, fractions with A above and below B."""
    pairs: dict[tuple[str, str], list[dict[str, Cell]]] = {}
    for row in rows:
        pairs.setdefault((str(row["experiment_a"]), str(row["experiment_b"])), []).append(row)
    out: list[dict[str, Cell]] = []
    for (a, b), block in pairs.items():
        above, below = curve_summary([float(r["a12"]) for r in block],
                                     [float(r["p_holm"]) for r in block])
        out.append({"experiment_a": a, "experiment_b": b, "points": len(block),
                    "births_from": int(block[0]["births"]), "births_to": int(block[-1]["births"]),
                    "fraction_a_above": above, "fraction_b_above": below})
    return out


CURVE_SUMMARY_COLUMNS = ("experiment_a", "experiment_b", "points", "births_from", "births_to",
                         "fraction_a_above", "fraction_b_above")
"""Columns of the whole-curve summary in ``summary.md``."""


# --------------------------------------------------------------------------------------------
# Writing


def _cell(value: Cell) -> str:
    if isinstance(value, float):
        return "" if math.isnan(value) else f"{value:.6g}"
    return str(value)


def write_csv(path: Path, columns: Sequence[str], rows: Sequence[Mapping[str, Cell]]) -> None:
    """A table as CSV: a header of ``columns``, floats to 6 digits, NaN as an empty cell."""
    with open(path, "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow(columns)
        for row in rows:
            writer.writerow([_cell(row[c]) for c in columns])


def markdown_table(columns: Sequence[str], rows: Sequence[Mapping[str, Cell]]) -> list[str]:
    """A table as Markdown lines: floats to 4 digits, NaN as ``-``."""
    def short(value: Cell) -> str:
        if isinstance(value, float):
            return "-" if math.isnan(value) else f"{value:.4g}"
        return str(value)

    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(short(r[c]) for c in columns) + " |" for r in rows]
    return lines


TABLE_FILES = ("summary.csv", "tests_per_run.csv", "tests_pooled_descriptive.csv",
               "curve_tests.csv", "summary.md")
"""Files written by :func:`write_tables`, in order."""

INCLUDED_COLUMNS = ("experiment", "folder", "set", "mode", "runs", "births_budget",
                    "births_reached", "lost_robots", "failed_births")
"""Columns of the table of what a report compares (:func:`included_rows`)."""


@dataclass(frozen=True, slots=True)
class Section:
    """One section of ``summary.md`` and ``index.html``: text, then a table.

    Attributes:
        title: Its heading.
        text: Paragraphs; one starting with ``- `` is a list item. Backticks mark code.
        columns: The table's columns (none: no table).
        rows: The table's rows (cells by column).
        empty: Said instead of the table when it has no rows.
        name: A short stable name (the HTML table's id).
    """

    title: str
    text: tuple[str, ...]
    columns: tuple[str, ...] = ()
    rows: tuple[Mapping[str, Cell], ...] = ()
    empty: str = ""
    name: str = ""


_FITNESS_NOTE = (
    "Fitness in metres (f = v + 5 s). Offline experiments: the fitness of each robot's isolated "
    "evaluation. Online (scenario 3): the robot's sliding-window fitness over its last "
    "evaluation window in the shared, crowded world: a different measurement, so offline and "
    "online values are not directly comparable. Diversity: mean pairwise tree edit distance of "
    "the bodies (edits). `births_budget` and `births_reached_min` count births as the engines "
    "do (the runs' budget); `births_mean` counts robots delivered with failed births (lost "
    "before their first fitness) left out and counted in `failed_births`; `lost_robots` counts "
    "every robot lost to a blow-up or a failed evaluation, stored without a fitness and never "
    "counted as 0 m.")


def included_rows(included: Included) -> list[dict[str, Cell]]:
    """One row per experiment compared: its folder, set, budget, births reached and losses."""
    base = included.root if included.root.is_dir() else included.root.parent
    rows: list[dict[str, Cell]] = []
    for e in included.experiments:
        reached = sorted({r.engine_births for r in e.runs})
        span = "-" if not reached else (str(reached[0]) if len(reached) == 1
                                         else f"{reached[0]}-{reached[-1]}")
        try:
            folder = e.path.relative_to(base).as_posix() or "."
        except ValueError:
            folder = str(e.path)
        rows.append({"experiment": e.label, "folder": folder,
                     "set": f"study {e.study}" if e.study is not None else "outside any study",
                     "mode": str(e.config.get("mode", "")), "runs": len(e.runs),
                     "births_budget": e.budget, "births_reached": span,
                     "lost_robots": sum(r.lost_robots for r in e.runs),
                     "failed_births": sum(int(r.failed_births.size) for r in e.runs)})
    return rows


def _included_text(included: Included) -> tuple[str, ...]:
    sets = sorted({str(e.study) if e.study is not None else "" for e in included.experiments})
    text = [f"The experiments below `{included.root}` that this report compares"
            + (", from several sets (every set was asked for)" if len(sets) > 1 else "")
            + ". `births_budget`: births per run asked for; `births_reached`: what the runs "
              "reached (both counted as the engines count, failed births included); "
              "`lost_robots`: robots lost to blow-ups or failed evaluations, `failed_births` "
              "those of them lost before their first fitness."]
    left = [s.describe() for s in included.left_out]
    if left:
        text.append("Left out (a report compares one set: a study, or the experiments outside "
                    "any study): " + "; ".join(left) + f". Report them with `revolve report "
                    f"FOLDER`, or all together with `revolve report {included.root} --all`.")
    if included.budgets_differ:
        text.append(
            "Budgets differ: not every run reached the same births. Every pair is compared at "
            "the most births both reached (the `births` column of the tests), each run by its "
            "population at the last commit point at or before them; curves only over that "
            "common range; the figures of final populations show every run at "
            f"{included.common_births} births, the most every run reached.")
    return tuple(text)


def _test_text(samples: dict[str, str]) -> tuple[str, ...]:
    return (*[f"- `{name}`: {text}" for name, text in samples.items()],
            "- `births`: where the pair is compared, the most births every run of both reached "
            "(engine births): each run's population at the last commit point at or before them",
            "- `lost_a`, `lost_b`: robots lost by each side's runs among those births (not in "
            "the values: a lost robot has no fitness)",
            "- `p_min`: the smallest p Mann-Whitney can give with these n (0.1 with 3 runs "
            "against 3): a p at its floor is the strongest result the study can show",
            "- `p_holm`: Holm-Bonferroni correction over the pairs of one sample",
            "- `a12`: Vargha-Delaney A12 of A over B (0.5: no effect; 1: every A above every "
            "B); [a12_ci_low, a12_ci_high]: its 95 % interval, the A12 values an exact test "
            "does not reject (it excludes 0.5 exactly when p < 0.05 with small samples; "
            "docs/reports.md)")


def sections(included: Included, tables: Mapping[str, list[dict[str, Cell]]]
             ) -> list[Section]:
    """The report's tables with what they mean, in the order of ``summary.md``."""
    columns = summary_columns(included.experiments)
    learning = (("Learning: `inborn_fitness_mean` and `learned_fitness_mean` are the infants' "
                 "fitness with their inborn and learned controllers as the learner measured them "
                 "(its own evaluation window); `learning_gain_mean` is their mean difference; "
                 "`learner_failures` counts infants that kept their inborn controller because "
                 "the learner failed."),) if columns != SUMMARY_COLUMNS else ()
    none = "(fewer than two experiments with values)"
    return [
        Section("What this report compares", _included_text(included), INCLUDED_COLUMNS,
                tuple(included_rows(included)), name="included"),
        Section("Experiments", (_FITNESS_NOTE, *learning), columns, tuple(tables["summary"]),
                name="summary"),
        Section("Primary tests: one value per run (two-sided Mann-Whitney U, Holm-Bonferroni)",
                _test_text(TESTED_SAMPLES), MANN_WHITNEY_COLUMNS, tuple(tables["per_run"]),
                none, "tests_per_run"),
        Section("Whole curves at equal births (per run, Mann-Whitney U, Holm-Bonferroni over "
                "the births of a pair)",
                ("Population mean fitness of each run at 10 %, 20 %, ... 100 % of the births "
                 f"both experiments reached; a point counts when p_holm < {ALPHA} (A12 says "
                 "the side). Like with like: offline experiments are paired with offline ones "
                 "and online with online (an online curve is sliding-window fitness in a shared "
                 "world, not the same measurement at the same births). Point by point: "
                 "`curve_tests.csv`.",),
                CURVE_SUMMARY_COLUMNS, tuple(curve_summary_rows(tables["curve"])),
                "(no pair to compare)", "curve_summary"),
        Section("Shaking: is evolution paid for vibration?",
                ("The shaking measure of a robot (offline evaluations) is the path of its core "
                 "summed at every control period over the path summed at its task's pose rate "
                 "(`pose_rate`; `every-period` gives 1, stored runs made before pose rates "
                 "have it): 1 for a smooth walker, 2 when half its path is motion between "
                 "pose samples (tremor, rocking in place). Fittest: the 10 % fittest measured "
                 "robots. A fittest median well above the median says that the fitness pays "
                 "for shaking (docs/experiments.md).",),
                SHAKING_COLUMNS, tuple(tables["shaking"]), "(no robot with a shaking measure)",
                "shaking"),
                Section("Descriptive only: pooled populations (no p-values shown)",
                ("Robots of one run share their ancestry and world, so they are not "
                 "independent samples: a test on them counts every robot as a sample and gives "
                 "p-values far smaller than the data support. The tests of this report are the "
                 "per-run tests above. This table therefore shows only the pooled medians and "
                 "A12 as a description; its p-values are left out of this page and of "
                 "summary.md, and kept only in `tests_pooled_descriptive.csv`.",
                 *[t for t in _test_text(POOLED_SAMPLES) if not t.startswith("- `p_")]),
                POOLED_SHOWN_COLUMNS, tuple(tables["pooled"]), none, "tests_pooled"),
    ]


def markdown(section: Section) -> list[str]:
    """A section as Markdown lines (a level-2 heading, its text, its table)."""
    lines = ["", f"## {section.title}", ""]
    for paragraph in section.text:
        lines.append(paragraph)
        if not paragraph.startswith("- "):
            lines.append("")
    if section.text and section.text[-1].startswith("- "):
        lines.append("")
    if section.columns:
        lines += markdown_table(section.columns, list(section.rows)) if section.rows else [
            section.empty]
    return lines


def write_tables(included: Included, out_dir: Path) -> tuple[tuple[Path, ...], list[Section]]:
    """Write the files of :data:`TABLE_FILES` into ``out_dir``; the paths and the sections."""
    experiments = included.experiments
    tables = {"summary": summary_rows(experiments), "per_run": mann_whitney_rows(experiments),
              "pooled": pooled_rows(experiments), "curve": curve_rows(experiments),
              "shaking": shaking_rows(experiments)}
    paths = tuple(out_dir / name for name in TABLE_FILES)
    write_csv(paths[0], summary_columns(experiments), tables["summary"])
    write_csv(paths[1], MANN_WHITNEY_COLUMNS, tables["per_run"])
    write_csv(paths[2], MANN_WHITNEY_COLUMNS, tables["pooled"])
    write_csv(paths[3], CURVE_COLUMNS, tables["curve"])
    parts = sections(included, tables)
    lines = ["# Summary"] + [line for part in parts for line in markdown(part)]
    paths[4].write_text("\n".join(lines) + "\n", encoding="utf-8")
    return paths, parts
