"""Fitness terms as plain data: ``f = v + 5 s`` of a trajectory, and the ``Window`` a task scores.

The arithmetic the whole-trajectory and the sliding-window forms share; the rule is in
:mod:`revolve_env.fitness`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "DEFAULT_S_WEIGHT",
    "DEFAULT_WINDOW",
    "TIME_EPS",
    "FitnessTerms",
    "Window",
    "fitness_terms",
    "hypot",
    "pose_path_lengths",
    "speed_fitness",
    "trajectory_window",
    "window_fitness",
]

DEFAULT_WINDOW = 12.0
"""Length of the fitness window. Seconds."""

DEFAULT_S_WEIGHT = 5.0
"""Weight of the straight-line displacement ``s`` in ``f = v + 5 s``."""

TIME_EPS = 1e-9  # seconds: samples this close to the window's start still belong to it


@overload
def speed_fitness(v: float, s: float, s_weight: float = DEFAULT_S_WEIGHT) -> float: ...
@overload
def speed_fitness(v: NDArray[np.float64], s: NDArray[np.float64],
                  s_weight: float = DEFAULT_S_WEIGHT) -> NDArray[np.float64]: ...
def speed_fitness(v: float | NDArray[np.float64], s: float | NDArray[np.float64],
                  s_weight: float = DEFAULT_S_WEIGHT) -> float | NDArray[np.float64]:
    """The paper's fitness ``v + s_weight * s`` (section 4), of floats or element-wise. Metres.

    The formula's one home: the trajectory's terms, the windows' and the paper's task
    (:class:`revolve_env.tasks.Locomotion`) all call it.
    """
    return v + s_weight * s


@dataclass(frozen=True, slots=True)
class FitnessTerms:
    """Fitness and its terms.

    Attributes:
        fitness: ``v + s_weight * s``. Metres.
        v: Horizontal path length of the core over the window. Metres.
        s: Horizontal distance between the core's first and last positions in the window. Metres.
    """

    fitness: float
    v: float
    s: float


class Window(NamedTuple):
    """Every robot's fitness window as arrays, one entry per robot (``n`` robots).

    A robot with fewer than two samples has zeros everywhere but ``samples`` (its fitness is 0
    whatever the task: :func:`revolve_env.tasks.score`).

    Attributes:
        start: (n, 2) core ``(x, y)`` at the window's first sample. Metres.
        end: (n, 2) core ``(x, y)`` at its last sample. Metres.
        v: (n,) horizontal path length of the core from start to end. Metres.
        s: (n,) straight horizontal distance from start to end. Metres.
        samples: (n,) samples in the window (one per control period).
        signal_start: (n,) the task's signal (:attr:`revolve_env.tasks.Task.signal`) at the
            first sample; None for a task without one.
        signal_end: (n,) the signal at the last sample; None likewise.
        duration: (n,) time from the first to the last sample (0 below two samples); None
            where the maker of the window does not know the sample times. Seconds.
    """

    start: NDArray[np.float64]
    end: NDArray[np.float64]
    v: NDArray[np.float64]
    s: NDArray[np.float64]
    samples: NDArray[np.int64]
    signal_start: NDArray[np.float64] | None = None
    signal_end: NDArray[np.float64] | None = None
    duration: NDArray[np.float64] | None = None


def _horizontal(positions: ArrayLike) -> NDArray[np.float64]:
    p = np.asarray(positions, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] not in (2, 3):
        raise ValueError(f"positions must have shape (T, 2) or (T, 3), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError("positions contain NaN or infinity")
    return p[:, :2]


def fitness_terms(positions: ArrayLike, s_weight: float = DEFAULT_S_WEIGHT) -> FitnessTerms:
    """Fitness of a whole trajectory of core positions.

    Args:
        positions: Shape (T, 3) or (T, 2), metres; only x and y are used. T may be 0 or 1
            (fitness 0).
        s_weight: Weight of ``s``.
    """
    xy = _horizontal(positions)
    if len(xy) < 2:
        return FitnessTerms(0.0, 0.0, 0.0)
    steps = np.diff(xy, axis=0)
    v = float(np.sum(np.hypot(steps[:, 0], steps[:, 1])))
    s = float(math.hypot(*(xy[-1] - xy[0])))
    return FitnessTerms(speed_fitness(v, s, s_weight), v, s)


def window_fitness(
    times: ArrayLike, positions: ArrayLike, window: float = DEFAULT_WINDOW,
    s_weight: float = DEFAULT_S_WEIGHT,
) -> FitnessTerms:
    """Fitness over the samples of the last ``window`` seconds (``t >= t_last - window``).

    Args:
        times: Non-decreasing sample times, shape (T,). Seconds.
        positions: Core positions, shape (T, 3) or (T, 2). Metres.
        window: Window length. Seconds.
        s_weight: Weight of ``s``.
    """
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    xy = _horizontal(positions)
    if len(t) != len(xy):
        raise ValueError(f"{len(t)} times but {len(xy)} positions")
    if not window > 0:
        raise ValueError(f"window must be positive, got {window} s")
    if len(t) == 0:
        return FitnessTerms(0.0, 0.0, 0.0)
    if np.any(np.diff(t) < 0):
        raise ValueError("times must be non-decreasing")
    first = int(np.searchsorted(t, t[-1] - window - TIME_EPS, side="left"))
    return fitness_terms(xy[first:], s_weight)


def trajectory_window(paths: Sequence[NDArray[np.float64]],
                      signals: Sequence[NDArray[np.float64]] | None = None, stride: int = 1,
                      period: float | None = None) -> Window:
    """The window of each robot's whole trajectory (an evaluation: every pose sample counts).

    The pose samples are the rows ``0, stride, 2 stride, ...`` of each path
    (:mod:`revolve_env.fitness.sampling`: a path has a row per control period from the end of
    insertion); ``v`` and ``s`` are :func:`fitness_terms`' over them to the bit, so that
    ``v + 5 s`` is its fitness (with ``stride=1``: over every row, as before pose rates).

    Args:
        paths: One (T, 2) or (T, 3) array of core positions per robot, a row per control period
            (T may differ, 0 or 1 included: zeros). Metres.
        signals: One (T,) array of the task's signal per robot, sampled with the positions;
            None for a task without a signal.
        stride: Rows between two pose samples (:func:`~revolve_env.fitness.sampling.pose_stride`).
        period: Time between two rows (the control period), which gives the window's
            ``duration``; None: no duration. Seconds.
    """
    n = len(paths)
    start, end = np.zeros((n, 2)), np.zeros((n, 2))
    v, s = np.zeros(n), np.zeros(n)
    samples = np.array([(len(p) + stride - 1) // stride for p in paths], dtype=np.int64)
    sig_start = sig_end = None
    if signals is not None:
        sig_start, sig_end = np.zeros(n), np.zeros(n)
    for i, path in enumerate(paths):
        if samples[i] < 2:
            continue
        poses = path if stride == 1 else path[::stride]
        terms = fitness_terms(poses)
        start[i], end[i] = poses[0, :2], poses[-1, :2]
        v[i], s[i] = terms.v, terms.s
        if signals is not None:
            assert sig_start is not None and sig_end is not None
            sig_start[i], sig_end[i] = signals[i][0], signals[i][(samples[i] - 1) * stride]
    duration = None
    if period is not None:
        duration = np.where(samples < 2, 0.0, (samples - 1) * stride * period)
    return Window(start, end, v, s, samples, sig_start, sig_end, duration)


def pose_path_lengths(paths: Sequence[NDArray[np.float64]], stride: int
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Each path's length at every row and at its pose samples, over the same span. Metres.

    The span is from the first to the last pose sample (rows ``0`` to ``(k - 1) stride``): what
    :func:`~revolve_env.fitness.sampling.shaking` compares.
    """
    fine, coarse = np.zeros(len(paths)), np.zeros(len(paths))
    for i, path in enumerate(paths):
        k = (len(path) + stride - 1) // stride
        if k < 2:
            continue
        span = path[:(k - 1) * stride + 1]
        fine[i] = fitness_terms(span).v
        coarse[i] = fine[i] if stride == 1 else fitness_terms(span[::stride]).v
    return fine, coarse


def hypot(dx: NDArray[np.float64], dy: NDArray[np.float64]) -> NDArray[np.float64]:
    """``math.hypot`` element by element (CPython's own; the windows have always used it).

    Not the C library's ``np.hypot``: the two differ in the last bit now and then.
    """
    return np.fromiter(map(math.hypot, dx.tolist(), dy.tolist()), np.float64, dx.shape[0])
