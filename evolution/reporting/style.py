"""How the report's figures look: one place for what makes them readable at a glance.

* Colours a colour-blind reader tells apart: the Okabe-Ito palette (Okabe and Ito 2008, the
  palette recommended by Wong, Nature Methods 2011), one fixed colour per paper experiment.
* Text that reads on any background: on a coloured cell, black or white, whichever has the
  higher WCAG contrast ratio with the cell (:func:`text_color`).
* Legends outside the data: below the panels (:func:`legend_below`).
* Every run drawn: curves as one thin line per run under the median of the runs
  (:func:`runs_and_median`); distributions as every value's point over a box
  (:func:`points_over_box`), so no outlier hides.
* A caption inside every figure (:func:`new_figure`), so it reads without the report's text.
* One text size in every figure (:data:`TEXT_SIZE`; :func:`styled` draws a figure with it), and
  tick labels on every panel, shared scale or not (:func:`every_tick_label`).

Figures are ``matplotlib.figure.Figure`` objects drawn directly (no ``pyplot``): nothing depends
on a display or on the global backend.
"""

from __future__ import annotations

import functools
import textwrap
import warnings
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, ParamSpec

import numpy as np
from numpy.typing import NDArray

from evolution.experiments.loop.registry import PAPER_SCENARIOS
from evolution.reporting.data import ExperimentData

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure, SubFigure
    from matplotlib.typing import RcKeyType

__all__ = [
    "OTHER_COLORS",
    "TEXT_SIZE",
    "TEXT_STYLE",
    "every_tick_label",
    "styled",
    "tick_label",
    "PAPER_COLORS",
    "colors",
    "contrast_ratio",
    "legend_below",
    "new_figure",
    "points_over_box",
    "runs_and_median",
    "text_color",
]

PAPER_COLORS = {"scenario1": "#0072B2", "scenario2": "#D55E00", "scenario3": "#009E73",
                "baseline_a": "#CC79A7", "baseline_b": "#E69F00"}
"""The colour of each of the paper's experiments (Okabe-Ito: blue, vermillion, bluish green,
reddish purple, orange)."""

OTHER_COLORS = ("#56B4E9", "#000000", "#999999", "#8C510A", "#F0E442")
"""Colours of other experiments, in order (sky blue, black, grey, brown, yellow)."""


TEXT_SIZE = 9.0
"""The one text size of every figure of a report: titles, axis and tick labels, legends,
captions, cell text. Points (a figure of any width, saved at 150 dpi and shown on the page at
its size, reads at the same size as the others)."""

TEXT_STYLE: dict[RcKeyType, float | str] = {
    "font.size": TEXT_SIZE, "axes.titlesize": TEXT_SIZE, "axes.labelsize": TEXT_SIZE,
    "xtick.labelsize": TEXT_SIZE, "ytick.labelsize": TEXT_SIZE, "legend.fontsize": TEXT_SIZE,
    "legend.title_fontsize": TEXT_SIZE, "figure.titlesize": TEXT_SIZE,
    "figure.titleweight": "bold", "axes.titleweight": "normal",
}
"""The matplotlib settings :func:`styled` draws with (only the figure's title is bold)."""

_P = ParamSpec("_P")


def styled(draw: Callable[_P, Figure]) -> Callable[_P, Figure]:
    """``draw`` with the report's text: every text of its figure at :data:`TEXT_SIZE`.

    The figure is drawn under :data:`TEXT_STYLE` (matplotlib's ``rc_context``: the global
    settings are restored after), then every text it holds and every axis's tick labels (made
    when the figure is saved) are set to :data:`TEXT_SIZE`, whatever size a call asked for.
    """

    @functools.wraps(draw)
    def with_style(*args: _P.args, **kwargs: _P.kwargs) -> Figure:
        from matplotlib import rc_context
        from matplotlib.text import Text

        with rc_context(TEXT_STYLE):
            figure = draw(*args, **kwargs)
        for text in figure.findobj(Text):
            text.set_fontsize(TEXT_SIZE)
        for ax in figure.axes:
            ax.tick_params(labelsize=TEXT_SIZE)
        return figure

    return with_style


def every_tick_label(axes: Sequence[Axes]) -> None:
    """Tick labels on the y axis of every panel, shared scale or not.

    matplotlib shows a shared y axis's labels on the leftmost panel only; a panel of its own
    (the online one beside the offline one) needs its own numbers to be read.
    """
    for ax in axes:
        ax.tick_params(axis="y", labelleft=True)


def colors(experiments: Sequence[ExperimentData]) -> dict[str, str]:
    """One colour per experiment label: fixed for the paper's five, the others in order."""
    out: dict[str, str] = {}
    others = 0
    for e in experiments:
        if e.name in PAPER_SCENARIOS and PAPER_COLORS[e.name] not in out.values():
            out[e.label] = PAPER_COLORS[e.name]
        else:
            out[e.label] = OTHER_COLORS[others % len(OTHER_COLORS)]
            others += 1
    return out


def _luminance(rgb: Sequence[float]) -> float:
    """WCAG relative luminance of an sRGB colour with channels in [0, 1]."""
    linear = [c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4 for c in rgb[:3]]
    return 0.2126 * linear[0] + 0.7152 * linear[1] + 0.0722 * linear[2]


def contrast_ratio(a: Sequence[float], b: Sequence[float]) -> float:
    """WCAG contrast ratio of two sRGB colours (1: none, 21: black on white)."""
    la, lb = sorted((_luminance(a), _luminance(b)), reverse=True)
    return (la + 0.05) / (lb + 0.05)


def text_color(background: Sequence[float]) -> str:
    """``"black"`` or ``"white"``: whichever reads better on ``background`` (sRGB in [0, 1])."""
    on_black = contrast_ratio(background, (0.0, 0.0, 0.0))
    on_white = contrast_ratio(background, (1.0, 1.0, 1.0))
    return "black" if on_black >= on_white else "white"


def new_figure(width: float, height: float, caption: str, ncols: int = 1, nrows: int = 1,
               sharey: bool | str = False, sharex: bool | str = False,
               width_ratios: Sequence[float] | None = None
               ) -> tuple[Figure, SubFigure, list[list[Axes]]]:
    """A figure of ``nrows x ncols`` axes above a caption of wrapped text.

    The caption is its own subfigure, so it spans the whole width whatever the axes' margins.
    Returns the figure, the subfigure holding the axes (for :func:`legend_below`) and the axes.
    """
    from matplotlib.figure import Figure

    # About 16 characters an inch at TEXT_SIZE; a line 1.2 text sizes high.
    lines = textwrap.wrap(caption, width=int(width * 16), break_on_hyphens=False)
    caption_height = 1.2 * TEXT_SIZE / 72 * len(lines) + 0.12
    figure = Figure(figsize=(width, height + caption_height), layout="constrained")
    parts = figure.subfigures(2, 1, height_ratios=[height, caption_height])
    assert isinstance(parts, np.ndarray)  # two subfigures come as an array
    top, bottom = parts
    axes = top.subplots(nrows, ncols, squeeze=False, sharey=sharey, sharex=sharex,
                        width_ratios=width_ratios)
    bottom.text(0.01, 0.98, "\n".join(lines), va="top", ha="left", fontsize=TEXT_SIZE)
    return figure, top, [list(row) for row in axes]


def legend_below(holder: Figure | SubFigure, handles: Sequence[Artist], labels: Sequence[str],
                 ncols: int = 2) -> None:
    """One legend for every panel, below them: never over the data."""
    if handles:
        holder.legend(list(handles), list(labels), loc="outside lower center",
                      ncols=max(1, min(ncols, len(labels))), frameon=False)


def runs_and_median(ax: Axes, grid: NDArray[np.int64], values: NDArray[np.float64],
                    color: str, steps: bool) -> Artist:
    """Each run as a thin line, the median over runs as a thick one; the median's line.

    The median is drawn where every run has a value (births all runs reached); each run's own
    line goes as far as it went. Offline curves are steps (``steps``).
    """
    from matplotlib.ticker import MaxNLocator

    style = "steps-post" if steps else "default"
    n = values.shape[0]
    if n > 1:
        for run in values:
            ax.plot(grid, run, color=color, lw=0.8, alpha=0.45, drawstyle=style)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # births no run reached
        median = np.nanmedian(values, axis=0)
    everyone = np.sum(np.isfinite(values), axis=0) == n
    (line,) = ax.plot(grid, np.where(everyone, median, np.nan), color=color, lw=2.2,
                      drawstyle=style)
    if steps and grid.size and everyone[-1]:  # the last generation's step has no width
        ax.plot(grid[-1:], median[-1:], color=color, marker="o", ms=4)
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    return line


def points_over_box(ax: Axes, position: float, values: NDArray[np.float64], color: str,
                    rng: np.random.Generator, size: float = 9.0, marker: str = "o",
                    edge: bool = False) -> None:
    """A box of ``values`` (quartiles, whiskers 1.5 IQR) under every value as a point.

    The points are jittered sideways (from ``rng``, so a report is reproducible) and drawn
    whatever their distance from the box: an outlier is a point like the others.
    """
    if values.size == 0:
        return
    box = ax.boxplot([values], positions=[position], widths=0.55, patch_artist=True,
                     showfliers=False, medianprops={"color": "black", "lw": 1.5},
                     whiskerprops={"color": "0.35"}, capprops={"color": "0.35"})
    for patch in box["boxes"]:
        patch.set_facecolor(color)
        patch.set_alpha(0.22)
        patch.set_edgecolor("0.35")
    x = position + rng.uniform(-0.2, 0.2, values.size)
    ax.scatter(x, values, s=size, marker=marker, color=color, alpha=0.9 if edge else 0.75,
               edgecolor="black" if edge else "none", lw=0.8 if edge else 0, zorder=3)


def tick_label(title: str, *details: str) -> str:
    """An experiment's axis label: its title wrapped to a box's width, then ``details``."""
    return "\n".join([textwrap.fill(title, 18, break_on_hyphens=False), *details])
