"""The paper's figures from :class:`~evolution.reporting.data.ExperimentData`.

Every figure has a title, axis labels with units, a legend and a caption saved inside it (the
bottom row), so it reads without this text. Experiments are labelled by
:attr:`ExperimentData.title` in report order, each with one colour in every figure
(:func:`colors`). Curves over births show the median over runs as a line and the interquartile
range as a band; offline curves are steps (a population changes once per generation), online
ones join their samples. Offline and online fitness are different measurements and never share
an axis: offline, the fitness of a robot's isolated evaluation; online, its sliding-window
fitness in the shared world. Births are counted as :mod:`evolution.reporting.data` says (failed
births left out; ``failed_births`` draws them apart).

Figures are drawn on ``matplotlib.figure.Figure`` objects directly (no ``pyplot``), so nothing
depends on a display or on the global backend: PNG is written by Agg, PDF by the PDF backend.
"""

from __future__ import annotations

import textwrap
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from evolution.reporting.data import PAPER_ORDER, ExperimentData, runs_on_grid
from evolution.reporting.stats import ALPHA, CURVE_FRACTIONS
from evolution.reporting.tables import curve_rows

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "FIGURES",
    "LEARNING_FIGURES",
    "colors",
    "curve_tests",
    "diversity_over_births",
    "failed_births",
    "final_diversity",
    "final_fitness",
    "fitness_over_births",
    "learning_gain",
    "write_figures",
]

PAPER_COLORS = {"scenario1": "#1f77b4", "scenario2": "#d62728", "scenario3": "#2ca02c",
                "baseline_a": "#7f7f7f", "baseline_b": "#ff7f0e"}
"""The colour of each of the paper's experiments."""

_OTHER_COLORS = ("#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22")

OFFLINE_FITNESS = ("Offline: fitness f = v + 5 s (m) of each robot's isolated evaluation "
                   "(alone at the origin, after the insertion time)")
ONLINE_FITNESS = ("Online: sliding-window fitness f = v + 5 s (m) over the robot's last "
                  "evaluation window while it lives in the shared, crowded world")
BIRTHS = ("Births: robots delivered; a robot lost before its first fitness (blow-up, unbuildable "
          "body, non-finite fitness) is a failed birth, left out of the births axis and counted "
          "in failed_births.png.")
BAND = ("Line: median over runs; band: interquartile range (25th-75th percentile) over runs; "
        "dashed: births only some runs reached (a run that lost robots ends at fewer births).")


def colors(experiments: Sequence[ExperimentData]) -> dict[str, str]:
    """One colour per experiment label: fixed for the paper's five, the others in order."""
    out: dict[str, str] = {}
    others = 0
    for e in experiments:
        if e.name in PAPER_ORDER and PAPER_COLORS[e.name] not in out.values():
            out[e.label] = PAPER_COLORS[e.name]
        else:
            out[e.label] = _OTHER_COLORS[others % len(_OTHER_COLORS)]
            others += 1
    return out


def _figure(width: float, height: float, caption: str, ncols: int = 1, nrows: int = 1
            ) -> tuple[Figure, list[list[Axes]]]:
    """A figure of ``nrows x ncols`` axes above a caption of wrapped text.

    The caption is its own subfigure, so it spans the whole width whatever the axes' margins.
    """
    from matplotlib.figure import Figure

    lines = textwrap.wrap(caption, width=int(width * 16), break_on_hyphens=False)
    caption_height = 0.16 * len(lines) + 0.12
    figure = Figure(figsize=(width, height + caption_height), layout="constrained")
    parts = figure.subfigures(2, 1, height_ratios=[height, caption_height])
    assert isinstance(parts, np.ndarray)  # two subfigures come as an array
    top, bottom = parts
    axes = top.subplots(nrows, ncols, squeeze=False)
    bottom.text(0.01, 0.98, "\n".join(lines), va="top", ha="left", fontsize=8)
    return figure, [list(row) for row in axes]


def _band(ax: Axes, grid: np.ndarray, values: np.ndarray, color: str, label: str,
          steps: bool) -> None:
    """Median over runs as a line (steps when ``steps``), interquartile range as a band.

    Solid where every run has reached those births; dashed beyond (the runs that got further,
    e.g. when some runs were interrupted).
    """
    from matplotlib.ticker import MaxNLocator

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # births no run reached
        median = np.nanmedian(values, axis=0)
        low, high = np.nanpercentile(values, [25, 75], axis=0)
    n = values.shape[0]
    everyone = np.sum(np.isfinite(values), axis=0) == n
    style = "steps-post" if steps else "default"
    marker = "o" if grid.size <= 25 and not steps else None
    ax.plot(grid, np.where(everyone, median, np.nan), color=color, lw=1.5, marker=marker, ms=3,
            drawstyle=style, label=f"{label} ({n} run{'s' * (n != 1)})")
    if steps and grid.size:  # the last generation's step has no width: a dot shows its value
        ax.plot(grid[-1:], median[-1:], color=color, marker="o", ms=3)
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    if not everyone.all():
        last = int(np.flatnonzero(everyone)[-1]) if everyone.any() else 0
        partial = np.where(np.arange(grid.size) >= last, median, np.nan)
        ax.plot(grid, partial, color=color, lw=1.0, ls="--", drawstyle=style)
    if n > 1:
        ax.fill_between(grid, low, high, color=color, alpha=0.2, lw=0,
                        step="post" if steps else None)


def _groups(experiments: Sequence[ExperimentData]) -> list[tuple[str, list[ExperimentData]]]:
    """Offline and online experiments apart (each group only when it has experiments)."""
    offline = [e for e in experiments if not e.online]
    online = [e for e in experiments if e.online]
    return [(name, group) for name, group in (("offline", offline), ("online", online)) if group]


def fitness_over_births(experiments: Sequence[ExperimentData]) -> Figure:
    """Population mean (left) and best (right) fitness over births; offline and online apart."""
    groups = _groups(experiments) or [("offline", [])]
    caption = (f"Fitness of the population over births, per experiment. {BAND} "
               f"Offline curves are steps: the population changes once per generation. "
               f"{OFFLINE_FITNESS}. {ONLINE_FITNESS}. The two are different measurements and "
               f"get separate rows. {BIRTHS}")
    figure, axes = _figure(11.0, 3.8 * len(groups), caption, 2, len(groups))
    palette = colors(experiments)
    for (kind, group), (left, right) in zip(groups, axes, strict=True):
        for e in group:
            if not e.runs:
                continue
            xs = [r.fitness.births for r in e.runs]
            for ax, ys in ((left, [r.fitness.mean for r in e.runs]),
                           (right, [r.fitness.best for r in e.runs])):
                grid, values = runs_on_grid(xs, ys)
                _band(ax, grid, values, palette[e.label], e.title, steps=not e.online)
        what = "isolated evaluation" if kind == "offline" else "sliding window, shared world"
        for ax, stat in ((left, "mean"), (right, "best")):
            ax.set_xlabel("births")
            ax.set_ylabel(f"{stat} fitness (m)")
            ax.set_title(f"{kind.capitalize()}: population {stat} fitness ({what})",
                         fontsize="medium")
            ax.grid(alpha=0.3)
        if left.lines:
            left.legend(fontsize="small")
    figure.suptitle("Fitness over births")
    return figure


def _boxes(ax: Axes, data: list[np.ndarray], points: list[np.ndarray], labels: list[str],
           palette: list[str]) -> None:
    """Box plots of ``data`` with ``points`` (one per run) drawn over each box."""
    positions = list(range(1, len(data) + 1))
    kept = [(p, d) for p, d in zip(positions, data, strict=True) if d.size]
    if kept:
        box = ax.boxplot([d for _, d in kept], positions=[p for p, _ in kept], widths=0.6,
                         patch_artist=True, medianprops={"color": "black"}, showfliers=False)
        for patch, (p, _) in zip(box["boxes"], kept, strict=True):
            patch.set_facecolor(palette[p - 1])
            patch.set_alpha(0.35)
    rng = np.random.default_rng(0)  # jitter only, so a report is reproducible
    for p, values in zip(positions, points, strict=True):
        if values.size:
            x = p + rng.uniform(-0.12, 0.12, values.size)
            ax.scatter(x, values, s=22, marker="D", color=palette[p - 1], edgecolor="black",
                       lw=0.6, zorder=3, label="one run" if p == positions[0] else None)
    ax.set_xticks(positions, labels, rotation=15, fontsize="small")
    ax.set_xlim(0.4, len(data) + 0.6)
    ax.grid(axis="y", alpha=0.3)


def final_fitness(experiments: Sequence[ExperimentData]) -> Figure:
    """Box plots of the final populations' fitness (robots pooled) with per-run means."""
    groups = _groups(experiments) or [("offline", [])]
    caption = ("Fitness of the final populations. Box: every robot of every run's final "
               "population (whiskers 1.5 IQR, outliers hidden); diamonds: each run's mean, "
               "the values the per-run tests compare. "
               f"{OFFLINE_FITNESS}. {ONLINE_FITNESS}: a separate panel.")
    widths = [max(1, len(g)) for _, g in groups]
    figure, axes = _figure(max(5.5, 1.6 * sum(widths) + 2.5), 4.2, caption, len(groups))
    palette = colors(experiments)
    for (kind, group), ax in zip(groups, axes[0], strict=True):
        _boxes(ax, [e.final_fitness() for e in group], [e.final_run_means() for e in group],
               [f"{e.title}\n({len(e.runs)} runs, {e.final_fitness().size} robots)"
                for e in group], [palette[e.label] for e in group])
        ax.set_ylabel("fitness (m)")
        ax.set_title(f"{kind.capitalize()} fitness", fontsize="medium")
        if group:
            ax.legend(fontsize="small", loc="upper right")
    figure.suptitle("Final populations")
    return figure


def diversity_over_births(experiments: Sequence[ExperimentData]) -> Figure:
    """Population diversity over births (and the brain-aware one when it was computed)."""
    brain = any(r.brain_diversity.size for e in experiments for r in e.runs)
    panels = [("diversity", "Body diversity (tree edit distance)")]
    if brain:
        panels.append(("brain_diversity", "Brain-aware diversity (body + neural distance)"))
    caption = ("Genetic diversity of the population over births: mean pairwise tree edit "
               "distance of the bodies (the paper's costs: insert, remove, change type, change "
               "slot each cost 1)"
               + ("; right: plus the neural distance of matched parts (evolution.diversity)"
                  if brain else "")
               + f", measured every diversity_interval births. {BAND} Offline: steps. {BIRTHS}")
    figure, axes = _figure(6.5 * len(panels), 4.0, caption, len(panels))
    palette = colors(experiments)
    for (field, what), ax in zip(panels, axes[0], strict=True):
        for e in experiments:
            runs = [r for r in e.runs if getattr(r, field).size]
            if not runs:
                continue
            grid, values = runs_on_grid([r.diversity_births for r in runs],
                                        [getattr(r, field) for r in runs])
            _band(ax, grid, values, palette[e.label], e.title, steps=not e.online)
        ax.set_xlabel("births")
        ax.set_ylabel("mean pairwise distance (edits)")
        ax.set_title(what, fontsize="medium")
        ax.grid(alpha=0.3)
        if ax.lines:
            ax.legend(fontsize="small")
    figure.suptitle("Diversity over births")
    return figure


def final_diversity(experiments: Sequence[ExperimentData]) -> Figure:
    """Box plots of each run's final diversity (and brain-aware diversity when computed)."""
    brain = any(e.final_brain_diversities().size for e in experiments)
    panels = [("body", [e.final_diversities() for e in experiments])]
    if brain:
        panels.append(("brain-aware", [e.final_brain_diversities() for e in experiments]))
    caption = ("Diversity of the final populations, one value per run (diamonds; the box "
               "summarises them): mean pairwise tree edit distance of the bodies"
               + ("; below: body plus neural distance" if brain else "") + ", in edits.")
    figure, axes = _figure(max(5.5, 1.5 * len(experiments) + 2.5), 4.2 * len(panels),
                           caption, 1, len(panels))
    palette = [colors(experiments)[e.label] for e in experiments]
    for (what, data), (ax,) in zip(panels, axes, strict=True):
        _boxes(ax, data, data, [f"{e.title}\n(n={d.size})" for e, d in
                                zip(experiments, data, strict=True)], palette)
        ax.set_ylabel(f"{what} diversity (edits)")
        ax.set_title(f"{what.capitalize()} diversity", fontsize="medium")
    figure.suptitle("Diversity of the final populations")
    return figure


def failed_births(experiments: Sequence[ExperimentData]) -> Figure:
    """Cumulative failed births over births, each run a step line."""
    caption = ("Failed births over births: robots lost before their first fitness (a blow-up "
               "in the isolated evaluation or before the first sample in the shared world, a "
               "body the engine could not build, a non-finite fitness), counted apart from the "
               "births on the x axis. One step line per run; the legend gives the total over "
               "runs and the robots lost later in life (online blow-ups of living robots).")
    figure, ((ax,),) = _figure(7.0, 3.6, caption)
    palette = colors(experiments)
    for e in experiments:
        total = sum(int(r.failed_births.size) for r in e.runs)
        lost = sum(r.lost_robots for r in e.runs)
        for k, r in enumerate(e.runs):
            x, y = r.failed_births_over_births()
            x = np.concatenate([[0], x, [r.births]])
            y = np.concatenate([[0], y, [y[-1] if y.size else 0]])
            ax.plot(x, y, drawstyle="steps-post", color=palette[e.label], lw=1.2, alpha=0.8,
                    label=(f"{e.title}: {total} failed, {lost - total} lost later"
                           if k == 0 else None))
    ax.set_xlabel("births")
    ax.set_ylabel("failed births so far (robots)")
    ax.set_title("Failed births (blow-ups and failed evaluations)", fontsize="medium")
    ax.grid(alpha=0.3)
    if ax.lines:
        ax.legend(fontsize="small")
    return figure


def curve_tests(experiments: Sequence[ExperimentData]) -> Figure:
    """A12 of every pair at equal births (colour), ``*`` where significant after Holm."""
    rows = curve_rows(experiments)
    pairs = list(dict.fromkeys((str(r["experiment_a"]), str(r["experiment_b"])) for r in rows))
    titles = {e.label: e.title for e in experiments}
    caption = ("Whole-curve comparison at equal births: for every pair A vs B, each run's "
               "population mean fitness at 10 %, 20 %, ... 100 % of the births both reached, "
               "two-sided Mann-Whitney U per point, Holm-Bonferroni over the points of a pair. "
               "Colour: Vargha-Delaney A12 (1: every run of A above every run of B; 0.5: no "
               "effect; blank: no value on one side); *: p_holm < 0.05; n: runs per side. "
               "Offline and online fitness are different measurements (see "
               "fitness_over_births).")
    figure, ((ax,),) = _figure(10.0, max(2.5, 0.4 * len(pairs) + 1.4), caption)
    matrix = np.full((max(1, len(pairs)), len(CURVE_FRACTIONS)), np.nan)
    sizes: dict[tuple[str, str], str] = {}
    for r in rows:
        pair = (str(r["experiment_a"]), str(r["experiment_b"]))
        i, j = pairs.index(pair), int(r["point"])
        matrix[i, j] = float(r["a12"])
        sizes[pair] = f"n={r['n_a']}/{r['n_b']}"
        mark = "*" if float(r["p_holm"]) < ALPHA else ""
        ax.text(j, i, f"{int(r['births'])}{mark}", ha="center", va="center", fontsize=7)
    image = ax.imshow(matrix, cmap="RdBu_r", vmin=0.0, vmax=1.0, aspect="auto")
    figure.colorbar(image, ax=ax, label="A12 (A over B)")
    ax.set_yticks(range(len(pairs)), [f"{titles[a]} vs {titles[b]} ({sizes[(a, b)]})"
                                      for a, b in pairs], fontsize="small")
    ax.set_xticks(range(len(CURVE_FRACTIONS)), [f"{round(100 * f)}" for f in CURVE_FRACTIONS])
    ax.set_xlabel("births, % of those both reached (cell text: births; *: p_holm < 0.05)")
    ax.set_title("Population mean fitness, A vs B at equal births", fontsize="medium")
    return figure


FIGURES: dict[str, Callable[[Sequence[ExperimentData]], Figure]] = {
    "fitness_over_births": fitness_over_births,
    "final_fitness": final_fitness,
    "diversity_over_births": diversity_over_births,
    "final_diversity": final_diversity,
    "failed_births": failed_births,
    "curve_tests": curve_tests,
}
"""Figure file stems and the functions drawing them."""


def learning_gain(experiments: Sequence[ExperimentData]) -> Figure:
    """Box plots of the infants' inborn and learned fitness, for each experiment that learns.

    Each fitness is the one the infant's learner measured.
    """
    learners = [e for e in experiments if e.learns]
    caption = ("Infancy learning: each infant's fitness (m) with its inborn and its learned "
               "controller, both as its learner measured them (the Training Center's own "
               "evaluation window, not the robot's fitness in the run); diamonds: each run's "
               "mean.")
    figure, ((ax,),) = _figure(max(5.5, 2.2 * len(learners) + 2.5), 4.0, caption)
    palette = colors(experiments)
    data: list[np.ndarray] = []
    points: list[np.ndarray] = []
    labels: list[str] = []
    shades: list[str] = []
    for e in learners:
        inborn, learned = e.learning_fitness()
        gain = float((learned - inborn).mean()) if inborn.size else float("nan")
        data += [inborn, learned]
        points += [np.array([r.inborn_fitness.mean() for r in e.runs if r.inborn_fitness.size]),
                   np.array([r.learned_fitness.mean() for r in e.runs
                             if r.learned_fitness.size])]
        labels += [f"{e.title}\ninborn (n={inborn.size})",
                   f"{e.title}\nlearned (gain {gain:+.3g} m)"]
        shades += [palette[e.label]] * 2
    _boxes(ax, data, points, labels, shades)
    ax.set_ylabel("fitness in the Training Center (m)")
    ax.set_title("Infancy learning: inborn vs learned controller")
    return figure


LEARNING_FIGURES: dict[str, Callable[[Sequence[ExperimentData]], Figure]] = {
    "learning_gain": learning_gain,
}
"""Figures drawn only when an experiment learns."""


def write_figures(
    experiments: Sequence[ExperimentData], out_dir: Path, formats: Sequence[str] = ("png", "pdf")
) -> tuple[Path, ...]:
    """Draw every figure of :data:`FIGURES` and save it in each format; returns the paths.

    The figures of :data:`LEARNING_FIGURES` are drawn too when an experiment learns.
    """
    written = []
    figures = dict(FIGURES)
    if any(e.learns for e in experiments):
        figures.update(LEARNING_FIGURES)
    for stem, draw in figures.items():
        written += save_figure(draw(experiments), out_dir, stem, formats)
    return tuple(written)


def save_figure(figure: Figure, out_dir: Path, stem: str, formats: Sequence[str]) -> list[Path]:
    """Save ``figure`` as ``out_dir/<stem>.<fmt>`` for each format (150 dpi); the paths."""
    paths = [out_dir / f"{stem}.{fmt}" for fmt in formats]
    for path in paths:
        figure.savefig(path, dpi=150)
    return paths
