"""TrajectoryStore: one write per step for every robot; handed-out views never change."""

from __future__ import annotations

import numpy as np
import pytest

from revolve_env.envs.trajectories import TrajectoryStore


def test_every_robots_samples_come_back_in_order_and_old_views_stay_as_they_were() -> None:
    store = TrajectoryStore(capacity=16)  # small: segments move and the arena is remade often
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
