"""The paper's figures from :class:`~evolution.reporting.data.ExperimentData`.

Figures are drawn on ``matplotlib.figure.Figure`` objects directly (no ``pyplot``), so nothing
depends on a display or on the global backend: PNG is written by Agg, PDF by the PDF backend.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from evolution.reporting.data import ExperimentData, runs_on_grid

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "FIGURES",
    "LEARNING_FIGURES",
    "diversity_over_births",
    "final_diversity",
    "final_fitness",
    "fitness_over_births",
    "learning_gain",
    "write_figures",
]

_COLORS = ("#1f77b4", "#d62728", "#2ca02c", "#7f7f7f", "#ff7f0e", "#9467bd", "#8c564b",
           "#e377c2", "#17becf", "#bcbd22")


def _figure(
    width: float, height: float = 4.0, ncols: int = 1
) -> tuple[Figure, list[Axes]]:
    from matplotlib.figure import Figure

    figure = Figure(figsize=(width, height), layout="constrained")
    axes = figure.subplots(1, ncols, squeeze=False)[0]
    return figure, list(axes)


def _band(ax: Axes, grid: np.ndarray, values: np.ndarray, color: str, label: str) -> None:
    """Mean over runs as a line, +-1 standard deviation as a band.

    Solid where every run has reached those births; dashed beyond (the mean of the runs that
    got further, e.g. when some runs were interrupted).
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # births no run (or one run) reached
        mean = np.nanmean(values, axis=0)
        sd = np.nanstd(values, axis=0, ddof=1)
    n = values.shape[0]
    count = np.sum(np.isfinite(values), axis=0)
    everyone = count == n
    marker = "o" if grid.size <= 25 else None
    solid = np.where(everyone, mean, np.nan)
    ax.plot(grid, solid, color=color, lw=1.5, marker=marker, ms=3,
            label=f"{label} ({n} run{'s' * (n != 1)})")
    if not everyone.all():
        last = int(np.flatnonzero(everyone)[-1]) if everyone.any() else 0
        partial = np.where(np.arange(grid.size) >= last, mean, np.nan)
        ax.plot(grid, partial, color=color, lw=1.0, ls="--", marker=marker, ms=2)
    if n > 1:
        ax.fill_between(grid, mean - sd, mean + sd, color=color, alpha=0.2, lw=0)


def fitness_over_births(experiments: Sequence[ExperimentData]) -> Figure:
    """Population mean (left) and best (right) fitness over births; mean +-1 SD over runs."""
    figure, (left, right) = _figure(11.0, 4.2, 2)
    for k, e in enumerate(experiments):
        if not e.runs:
            continue
        color = _COLORS[k % len(_COLORS)]
        xs = [r.fitness.births for r in e.runs]
        grid, mean = runs_on_grid(xs, [r.fitness.mean for r in e.runs])
        _band(left, grid, mean, color, e.label)
        grid, best = runs_on_grid(xs, [r.fitness.best for r in e.runs])
        _band(right, grid, best, color, e.label)
    for ax, what in ((left, "mean"), (right, "best")):
        ax.set_xlabel("births")
        ax.set_ylabel(f"{what} fitness of the population (m)")
        ax.grid(alpha=0.3)
    left.set_title("Population mean fitness (mean and ±1 SD over runs)")
    if any(line.get_linestyle() == "--" for line in left.lines):
        left.text(0.99, 0.01, "dashed: not every run got this far", transform=left.transAxes,
                  ha="right", va="bottom", fontsize="small", color="0.3")
    right.set_title("Best fitness in the population")
    left.legend(fontsize="small")
    return figure


def _boxes(ax: Axes, data: list[np.ndarray], labels: list[str]) -> None:
    positions = list(range(1, len(data) + 1))
    kept = [(p, d) for p, d in zip(positions, data, strict=True) if d.size]
    if kept:
        box = ax.boxplot([d for _, d in kept], positions=[p for p, _ in kept], widths=0.6,
                         patch_artist=True, showmeans=True,
                         medianprops={"color": "black"},
                         meanprops={"marker": "^", "markerfacecolor": "white",
                                    "markeredgecolor": "black"})
        for patch, (p, _) in zip(box["boxes"], kept, strict=True):
            patch.set_facecolor(_COLORS[(p - 1) % len(_COLORS)])
            patch.set_alpha(0.35)
    ax.set_xticks(positions, labels, rotation=20)
    ax.set_xlim(0.4, len(data) + 0.6)
    ax.grid(axis="y", alpha=0.3)


def final_fitness(experiments: Sequence[ExperimentData]) -> Figure:
    """Box plots of the fitness of the final populations (robots of all runs pooled)."""
    figure, (ax,) = _figure(max(4.5, 1.3 * len(experiments) + 2))
    _boxes(ax, [e.final_fitness() for e in experiments],
           [f"{e.label}\n(n={e.final_fitness().size})" for e in experiments])
    ax.set_ylabel("fitness (m)")
    ax.set_title("Fitness of the final populations (all runs pooled; triangle = mean)")
    return figure


def diversity_over_births(experiments: Sequence[ExperimentData]) -> Figure:
    """Population diversity over births; mean +-1 SD over runs."""
    figure, (ax,) = _figure(7.0, 4.2)
    for k, e in enumerate(experiments):
        runs = [r for r in e.runs if r.diversity.size]
        if not runs:
            continue
        grid, values = runs_on_grid([r.diversity_births for r in runs],
                                    [r.diversity for r in runs])
        _band(ax, grid, values, _COLORS[k % len(_COLORS)], e.label)
    ax.set_xlabel("births")
    ax.set_ylabel("diversity (mean pairwise tree edit distance)")
    ax.set_title("Diversity over births (mean and ±1 SD over runs)")
    ax.grid(alpha=0.3)
    if ax.lines:
        ax.legend(fontsize="small")
    return figure


def final_diversity(experiments: Sequence[ExperimentData]) -> Figure:
    """Box plots of the diversity of each run's final population."""
    figure, (ax,) = _figure(max(4.5, 1.3 * len(experiments) + 2))
    _boxes(ax, [e.final_diversities() for e in experiments],
           [f"{e.label}\n(n={e.final_diversities().size})" for e in experiments])
    ax.set_ylabel("diversity (mean pairwise tree edit distance)")
    ax.set_title("Diversity of the final populations (one value per run)")
    return figure


FIGURES: dict[str, Callable[[Sequence[ExperimentData]], Figure]] = {
    "fitness_over_births": fitness_over_births,
    "final_fitness": final_fitness,
    "diversity_over_births": diversity_over_births,
    "final_diversity": final_diversity,
}
"""Figure file stems and the functions drawing them."""


def learning_gain(experiments: Sequence[ExperimentData]) -> Figure:
    """Box plots of the infants' inborn and learned fitness, for each experiment that learns.

    Each fitness is the one the infant's learner measured.
    """
    learners = [e for e in experiments if e.learns]
    figure, (ax,) = _figure(max(4.5, 2.2 * len(learners) + 2))
    data: list[np.ndarray] = []
    labels: list[str] = []
    for e in learners:
        inborn, learned = e.learning_fitness()
        gain = float((learned - inborn).mean()) if inborn.size else float("nan")
        data += [inborn, learned]
        labels += [f"{e.label}\ninborn (n={inborn.size})",
                   f"{e.label}\nlearned (gain {gain:+.3g} m)"]
    _boxes(ax, data, labels)
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
        figure = draw(experiments)
        for fmt in formats:
            path = out_dir / f"{stem}.{fmt}"
            figure.savefig(path, dpi=150)
            written.append(path)
    return tuple(written)
