"""The paper's figures from :class:`~evolution.reporting.data.ExperimentData`.

Every figure has a title, axis labels with units, a legend below its panels (never over the
data) and a caption saved inside it, so it reads without this text. Experiments are labelled by
:attr:`ExperimentData.title` in report order, each with one colour-blind-safe colour in every
figure (:mod:`evolution.reporting.style`). Curves over births draw every run as a thin line and
the median over runs as a thick one; offline curves are steps (a population changes once per
generation), online ones join their samples. Distributions draw every value as a point over a
box, so no run and no outlier hides.

Offline and online fitness are different measurements (offline: the fitness of a robot's
isolated evaluation; online: its sliding-window fitness in the shared world), so they get
separate panels, but side by side on one y-scale, so they can be compared by eye. Births are
counted as :mod:`evolution.reporting.data` says (failed births left out of the axes); robots lost
to blow-ups are never drawn as 0 m: they have no fitness, and every figure counts them apart.
When the runs reached different births, the figures of populations show every run at the most
births all of them reached (like with like), and the curves mark that point.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from evolution.reporting.data import ExperimentData, common_births, runs_on_grid
from evolution.reporting.stats import ALPHA, CURVE_FRACTIONS
from evolution.reporting.style import (
    colors,
    every_tick_label,
    legend_below,
    new_figure,
    points_over_box,
    runs_and_median,
    styled,
    text_color,
    tick_label,
)
from evolution.reporting.tables import curve_rows

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "FIGURES",
    "FIGURE_DPI",
    "LEARNING_FIGURES",
    "curve_tests",
    "diversity_over_births",
    "final_diversity",
    "final_fitness",
    "fitness_over_births",
    "learning_gain",
    "lost_robots",
    "save_figure",
    "write_figures",
]

OFFLINE_FITNESS = ("Offline: fitness f = v + 5 s (m) of each robot's isolated evaluation "
                   "(alone at the origin, after the insertion time)")
ONLINE_FITNESS = ("Online: sliding-window fitness f = v + 5 s (m) over the robot's last "
                  "evaluation window while it lives in the shared, crowded world")
BIRTHS = ("Births: robots delivered; a robot lost before its first fitness (blow-up, unbuildable "
          "body, non-finite fitness) is a failed birth, left out of the births axis; lost robots "
          "have no fitness (never 0 m) and are counted in the legend and in lost_robots.png.")
FIGURE_DPI = 150
"""Pixels per inch of the PNG figures (the page shows each at its size in inches, so that the
text of every figure reads at one size)."""

RUNS = "Thin lines: each run; thick line: the median over runs (where every run has a value)."


def _groups(experiments: Sequence[ExperimentData]) -> list[tuple[str, list[ExperimentData]]]:
    """Offline and online experiments apart (each group only when it has experiments)."""
    offline = [e for e in experiments if not e.online]
    online = [e for e in experiments if e.online]
    return [(name, group) for name, group in (("offline", offline), ("online", online)) if group]


def _label(e: ExperimentData) -> str:
    """An experiment's legend entry: its title, runs and lost robots."""
    n = len(e.runs)
    return f"{e.title}: {n} run{'s' * (n != 1)}, {sum(r.lost_robots for r in e.runs)} lost"


def _mark_common(axes: Sequence[Axes], experiments: Sequence[ExperimentData]) -> Artist | None:
    """A dotted vertical line at the births every run reached, when the runs differ.

    Only where the births axis and the engine's count agree (no failed births): elsewhere the
    point lies at different births of each run's axis, and the caption says it instead.
    """
    reached = {r.engine_births for e in experiments for r in e.runs}
    failed = any(r.failed_births.size for e in experiments for r in e.runs)
    if len(reached) <= 1 or failed:
        return None
    common = common_births(experiments)
    line = None
    for ax in axes:
        line = ax.axvline(common, color="0.25", ls=":", lw=1.2)
    return line


def _compared_note(experiments: Sequence[ExperimentData]) -> str:
    """What the caption says when the runs reached different births."""
    if len({r.engine_births for e in experiments for r in e.runs}) <= 1:
        return ""
    return (f" The runs reached different births: the tests compare each pair at the most "
            f"births both reached, and every run reached {common_births(experiments)} births "
            "(as the engines count them, failed births included).")


@styled
def fitness_over_births(experiments: Sequence[ExperimentData]) -> Figure:
    """Population mean (top) and best (bottom) fitness over births.

    Offline and online side by side, on one y-scale per row.
    """
    groups = _groups(experiments) or [("offline", [])]
    caption = (f"Fitness of the population over births, per experiment. {RUNS} Offline curves "
               "are steps: the population changes once per generation. "
               f"{OFFLINE_FITNESS}. {ONLINE_FITNESS}. The two are different measurements and "
               "get separate panels, on one y-scale per row so they can be compared by eye. "
               f"{BIRTHS}{_compared_note(experiments)}")
    figure, top, axes = new_figure(5.5 * len(groups) + 1.0, 7.4, caption, len(groups), 2,
                                   sharey="row", sharex=True)
    palette = colors(experiments)
    handles: list[Artist] = []
    labels: list[str] = []
    for column, (kind, group) in enumerate(groups):
        mean_ax, best_ax = axes[0][column], axes[1][column]
        for e in group:
            if not e.runs:
                continue
            xs = [r.fitness.births for r in e.runs]
            for ax, ys in ((mean_ax, [r.fitness.mean for r in e.runs]),
                           (best_ax, [r.fitness.best for r in e.runs])):
                grid, values = runs_on_grid(xs, ys)
                line = runs_and_median(ax, grid, values, palette[e.label], steps=not e.online)
            handles.append(line)
            labels.append(_label(e))
        what = "isolated evaluation" if kind == "offline" else "sliding window, shared world"
        for ax, stat in ((mean_ax, "mean"), (best_ax, "best")):
            ax.set_ylabel(f"population {stat} fitness (m)")
            ax.set_title(f"{kind.capitalize()}: population {stat} ({what})")
            ax.grid(alpha=0.3)
        best_ax.set_xlabel("births")
    every_tick_label([ax for row in axes for ax in row])  # the online panels too
    common = _mark_common([ax for row in axes for ax in row], experiments)
    if common is not None:
        handles.append(common)
        labels.append(f"{common_births(experiments)} births: the most every run reached")
    legend_below(top, handles, labels, ncols=2)
    top.suptitle("Fitness over births")
    return figure


def _population_title(experiments: Sequence[ExperimentData]) -> tuple[int, str]:
    """The births the population figures show, and how to say it."""
    births = common_births(experiments)
    final = all(r.engine_births == births for e in experiments for r in e.runs)
    return births, ("final populations" if final else
                    f"populations at {births} births (the most every run reached)")


@styled
def final_fitness(experiments: Sequence[ExperimentData]) -> Figure:
    """Every robot's fitness in the compared populations, over a box, with each run's mean.

    Offline and online side by side, on one y-scale.
    """
    groups = _groups(experiments) or [("offline", [])]
    births, what = _population_title(experiments)
    caption = (f"Fitness in the {what}. Dots: every robot of every run's population (none "
               "hidden, outliers included); box: their quartiles, whiskers 1.5 IQR; diamonds: "
               "each run's mean, the values the per-run tests compare. Lost robots have no "
               "fitness and are counted under each experiment. "
               f"{OFFLINE_FITNESS}. {ONLINE_FITNESS}: a separate panel on the same y-scale.")
    widths = [max(1, len(g)) for _, g in groups]
    figure, top, axes = new_figure(max(6.0, 1.8 * sum(widths) + 2.0), 4.8, caption,
                                   len(groups), sharey=True, width_ratios=widths)
    palette = colors(experiments)
    rng = np.random.default_rng(0)  # jitter only, so a report is reproducible
    from matplotlib.lines import Line2D

    for (kind, group), ax in zip(groups, axes[0], strict=True):
        names = []
        for p, e in enumerate(group, start=1):
            populations = e.populations_at(births)
            robots = [pop.fitness for pop in populations]
            pooled = np.concatenate(robots) if robots else np.zeros(0)
            points_over_box(ax, p, pooled, palette[e.label], rng)
            means = np.array([f.mean() for f in robots if f.size])
            ax.scatter(p + rng.uniform(-0.08, 0.08, means.size), means, s=42, marker="D",
                       color=palette[e.label], edgecolor="black", lw=0.8, zorder=4)
            names.append(tick_label(e.title, f"{len(e.runs)} runs, {pooled.size} robots",
                                    f"{e.lost_before(births)} lost"))
        ax.set_xticks(range(1, len(group) + 1), names)
        ax.set_xlim(0.4, len(group) + 0.6)
        ax.set_ylabel("fitness (m)")
        ax.set_title(f"{kind.capitalize()} fitness")
        ax.grid(axis="y", alpha=0.3)
    every_tick_label(axes[0])  # the online panel too
    key = [Line2D([], [], ls="", marker="o", color="0.4", ms=4),
           Line2D([], [], ls="", marker="D", color="0.6", markeredgecolor="black", ms=6)]
    legend_below(top, key, ["one robot", "one run's mean"])
    top.suptitle(f"Fitness of the {what}")
    return figure


@styled
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
               + f", measured every diversity_interval births. {RUNS} Offline: steps. The "
                 f"same measurement offline and online: one panel. {BIRTHS}"
                 f"{_compared_note(experiments)}")
    figure, top, axes = new_figure(6.5 * len(panels) + 0.5, 4.2, caption, len(panels))
    palette = colors(experiments)
    handles: list[Artist] = []
    labels: list[str] = []
    for (field, what), ax in zip(panels, axes[0], strict=True):
        for e in experiments:
            runs = [r for r in e.runs if getattr(r, field).size]
            if not runs:
                continue
            grid, values = runs_on_grid([r.diversity_births for r in runs],
                                        [getattr(r, field) for r in runs])
            line = runs_and_median(ax, grid, values, palette[e.label], steps=not e.online)
            if field == "diversity":
                handles.append(line)
                labels.append(_label(e))
        ax.set_xlabel("births")
        ax.set_ylabel("mean pairwise distance (edits)")
        ax.set_title(what)
        ax.grid(alpha=0.3)
    common = _mark_common(axes[0], experiments)
    if common is not None:
        handles.append(common)
        labels.append(f"{common_births(experiments)} births: the most every run reached")
    legend_below(top, handles, labels, ncols=2)
    top.suptitle("Diversity over births")
    return figure


@styled
def final_diversity(experiments: Sequence[ExperimentData]) -> Figure:
    """Each run's diversity in the compared populations (and brain-aware when computed)."""
    births, what = _population_title(experiments)
    body = [np.array([p.diversity for p in e.populations_at(births)]) for e in experiments]
    brain = [np.array([p.brain_diversity for p in e.populations_at(births)])
             for e in experiments]
    panels = [("body", body)]
    if any(np.isfinite(b).any() for b in brain):
        panels.append(("brain-aware", brain))
    caption = (f"Diversity of the {what}, one value per run (diamonds, every run; the box "
               "summarises them): mean pairwise tree edit distance of the bodies"
               + ("; below: body plus neural distance" if len(panels) > 1 else "")
               + ", in edits.")
    figure, top, axes = new_figure(max(6.0, 1.6 * len(experiments) + 2.5), 4.2 * len(panels),
                                   caption, 1, len(panels))
    palette = colors(experiments)
    rng = np.random.default_rng(0)
    for (kind, data), (ax,) in zip(panels, axes, strict=True):
        names = []
        for p, (e, values) in enumerate(zip(experiments, data, strict=True), start=1):
            finite = values[np.isfinite(values)]
            points_over_box(ax, p, finite, palette[e.label], rng, size=40, marker="D",
                            edge=True)
            names.append(tick_label(e.title, f"{finite.size} runs"))
        ax.set_xticks(range(1, len(experiments) + 1), names)
        ax.set_xlim(0.4, len(experiments) + 0.6)
        ax.set_ylabel(f"{kind} diversity (edits)")
        ax.set_title(f"{kind.capitalize()} diversity")
        ax.grid(axis="y", alpha=0.3)
    top.suptitle(f"Diversity of the {what}")
    return figure


@styled
def lost_robots(experiments: Sequence[ExperimentData]) -> Figure:
    """Cumulative robots lost over births, each run a step line."""
    caption = ("Robots lost over births: robots lost to a blow-up (in the isolated evaluation or "
               "in the shared world), a body the engine could not build or a non-finite "
               "fitness. They have no fitness (they are not drawn as 0 m anywhere) and are "
               "counted here, each at its birth; failed births (lost before their first "
               "fitness) are left out of the births axis. One step line per run.")
    figure, top, ((ax,),) = new_figure(7.5, 3.6, caption)
    palette = colors(experiments)
    handles: list[Artist] = []
    labels: list[str] = []
    for e in experiments:
        failed = sum(int(r.failed_births.size) for r in e.runs)
        lost = sum(r.lost_robots for r in e.runs)
        for k, r in enumerate(e.runs):
            x, y = r.lost_over_births()
            x = np.concatenate([[0], x, [r.births]])
            y = np.concatenate([[0], y, [y[-1] if y.size else 0]])
            (line,) = ax.plot(x, y, drawstyle="steps-post", color=palette[e.label], lw=1.4,
                              alpha=0.8)
            if k == 0:
                handles.append(line)
                labels.append(f"{e.title}: {lost} lost ({failed} failed births, "
                              f"{lost - failed} later in life)")
    if not any(r.lost_robots for e in experiments for r in e.runs):
        ax.text(0.5, 0.5, "no robot was lost in any run", transform=ax.transAxes,
                ha="center", va="center", color="0.3")
    from matplotlib.ticker import MaxNLocator

    ax.set_xlabel("births")
    ax.set_ylabel("robots lost so far")
    most = max((r.lost_robots for e in experiments for r in e.runs), default=0)
    ax.set_ylim(0, max(1.0, 1.08 * most))  # 0 to 1 when none was lost, not a sliver
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_title("Robots lost (blow-ups, unbuildable bodies, failed evaluations)")
    ax.grid(alpha=0.3)
    legend_below(top, handles, labels, ncols=1)
    return figure


@styled
def curve_tests(experiments: Sequence[ExperimentData]) -> Figure:
    """A12 of every pair at equal births (colour), ``*`` where significant after Holm."""
    from matplotlib import colormaps

    rows = curve_rows(experiments)
    pairs = list(dict.fromkeys((str(r["experiment_a"]), str(r["experiment_b"])) for r in rows))
    titles = {e.label: e.title for e in experiments}
    caption = ("Whole-curve comparison at equal births: for every pair A vs B, each run's "
               "population mean fitness at 10 %, 20 %, ... 100 % of the births both reached "
               "(never beyond), two-sided Mann-Whitney U per point, Holm-Bonferroni over the "
               "points of a pair. Colour: Vargha-Delaney A12 (1: every run of A above every run "
               "of B; 0.5: no effect; blank: no value on one side); cell text: births, *: "
               "p_holm < 0.05; n: runs per side. Like with like: offline experiments are "
               "paired with offline ones, online with online (their fitness are different "
               "measurements, see fitness_over_births), never one with the other.")
    figure, _, ((ax,),) = new_figure(10.0, max(2.5, 0.42 * len(pairs) + 1.4), caption)
    cmap = colormaps["RdBu_r"]
    matrix = np.full((max(1, len(pairs)), len(CURVE_FRACTIONS)), np.nan)
    sizes: dict[tuple[str, str], str] = {}
    for r in rows:
        pair = (str(r["experiment_a"]), str(r["experiment_b"]))
        i, j = pairs.index(pair), int(r["point"])
        matrix[i, j] = float(r["a12"])
        sizes[pair] = f"n={r['n_a']}/{r['n_b']}"
        mark = "*" if float(r["p_holm"]) < ALPHA else ""
        ax.text(j, i, f"{int(r['births'])}{mark}", ha="center", va="center",
                color=text_color(cmap(float(r["a12"]))))
    image = ax.imshow(matrix, cmap=cmap, vmin=0.0, vmax=1.0, aspect="auto")
    figure.colorbar(image, ax=ax, label="A12 (A over B)")
    ax.set_yticks(range(len(pairs)), [f"{titles[a]} vs {titles[b]} ({sizes[(a, b)]})"
                                      for a, b in pairs])
    if not pairs:
        ax.text(0.5, 0.5, "no two experiments of one mode to compare (offline with offline, "
                "online with online)", transform=ax.transAxes, ha="center", va="center",
                color="0.3")
    ax.set_xticks(range(len(CURVE_FRACTIONS)), [f"{round(100 * f)}" for f in CURVE_FRACTIONS])
    ax.set_xlabel("births, % of those both reached (cell text: births; *: p_holm < 0.05)")
    ax.set_title("Population mean fitness, A vs B at equal births")
    return figure


FIGURES: dict[str, Callable[[Sequence[ExperimentData]], Figure]] = {
    "fitness_over_births": fitness_over_births,
    "final_fitness": final_fitness,
    "diversity_over_births": diversity_over_births,
    "final_diversity": final_diversity,
    "lost_robots": lost_robots,
    "curve_tests": curve_tests,
}
"""Figure file stems and the functions drawing them."""


@styled
def learning_gain(experiments: Sequence[ExperimentData]) -> Figure:
    """Every infant's inborn and learned fitness, for each experiment that learns.

    Each fitness is the one the infant's learner measured.
    """
    learners = [e for e in experiments if e.learns]
    caption = ("Infancy learning: each infant's fitness (m) with its inborn and its learned "
               "controller, both as its learner measured them (the Training Center's own "
               "evaluation window, not the robot's fitness in the run). Dots: every infant; "
               "box: their quartiles; diamonds: each run's mean.")
    figure, _, ((ax,),) = new_figure(max(6.0, 2.2 * len(learners) + 2.5), 4.0, caption)
    palette = colors(experiments)
    rng = np.random.default_rng(0)
    names: list[str] = []
    position = 0
    for e in learners:
        inborn, learned = e.learning_fitness()
        gain = float((learned - inborn).mean()) if inborn.size else float("nan")
        for values, runs, name in (
                (inborn, [r.inborn_fitness for r in e.runs], f"inborn (n={inborn.size})"),
                (learned, [r.learned_fitness for r in e.runs], f"learned (gain {gain:+.3g} m)")):
            position += 1
            points_over_box(ax, position, values, palette[e.label], rng)
            means = np.array([v.mean() for v in runs if v.size])
            ax.scatter(np.full(means.size, position), means, s=42, marker="D",
                       color=palette[e.label], edgecolor="black", lw=0.8, zorder=4)
            names.append(tick_label(e.title, name))
    ax.set_xticks(range(1, position + 1), names)
    ax.set_xlim(0.4, position + 0.6)
    ax.set_ylabel("fitness in the Training Center (m)")
    ax.set_title("Infancy learning: inborn vs learned controller")
    ax.grid(axis="y", alpha=0.3)
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
    """Save ``figure`` as ``out_dir/<stem>.<fmt>`` for each format (:data:`FIGURE_DPI`)."""
    paths = [out_dir / f"{stem}.{fmt}" for fmt in formats]
    for path in paths:
        figure.savefig(path, dpi=FIGURE_DPI)
    return paths
