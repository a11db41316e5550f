"""Labelled world pictures: each robot tagged with its id in a colour of its own (issue 31)."""

from __future__ import annotations

import numpy as np

from revolve_env.envs.watch import PALETTE, Label, label_frame, pick_color


def test_colours_are_distinct_while_the_palette_lasts_then_shared_evenly() -> None:
    taken: list[int] = []
    for _ in range(len(PALETTE)):
        taken.append(pick_color(taken))
    assert sorted(taken) == list(range(len(PALETTE)))
    taken.append(pick_color(taken))
    assert taken[-1] == 0
    assert pick_color([0, 2]) == 1  # a dead robot's colour is free again


def _count(frame: np.ndarray, rgb: tuple[float, float, float]) -> int:
    target = np.round(255 * np.array(rgb))
    return int((np.abs(frame.astype(int) - target) <= 1).all(axis=2).sum())


def test_each_robot_gets_a_tag_of_its_colour_beside_it() -> None:
    grey = np.full((240, 320, 3), 200, dtype=np.uint8)
    labels = [Label("#3  1.000 m", PALETTE[0], 1.0, tag="#3", at=(200.0, 150.0)),
              Label("#7  0.500 m", PALETTE[4], 0.5, tag="#7", at=(100.0, 200.0)),
              Label("#9  0.100 m", PALETTE[2], 0.1, tag="#9", at=(float("nan"), 0.0))]
    frame = label_frame(grey, "t = 1.0 s", labels)
    assert frame.shape == grey.shape
    for lb in labels[:2]:
        assert lb.at is not None
        x, y = int(lb.at[0]), int(lb.at[1])
        near = frame[max(0, y - 40):y + 5, x - 5:x + 45]
        assert _count(near, lb.color) > 150  # the tag's box above right of the robot
        box = np.abs(near.astype(int) - np.round(255 * np.array(lb.color))).max(axis=2) <= 1
        ink = (near.max(axis=2) < 60) | (near.min(axis=2) > 245)  # its text: black or white
        assert box.any() and ink.any()
    # a robot that is not in the picture gets no tag, only its legend line
    assert _count(frame, PALETTE[2]) < 100
