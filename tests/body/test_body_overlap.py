"""overlapping_boxes: every pair and axis at once, the same pairs as the test it replaced.

The reference below is ``overlapping_boxes`` as it was before (one separating axis at a time over
all pairs, 2026-11-27), kept here verbatim: the fast test must find exactly its pairs, on random
and evolved bodies and on boxes that touch, meet edge to edge or lie almost parallel, where a
rounding could tip the answer.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from strategies import robots

import revolve_env.body.geometry as geometry
from evolution.config import EvolutionConfig
from evolution.operators import reproduce
from evolution.random_robot import IdAllocator, random_part, random_robot
from revolve_env.body import EXAMPLES, Limits, Node, PartType, Robot, example
from revolve_env.body.geometry import Assembly, PlacedBox, assemble, overlapping_boxes
from revolve_env.body.parts import PART_SPECS, rotation_about
from revolve_env.body.validate import ORIENTATIONS


def reference(assembly: Assembly, tolerance: float = 0.5e-3) -> list[tuple[int, int]]:
    """``overlapping_boxes`` before the fast test (verbatim)."""
    n = len(assembly.boxes)
    if n < 2:
        return []
    centers = np.array([b.center for b in assembly.boxes])
    rots = np.array([b.rotation for b in assembly.boxes])
    half = np.maximum(np.array([b.size for b in assembly.boxes]) / 2 - tolerance, 0.0)
    part = np.array([b.part for b in assembly.boxes])
    radius = np.linalg.norm(half, axis=1)

    i_idx, j_idx = np.triu_indices(n, k=1)
    keep = part[i_idx] != part[j_idx]
    d = centers[j_idx] - centers[i_idx]
    keep &= np.linalg.norm(d, axis=1) < radius[i_idx] + radius[j_idx]
    i_idx, j_idx, d = i_idx[keep], j_idx[keep], d[keep]
    if len(i_idx) == 0:
        return []

    a_rot, b_rot = rots[i_idx], rots[j_idx]  # (m, 3, 3), columns are box axes
    a_half, b_half = half[i_idx], half[j_idx]
    # Candidate separating axes: 3 face normals of each box and the 9 edge cross products.
    axes = [a_rot[:, :, k] for k in range(3)] + [b_rot[:, :, k] for k in range(3)]
    for ka in range(3):
        for kb in range(3):
            axes.append(np.cross(a_rot[:, :, ka], b_rot[:, :, kb]))
    separated = np.zeros(len(i_idx), dtype=bool)
    for axis in axes:
        norm = np.linalg.norm(axis, axis=1)
        valid = norm > 1e-9  # parallel edges give no axis; the face axes cover that case
        unit = np.where(valid[:, None], axis / np.where(valid, norm, 1.0)[:, None], 0.0)
        ra = np.sum(a_half * np.abs(np.einsum("mij,mi->mj", a_rot, unit)), axis=1)
        rb = np.sum(b_half * np.abs(np.einsum("mij,mi->mj", b_rot, unit)), axis=1)
        dist = np.abs(np.sum(d * unit, axis=1))
        separated |= valid & (dist > ra + rb)
    return [(int(i), int(j)) for i, j in zip(i_idx[~separated], j_idx[~separated], strict=True)]


TOLERANCES = (0.5e-3, 0.0, 1e-4, 2e-3, 5e-3)


def same_pairs(assembly: Assembly) -> None:
    for tolerance in TOLERANCES:
        assert overlapping_boxes(assembly, tolerance) == reference(assembly, tolerance)


# -- whole bodies ---------------------------------------------------------------------------------

@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_examples_give_the_reference_pairs(name: str) -> None:
    same_pairs(assemble(example(name)))


@settings(max_examples=30, deadline=None)
@given(robots(max_parts=12))
def test_random_constructible_bodies_give_the_reference_pairs(robot: Robot) -> None:
    same_pairs(assemble(robot))


@st.composite
def unchecked_bodies(draw: st.DrawFn) -> Robot:
    """Parts hung on random free slots with no check at all: bodies that often overlap."""
    core = Node(PartType.CORE, draw(st.sampled_from(ORIENTATIONS)))
    robot = Robot(core)
    for _ in range(draw(st.integers(1, 14))):
        free = [(p, s) for p, n in robot.walk() for s in PART_SPECS[n.type].child_slots
                if n.child(s) is None]
        if not free:
            break
        path, slot = draw(st.sampled_from(free))
        part = draw(st.sampled_from([t for t in PartType if t != PartType.CORE]))
        params = tuple(draw(st.sampled_from((p.low, p.high, (p.low + p.high) / 2)))
                       if draw(st.booleans()) else draw(st.floats(p.low, p.high))
                       for p in PART_SPECS[part].params)
        robot = robot.replace_node((*path, slot),
                                   Node(part, draw(st.sampled_from(ORIENTATIONS)), params))
    return robot


@settings(max_examples=60, deadline=None)
@given(unchecked_bodies())
def test_unchecked_bodies_overlapping_or_not_give_the_reference_pairs(robot: Robot) -> None:
    same_pairs(assemble(robot))


def test_evolved_bodies_give_the_reference_pairs() -> None:
    """Children of children, as a run breeds them (large bodies, bars at their bounds)."""
    config = EvolutionConfig()
    rng = np.random.default_rng(11)
    population = [random_robot(rng, config) for _ in range(8)]
    children = 0
    while children < 15:
        a, b = rng.choice(len(population), 2, replace=False)
        child = reproduce(population[a], population[b], rng, config).child
        if child is None:
            continue
        children += 1
        population[int(np.argmin([r.num_parts() for r in population]))] = child
        same_pairs(assemble(child))
        # and the same body with one more part anywhere, checked or not
        free = [(p, s) for p, n in child.walk() for s in PART_SPECS[n.type].child_slots
                if n.child(s) is None]
        if free:
            path, slot = free[int(rng.integers(len(free)))]
            kind = [t for t in PartType if t != PartType.CORE][int(rng.integers(6))]
            part = random_part(rng, kind, (0.5, 0.5, 0.5), IdAllocator(["x"]))
            same_pairs(assemble(child.replace_node((*path, slot), part)))


# -- two boxes at the edge ------------------------------------------------------------------------

def boxes(*placed: tuple[np.ndarray, np.ndarray, np.ndarray]) -> Assembly:
    """An assembly of bare boxes, each its own part (what overlapping_boxes reads)."""
    return Assembly((), tuple(PlacedBox(k, f"box{k}", np.asarray(c, float), np.asarray(r, float),
                                        np.asarray(s, float), 0.01, 0)
                              for k, (c, r, s) in enumerate(placed)), ())


def turned(axis: str, radians: float) -> np.ndarray:
    return rotation_about(axis, math.degrees(radians))


ANGLES = st.sampled_from((0.0, math.pi / 2, math.pi / 4, 1e-4, 1.2e-4, 1e-6, 1e-9, 1e-12,
                          1e-15, math.pi / 2 + 1e-10)) | st.floats(-math.pi, math.pi)


@st.composite
def touching_pairs(draw: st.DrawFn) -> Assembly:
    """Two boxes face to face, edge to edge or corner to face, at (or a hair from) contact."""
    size_a = np.array([draw(st.sampled_from((0.0123, 0.034, 0.05, 0.1))) for _ in range(3)])
    size_b = np.array([draw(st.sampled_from((0.0123, 0.034, 0.05, 0.1))) for _ in range(3)])
    rot_a = turned(draw(st.sampled_from("xyz")), draw(ANGLES))
    rot_b = turned(draw(st.sampled_from("xyz")), draw(ANGLES)) @ turned(
        draw(st.sampled_from("xyz")), draw(ANGLES))
    # Along a direction, at the distance where the shrunk boxes touch, give or take a rounding.
    direction = np.array(draw(st.sampled_from(((1.0, 0, 0), (0, 1.0, 0), (1.0, 1.0, 0),
                                               (1.0, 1.0, 1.0), (0.3, -0.2, 0.9)))))
    direction /= np.linalg.norm(direction)
    tolerance = draw(st.sampled_from(TOLERANCES))
    reach_a = np.sum(np.abs(rot_a.T @ direction) * np.maximum(size_a / 2 - tolerance, 0))
    reach_b = np.sum(np.abs(rot_b.T @ direction) * np.maximum(size_b / 2 - tolerance, 0))
    nudge = draw(st.sampled_from((0.0, 1e-16, -1e-16, 1e-12, -1e-12, 1e-9, -1e-9, 1e-6)))
    center_b = (reach_a + reach_b + nudge) * direction
    return boxes((np.zeros(3), rot_a, size_a), (center_b, rot_b, size_b))


@settings(max_examples=150, deadline=None)
@given(touching_pairs())
def test_boxes_at_contact_give_the_reference_answer(assembly: Assembly) -> None:
    same_pairs(assembly)


@settings(max_examples=80, deadline=None)
@given(st.lists(st.tuples(
    st.tuples(*(st.floats(-0.08, 0.08) for _ in range(3))),
    st.sampled_from("xyz"), ANGLES, st.sampled_from("xyz"), ANGLES,
    st.tuples(*(st.sampled_from((0.002, 0.02, 0.0411, 0.06)) for _ in range(3)))),
    min_size=2, max_size=12))
def test_random_boxes_give_the_reference_pairs(placed: list) -> None:
    same_pairs(boxes(*((np.array(c), turned(a1, t1) @ turned(a2, t2), np.array(s))
                       for c, a1, t1, a2, t2, s in placed)))


# -- which way it decides -------------------------------------------------------------------------

def test_bodies_are_decided_without_the_axis_by_axis_test(monkeypatch: pytest.MonkeyPatch) -> None:
    """At the default tolerance attached parts are 1 mm apart: nothing is left to the old test."""
    def refuse(assembly: Assembly, tolerance: float) -> list[tuple[int, int]]:
        raise AssertionError("the axis-by-axis test ran")

    monkeypatch.setattr(geometry, "_overlapping_by_axis", refuse)
    for name in sorted(EXAMPLES):
        assert overlapping_boxes(assemble(example(name))) == []
    rng = np.random.default_rng(3)
    for _ in range(10):
        assert overlapping_boxes(assemble(random_robot(rng, EvolutionConfig()))) == []


def test_touching_parts_are_left_to_the_axis_by_axis_test(monkeypatch: pytest.MonkeyPatch) -> None:
    """Without a tolerance, attached parts touch exactly: the old test decides, as it did."""
    calls = []
    by_axis = geometry._overlapping_by_axis

    def counted(assembly: Assembly, tolerance: float) -> list[tuple[int, int]]:
        calls.append(tolerance)
        return by_axis(assembly, tolerance)

    monkeypatch.setattr(geometry, "_overlapping_by_axis", counted)
    assembly = assemble(example("spider"))
    assert overlapping_boxes(assembly, 0.0) == reference(assembly, 0.0)
    assert calls == [0.0]
    assert Limits().overlap_tolerance > 0  # what validation uses: the fast answer
