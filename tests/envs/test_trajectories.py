"""TrajectoryStore: one write per step for every robot; handed-out views never change."""

from __future__ import annotations

import numpy as np
import pytest

from revolve_env.envs.trajectories import TrajectoryStore


@pytest.mark.parametrize("length", [None, 0, 1, 5, 40])
def test_every_robots_samples_come_back_in_order_and_old_views_stay_as_they_were(
        length: int | None) -> None:
    # small: segments move and the arena is remade often; with a length, only the latest samples
    store = TrajectoryStore(capacity=16, length=length)
    rng = np.random.default_rng(0)
    kept: list[list[np.ndarray]] = []
    seen: list[tuple[np.ndarray, np.ndarray]] = []  # (view handed out, its values then)
    for k in range(300):
        if k % 37 == 0:
            store.add()
            kept.append([])
        if k % 90 == 89:
            keep = np.ones(len(store), dtype=bool)
            keep[1] = False
            store.remove(keep)
            del kept[1]
        rows = np.flatnonzero(rng.uniform(size=len(store)) < 0.8)
        samples = rng.normal(size=(rows.size, 3))
        store.append(rows, samples)
        for r, p in zip(rows.tolist(), samples, strict=True):
            kept[r].append(p)
        views = store.views()
        for r in range(len(store)):
            want = np.array(kept[r]).reshape(-1, 3)
            if length is not None:
                want = want[len(want) - min(len(want), length):]
            np.testing.assert_array_equal(views[r], want)
            np.testing.assert_array_equal(store.view(r), want)
            assert not views[r].flags.writeable
            assert store.room(r) >= len(want)
        seen += [(v, v.copy()) for v in views[:2]]
    for view, then in seen:
        np.testing.assert_array_equal(view, then)
    with pytest.raises(ValueError):
        store.view(0)[:] = 0.0


def test_a_robot_can_start_with_samples_and_room() -> None:
    store = TrajectoryStore()
    store.add(np.arange(12.0).reshape(4, 3), room=100)
    store.append(np.array([0]), np.ones((1, 3)))
    assert store.view(0).shape == (5, 3) and store.room(0) == 100
    store.clear()
    assert len(store) == 0


def test_a_length_bounds_the_memory_of_robots_that_live_long() -> None:
    bounded, whole = TrajectoryStore(length=50), TrajectoryStore()
    for store in (bounded, whole):
        for _ in range(3):
            store.add()
        for k in range(20_000):  # 333 s at 60 samples a second
            store.append(np.arange(3), np.full((3, 3), float(k)))
    np.testing.assert_array_equal(bounded.view(2)[:, 0], np.arange(19_950, 20_000))
    assert bounded.room(0) == 100 and bounded._arena.shape[0] == 4096  # the first arena
    assert whole.view(2).shape == (20_000, 3) and whole._arena.shape[0] > 60_000


def test_a_length_trims_the_samples_a_robot_starts_with() -> None:
    store = TrajectoryStore(length=2)
    store.add(np.arange(12.0).reshape(4, 3), room=100)
    np.testing.assert_array_equal(store.view(0), [[6.0, 7.0, 8.0], [9.0, 10.0, 11.0]])
    assert store.room(0) == 4
    with pytest.raises(ValueError, match="length must be >= 0"):
        TrajectoryStore(length=-1)
