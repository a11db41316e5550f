"""The blow-up screen and its reasons (revolve_env/world/blowups.py), on states made by hand.

:func:`all_calm` promises that when it passes every robot's :func:`reason` is None: it may fail
for a calm robot, never pass a blown one. Checked for calm states, states near the limits and
states with one non-finite entry anywhere, the core's orientation included.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from revolve_env.world.backend import BodyStates
from revolve_env.world.blowups import Screen, all_calm, reason
from revolve_env.world.config import WorldConfig

CONFIG = WorldConfig()
FIELDS = ("core_pos", "core_rot", "core_vel", "core_angvel", "joint_pos", "joint_vel")


def _states(rng: np.random.Generator, hinges: list[int], scale: float = 0.5) -> BodyStates:
    """Robots with ``hinges[i]`` hinges each, every speed a ``scale`` of its limit at most."""
    n = len(hinges)
    rot = np.linalg.qr(rng.normal(size=(n, 3, 3)))[0]  # rotations (up to a reflection)
    lin, ang = CONFIG.max_linear_speed / np.sqrt(3), CONFIG.max_angular_speed / np.sqrt(3)
    pos = rng.uniform(-50, 50, (n, 3))
    pos[:, 2] = rng.uniform(0, 2, n)
    return BodyStates(
        core_pos=pos, core_rot=rot, core_vel=rng.uniform(-1, 1, (n, 3)) * lin * scale,
        core_angvel=rng.uniform(-1, 1, (n, 3)) * ang * scale,
        joint_pos=rng.uniform(-1.5, 1.5, sum(hinges)),
        joint_vel=rng.uniform(-1, 1, sum(hinges)) * CONFIG.max_angular_speed * scale,
        diverged=np.zeros(n, dtype=bool))


def _reasons(s: BodyStates, hinges: list[int]) -> list[str | None]:
    starts = np.concatenate(([0], np.cumsum(hinges)))
    return [reason(s, i, slice(starts[i], starts[i + 1]), CONFIG, 1.0)
            for i in range(len(hinges))]


def _with(s: BodyStates, field: str, index: int, value: float) -> BodyStates:
    arrays = {f: np.array(getattr(s, f)) for f in FIELDS}
    arrays[field].reshape(-1)[index] = value
    return BodyStates(**arrays, diverged=s.diverged)


HINGES = st.lists(st.integers(0, 6), min_size=1, max_size=5)


@settings(max_examples=60, deadline=None)
@given(hinges=HINGES, seed=st.integers(0, 2**32 - 1),
       scale=st.sampled_from([0.0, 0.5, 0.99, 1.01, 1.5, 2.0]))
def test_the_screen_never_passes_a_blown_robot(hinges: list[int], seed: int, scale: float) -> None:
    s = _states(np.random.default_rng(seed), hinges, scale)
    if all_calm(s, Screen(len(hinges), sum(hinges), CONFIG)):
        assert _reasons(s, hinges) == [None] * len(hinges)
    if scale < 0.9:
        assert all_calm(s, Screen(len(hinges), sum(hinges), CONFIG))  # far from every limit


@settings(max_examples=80, deadline=None)
@given(hinges=HINGES, seed=st.integers(0, 2**32 - 1), field=st.sampled_from(FIELDS),
       where=st.integers(0, 10**6), bad=st.sampled_from([np.nan, np.inf, -np.inf]))
def test_one_non_finite_entry_anywhere_fails_the_screen_and_names_its_robot(
        hinges: list[int], seed: int, field: str, where: int, bad: float) -> None:
    calm = _states(np.random.default_rng(seed), hinges)
    size = getattr(calm, field).size
    if size == 0:  # no hinges at all
        return
    s = _with(calm, field, where % size, bad)
    assert not all_calm(s, Screen(len(hinges), sum(hinges), CONFIG))
    blown = [r is not None for r in _reasons(s, hinges)]
    assert sum(blown) == 1 and all("non-finite" in r for r in _reasons(s, hinges) if r)


@pytest.mark.parametrize("entry", [0, 4, 8])
def test_a_nan_orientation_alone_fails_the_screen(entry: int) -> None:
    """The orientation is bounded by construction (a rotation's entries are in [-1, 1]), so no
    limit applies to it; but a NaN there, with every other entry calm, is a blow-up."""
    calm = _states(np.random.default_rng(3), [2, 0, 3])
    assert all_calm(calm, Screen(3, 5, CONFIG))
    s = _with(calm, "core_rot", 9 + entry, np.nan)  # the second robot's
    assert _reasons(s, [2, 0, 3])[1] == "non-finite state (NaN or infinity) at t=1.000 s"
    assert not all_calm(s, Screen(3, 5, CONFIG))


def test_a_diverged_robot_and_a_core_below_the_ground_fail_the_screen() -> None:
    calm = _states(np.random.default_rng(4), [1, 1])
    diverged = BodyStates(**{f: getattr(calm, f) for f in FIELDS},
                          diverged=np.array([False, True]))
    assert not all_calm(diverged, Screen(2, 2, CONFIG))
    assert _reasons(diverged, [1, 1])[0] is None and "non-finite" in str(_reasons(diverged,
                                                                                  [1, 1])[1])
    fallen = _with(calm, "core_pos", 2, -1.5)
    assert not all_calm(fallen, Screen(2, 2, CONFIG))
    assert "fell through the ground" in str(_reasons(fallen, [1, 1])[0])
