"""Fitness f = v + 5 s on hand-computed trajectories; the online window equals the offline one."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from revolve_env.fitness import (
    FitnessWindows,
    SlidingWindowFitness,
    fitness_terms,
    window_fitness,
)


def test_square_path_returns_home() -> None:
    # 1 m square walked once: path 4 m, back where it started.
    square = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 0)]
    f = fitness_terms(square)
    assert f.v == pytest.approx(4.0)
    assert f.s == pytest.approx(0.0)
    assert f.fitness == pytest.approx(4.0)


def test_three_sides_of_square() -> None:
    f = fitness_terms([(0, 0), (1, 0), (1, 1), (0, 1)])
    assert (f.v, f.s, f.fitness) == pytest.approx((3.0, 1.0, 8.0))


def test_straight_line() -> None:
    # 0.1 m/s along a diagonal for 12 s sampled at 60 Hz: v = s = 1.2 m, f = 6 * 1.2.
    t = np.arange(0, 12 * 60 + 1) / 60.0
    pos = np.stack([0.1 / math.sqrt(2) * t, 0.1 / math.sqrt(2) * t, 0.05 + 0 * t], axis=1)
    f = window_fitness(t, pos)
    assert f.v == pytest.approx(1.2)
    assert f.s == pytest.approx(1.2)
    assert f.fitness == pytest.approx(7.2)


def test_standing_still_and_vertical_motion_count_nothing() -> None:
    pos = np.array([(0.3, -0.2, z) for z in np.linspace(0.02, 0.5, 50)])
    f = fitness_terms(pos)
    assert (f.fitness, f.v, f.s) == (0.0, 0.0, 0.0)
    assert fitness_terms(np.zeros((0, 3))).fitness == 0.0
    assert fitness_terms([(1.0, 2.0, 3.0)]).fitness == 0.0


def test_window_keeps_only_last_seconds() -> None:
    # 10 s going +x at 1 m/s, then 12 s standing still: the last 12 s hold no motion.
    t = np.arange(0, 22 * 10 + 1) / 10.0
    x = np.minimum(t, 10.0)
    pos = np.stack([x, 0 * t], axis=1)
    assert window_fitness(t, pos, window=12.0).fitness == pytest.approx(0.0)
    # window of 13 s includes the last second of motion
    assert window_fitness(t, pos, window=13.0).v == pytest.approx(1.0)


def test_bad_input_is_named() -> None:
    with pytest.raises(ValueError, match="shape"):
        fitness_terms(np.zeros((5, 4)))
    with pytest.raises(ValueError, match="NaN"):
        fitness_terms([(0, 0), (math.nan, 0)])
    with pytest.raises(ValueError, match="non-decreasing"):
        window_fitness([1.0, 0.0], [(0, 0), (1, 1)])
    w = SlidingWindowFitness()
    w.add(1.0, (0, 0, 0))
    with pytest.raises(ValueError, match="before"):
        w.add(0.5, (0, 0, 0))
    with pytest.raises(ValueError, match="window"):
        SlidingWindowFitness(window=0.0)


@settings(max_examples=40, deadline=None)
@given(
    steps=st.lists(
        st.tuples(st.floats(0.0, 0.5), st.floats(-1, 1), st.floats(-1, 1)), min_size=1, max_size=200
    ),
    window=st.floats(0.1, 5.0),
)
def test_online_window_equals_offline(
        steps: list[tuple[float, float, float]], window: float) -> None:
    online = SlidingWindowFitness(window=window, capacity=4)
    t, pos = [], []
    now = 0.0
    for dt, x, y in steps:
        now += dt
        t.append(now)
        pos.append((x, y, 0.1))
        online.add(now, (x, y, 0.1))
        offline = window_fitness(t, pos, window=window)
        got = online.terms()
        assert got.fitness == pytest.approx(offline.fitness, rel=1e-12, abs=1e-12)
        assert got.v == pytest.approx(offline.v, rel=1e-12, abs=1e-12)
        assert got.s == pytest.approx(offline.s, rel=1e-12, abs=1e-12)
    kept, _ = online.samples()
    assert kept[0] >= now - window - 1e-9  # old samples are dropped


def test_long_life_stays_exact() -> None:
    # 20 minutes at 60 Hz circling at 1 m/s: the running path sum passes 1 km and is rebased;
    # the window's terms stay exact.
    online = SlidingWindowFitness(window=12.0)
    t = np.arange(0, 1200 * 60 + 1) / 60.0
    pos = np.stack([np.cos(t), np.sin(t)], axis=1)
    for ti, p in zip(t, pos, strict=True):
        online.add(ti, p)
    expected = window_fitness(t, pos, window=12.0)
    got = online.terms()
    assert got.v == pytest.approx(12.0, rel=1e-3)  # chords of a unit circle at 1 rad/s
    assert got.v == pytest.approx(expected.v, rel=1e-12)
    assert got.s == pytest.approx(expected.s, rel=1e-12)
    assert len(online) == 12 * 60 + 1


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), window=st.floats(0.05, 2.0), stride=st.floats(0.001, 0.5))
def test_many_windows_at_once_equal_each_robots_own_window_bit_for_bit(
        seed: int, window: float, stride: float) -> None:
    """FitnessWindows (one buffer, every robot at once) against one SlidingWindowFitness (a
    buffer of one column) per robot: births at other times (some at the latest sample time, as
    between two steps of an env), deaths, long jumps that rebase the running sums, and a
    snapshot round trip."""
    rng = np.random.default_rng(seed)
    many = FitnessWindows(window=window, capacity=2)
    alone: list[SlidingWindowFitness] = []
    t = 0.0
    for k in range(120):
        if k == 0 or rng.uniform() < 0.1:  # a birth: it samples now, at the latest time
            many.add(1)
            alone.append(SlidingWindowFitness(window=window, capacity=2))
            if k:
                xy = rng.normal(size=(len(alone), 2))
                many.push(t, xy, np.arange(len(alone)) == len(alone) - 1)
                alone[-1].add(t, xy[-1])
        if len(alone) > 1 and rng.uniform() < 0.05:  # a death
            keep = np.ones(len(alone), dtype=bool)
            keep[rng.integers(len(alone))] = False
            many.remove(keep)
            alone = [w for w, kept in zip(alone, keep, strict=True) if kept]
        t += stride * rng.uniform(0.5, 1.5)
        xy = rng.normal(size=(len(alone), 3)) * (500.0 if rng.uniform() < 0.1 else 1.0)
        many.push(t, xy)
        for w, p in zip(alone, xy, strict=True):
            w.add(t, p)
        f, v, s = many.terms()
        want = [w.terms() for w in alone]
        assert f.tolist() == [x.fitness for x in want]
        assert v.tolist() == [x.v for x in want]
        assert s.tolist() == [x.s for x in want]
        if k % 40 == 39:
            snapshots = [many.snapshot(i) for i in range(len(many))]
            for snap, w in zip(snapshots, alone, strict=True):
                mine = w.snapshot()
                for key in ("t", "xy", "path"):
                    np.testing.assert_array_equal(snap[key], mine[key])
            many = FitnessWindows(window=window)
            many.add(len(alone))
            many.restore(snapshots)


def test_windows_refuse_bad_input_and_a_robot_left_out_keeps_its_window() -> None:
    many = FitnessWindows(window=1.0)
    many.add(2)
    many.push(0.0, np.zeros((2, 2)))
    many.push(0.5, np.array([[1.0, 0.0], [0.0, 2.0]]))
    with pytest.raises(ValueError, match="before"):
        many.push(0.25, np.zeros((2, 2)))
    with pytest.raises(ValueError, match="finite"):
        many.push(1.0, np.array([[np.nan, 0.0], [0.0, 0.0]]))
    with pytest.raises(ValueError, match="shape"):
        many.push(1.0, np.zeros((3, 2)))
    many.push(1.0, np.array([[2.0, 0.0], [9.0, 9.0]]), np.array([True, False]))
    f, v, s = many.terms()
    assert (v.tolist(), s.tolist()) == ([2.0, 2.0], [2.0, 2.0])
    first, last, path, count = many.ends()
    assert count.tolist() == [3, 2] and last[1].tolist() == [0.0, 2.0]
    with pytest.raises(ValueError, match="window"):
        FitnessWindows(window=0.0)
