"""World snapshots: MuJoCo restores a world exactly (a rebuilt scene steps on bit for bit);
pybullet says it cannot."""

from __future__ import annotations

import numpy as np
import pytest

from revolve_env.body.examples import EXAMPLES
from revolve_env.world import World, WorldConfig
from revolve_env.world.backend import SnapshotMismatchError

pytest.importorskip("mujoco", reason="the mujoco package is not installed")


def _drive(world: World, periods: int, seed: int) -> list[np.ndarray]:
    """Random targets every period; the sensors and core poses of every robot, every period."""
    rng = np.random.default_rng(seed)
    seen = []
    for _ in range(periods):
        for h in world.handles:
            world.set_targets(h, rng.uniform(-1, 1, world.n_outputs(h)))
        world.step(1)
        seen.append(np.concatenate([world.core_positions().ravel()]
                                   + [world.read_sensors(h) for h in world.handles]))
    return seen


def _busy_world() -> World:
    """Five example robots, crowded so they touch each other, two deaths and a late birth."""
    world = World(WorldConfig(engine="mujoco"))
    robots = [make() for make in EXAMPLES.values()]
    handles = [world.add_robot(r, (0.25 * i, 0.1 * (i % 2)), 0.7 * i) for i, r in enumerate(robots)]
    _drive(world, 40, 1)
    world.remove_robot(handles[1])
    _drive(world, 20, 2)
    world.add_robot(robots[1], (2.0, 0.0), 1.0)
    world.remove_robot(handles[3])
    _drive(world, 17, 3)  # the snapshot falls after a step: contacts one physics step old
    return world


def test_a_restored_mujoco_world_steps_on_bit_for_bit() -> None:
    with _busy_world() as original, World(WorldConfig(engine="mujoco")) as twin:
        assert original.exact_restore
        snap = original.snapshot()
        twin.add_robot(EXAMPLES["spider"](), (5.0, 5.0))  # whatever it held is replaced
        twin.restore(snap)
        assert twin.handles == original.handles and twin.time == original.time
        for h in original.handles:
            np.testing.assert_array_equal(twin.read_sensors(h), original.read_sensors(h))
            assert twin.blow_up(h) == original.blow_up(h)
        a, b = _drive(original, 90, 4), _drive(twin, 90, 4)
        for x, y in zip(a, b, strict=True):
            np.testing.assert_array_equal(x, y)
        # and births and deaths after the restore stay exact too
        for w in (original, twin):
            w.remove_robot(w.handles[0])
            w.add_robot(EXAMPLES["gecko"](), (-1.5, 0.0), 0.2)
        a, b = _drive(original, 30, 5), _drive(twin, 30, 5)
        for x, y in zip(a, b, strict=True):
            np.testing.assert_array_equal(x, y)


def test_a_snapshot_that_does_not_fit_is_refused_and_leaves_an_empty_world() -> None:
    with _busy_world() as original, World(WorldConfig(engine="mujoco")) as twin:
        snap = original.snapshot()
        snap["robots"][0]["robot"] = snap["robots"][1]["robot"]  # another body
        with pytest.raises(SnapshotMismatchError):
            twin.restore(snap)
        assert twin.handles == () and twin.time == 0.0 and twin.body_count() == 1
        with pytest.raises(SnapshotMismatchError, match="engine"):
            twin.restore({**original.snapshot(), "engine": "pybullet"})


def test_pybullet_says_it_cannot_restore_exactly() -> None:
    with World(WorldConfig(engine="pybullet")) as world:
        world.add_robot(EXAMPLES["spider"]())
        assert not world.exact_restore
        with pytest.raises(NotImplementedError, match="replay"):
            world.snapshot()
