"""The world's index arrays: the array-wise layout gives the per-robot loop's arrays."""

from __future__ import annotations

from dataclasses import fields
from typing import Any

import numpy as np
import pytest

from evolution.config import EvolutionConfig
from evolution.random_robot import random_robot
from revolve_env.body.examples import EXAMPLES
from revolve_env.world import World, WorldConfig
from revolve_env.world.robot_state import IMU_VALUES, Layout, RobotState, layout


def _loop_layout(states: list[RobotState], backend: Any) -> Layout:
    """The layout as it was built before: one robot after the other."""
    active, out_rows, touch_dest, touch_ids, root, link = [], [], [], [], [], []
    joint = inputs = 0
    in_offsets, out_offsets, joint_offsets = [0], [0], [0]
    for row, s in enumerate(states):
        active.append(joint + s.active_local)
        out_rows.append(np.full(s.n_outputs, row, dtype=np.intp))
        if s.touch_links.size:
            touch_dest.append(inputs + s.touch_local)
            touch_ids.append(backend.link_index(s.key, s.touch_links))
        on_root = s.light_links == 0
        if on_root.any():
            root.append((inputs + s.light_local[on_root],
                         np.full(int(on_root.sum()), row, dtype=np.intp),
                         s.light_position[on_root], s.light_direction[on_root]))
        if (~on_root).any():
            link.append((inputs + s.light_local[~on_root],
                         backend.link_index(s.key, s.light_links[~on_root]),
                         s.light_position[~on_root], s.light_direction[~on_root]))
        joint += s.n_joints
        joint_offsets.append(joint)
        inputs += s.n_inputs
        in_offsets.append(inputs)
        out_offsets.append(out_offsets[-1] + s.n_outputs)

    def cat(parts: list[Any]) -> np.ndarray:
        return np.concatenate(parts).astype(np.intp) if parts else np.zeros(0, dtype=np.intp)

    def vectors(parts: list[Any]) -> np.ndarray:
        return np.ascontiguousarray(np.concatenate(parts)) if parts else np.zeros((0, 3))

    offsets = np.asarray(in_offsets, dtype=np.intp)
    points = vectors([r[2] for r in root] + [r[2] for r in link])
    facings = vectors([r[3] for r in root] + [r[3] for r in link])
    return Layout(
        n=len(states), active_index=cat(active),
        output_offsets=np.asarray(out_offsets, dtype=np.intp), output_rows=cat(out_rows),
        joint_offsets=np.asarray(joint_offsets, dtype=np.intp),
        input_offsets=offsets, imu_dest=offsets[:-1, None] + np.arange(IMU_VALUES),
        touch_dest=cat(touch_dest), touch_ids=cat(touch_ids),
        light_dest=cat([r[0] for r in root] + [r[0] for r in link]),
        light_root_rows=cat([r[1] for r in root]), light_link_ids=cat([r[1] for r in link]),
        light_points=np.ascontiguousarray(points[:, :, None]),
        light_facings=np.ascontiguousarray(facings[:, :, None]))


def test_layout_is_the_loops() -> None:
    # MuJoCo's shared scene: its link ids do not depend on how often they are asked for
    pytest.importorskip("mujoco")
    rng = np.random.default_rng(4)
    robots = [random_robot(rng, EvolutionConfig()) for _ in range(12)]
    robots[3:3] = [EXAMPLES["spider"](), EXAMPLES["gecko"]()]
    with World(WorldConfig(engine="mujoco")) as world:
        for i, robot in enumerate(robots):
            world.add_robot(robot, (2.0 * i, 0.0))
        states = [world._state(h) for h in world.handles]
        kinds = {kind for s in states for kind, _ in s.model.sensors}
        assert {"touch", "light"} <= kinds  # both kinds of sensor are laid out
        new, old = layout(states, world.backend), _loop_layout(states, world.backend)
        for f in fields(Layout):
            a, b = getattr(new, f.name), getattr(old, f.name)
            if isinstance(a, np.ndarray):
                assert a.dtype == b.dtype and a.shape == b.shape, f.name
                assert a.flags.c_contiguous == b.flags.c_contiguous, f.name
            assert np.array_equal(a, b), f.name
        assert [s.row for s in states] == list(range(len(states)))
        assert [s.joint_start for s in states] == np.cumsum(
            [0] + [s.n_joints for s in states[:-1]]).tolist()
