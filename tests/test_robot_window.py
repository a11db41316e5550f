"""revolve_env.rollout.RobotWindow: one robot's window in floats gives TaskWindows' numbers.

The single-robot env scores with :class:`RobotWindow`; the population env with
:class:`TaskWindows`. On the same pushes the two must agree to the bit: fitness, terms, the
window a task sees and what is held between pose samples.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

from revolve_env.fitness import FitnessTerms, Window
from revolve_env.rollout import RobotWindow, TaskWindows, task_rule
from revolve_env.tasks import DirectedLocomotion, LightFollowing, Locomotion, Task

DT = 1 / 60


@dataclass(frozen=True)
class _Squared(Locomotion):
    """Not a shipped type: scored through the general path (its own fitness)."""

    def fitness(self, window: Window) -> NDArray[np.float64]:
        return window.v * window.s + window.duration  # type: ignore[operator]


TASKS: list[Task] = [
    Locomotion(), Locomotion(limit=0.3), Locomotion(s_weight=2.5, pose_rate="every-period"),
    DirectedLocomotion(heading=0.7), LightFollowing(), LightFollowing(pose_rate=20.0),
    _Squared(),
]


def _same(a: object, b: object) -> bool:
    """Equal to the bit (floats and arrays by their bytes, so -0.0 != 0.0 and NaN == NaN)."""
    if isinstance(a, np.ndarray) and isinstance(b, np.ndarray):
        return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    if isinstance(a, float) and isinstance(b, float):
        return np.float64(a).tobytes() == np.float64(b).tobytes()
    return a is None and b is None


def _check(one: RobotWindow, many: TaskWindows, window: Window) -> None:
    terms = one.terms()
    f = many.score(window)
    assert _same(terms.fitness, float(f[0]))
    assert _same(terms.v, float(window.v[0])) and _same(terms.s, float(window.s[0]))
    mine = one.current()
    for a, b in zip(mine, window, strict=True):
        assert _same(a, b)
    assert not mine.samples.flags.writeable


@settings(max_examples=60, deadline=None)
@given(task=st.sampled_from(TASKS), insertion=st.integers(0, 5),
       window=st.sampled_from([0.05, 0.2, 1.0, 12.0]), seed=st.integers(0, 2**32 - 1),
       steps=st.integers(1, 150), scale=st.sampled_from([0.01, 1.0, 400.0]))
def test_robot_window_gives_the_task_windows_numbers(task: Task, insertion: int, window: float,
                                                     seed: int, steps: int,
                                                     scale: float) -> None:
    """Random walks (big ones rebase the path past 1 km; short windows drop samples)."""
    rng = np.random.default_rng(seed)
    one, many = RobotWindow(task, window, DT, insertion), TaskWindows(task, window, DT, insertion)
    many.add(1)
    pos = np.zeros((1, 3))
    signal = task.signal is not None
    for age in range(insertion, insertion + steps):
        pos = pos + rng.normal(0.0, scale, (1, 3))
        sig = rng.uniform(0.0, 1.0, 1) if signal else None
        t = age * DT if rng.uniform() > 0.05 else (age - 1) * DT  # now and then the same time
        window_now = many.push(t, pos, np.array([age]), None, sig)
        one.push(t, float(pos[0, 0]), float(pos[0, 1]), age,
                 None if sig is None else float(sig[0]))
        _check(one, many, window_now)
        x, y, held = one.last()
        last, last_sig = many.ring.last()
        assert _same(x, float(last[0, 0])) and _same(y, float(last[0, 1]))
        assert _same(held, float(last_sig[0]) if last_sig is not None else 0.0)
    assert len(one) == int(many.ring.current().samples[0])


def test_a_robot_window_below_two_samples_scores_zero() -> None:
    one = RobotWindow(Locomotion(pose_rate="every-period"), 12.0, DT, 0)
    assert one.terms().fitness == 0.0 and one.last() == (0.0, 0.0, 0.0)
    one.push(0.0, 1.0, 2.0, 0, None)
    assert one.terms().fitness == 0.0 and int(one.current().samples[0]) == 1
    one.push(DT, 2.0, 2.0, 1, None)
    assert one.terms() == FitnessTerms(6.0, 1.0, 1.0)


def test_a_robot_window_holds_its_pose_between_pose_samples() -> None:
    one = RobotWindow(Locomotion(), 12.0, DT, 2)  # 5 Hz: a pose every 12 periods
    for age in range(2, 15):
        one.push(age * DT, float(age), 0.0, age, None)
    assert one.last()[0] == 14.0 and one.terms().v == 12.0  # ages 2 and 14 sampled


@pytest.mark.parametrize(("time", "x", "message"), [
    (float("nan"), 0.0, "time must be finite"),
    (-1.0, 0.0, "before the previous sample"),
    (1.0, float("inf"), "must be finite"),
])
def test_a_robot_window_refuses_bad_samples(time: float, x: float, message: str) -> None:
    one = RobotWindow(Locomotion(pose_rate="every-period"), 12.0, DT, 0)
    one.push(0.0, 0.0, 0.0, 0, None)
    with pytest.raises(ValueError, match=message):
        one.push(time, x, 0.0, 1, None)


def test_a_robot_window_of_a_signal_task_needs_the_signal() -> None:
    one = RobotWindow(LightFollowing(), 12.0, DT, 0)
    with pytest.raises(ValueError, match="push needs one"):
        one.push(0.0, 0.0, 0.0, 0, None)



def test_task_rule_reads_every_field_of_the_shipped_tasks() -> None:
    """The compiled env step scores the shipped tasks by ``task_rule``'s tuple: a field added
    to one of them (one that could change its fitness) must be added to that rule too."""
    read = {Locomotion: {"pose_rate", "s_weight", "limit"},
            DirectedLocomotion: {"pose_rate", "heading"},
            LightFollowing: {"pose_rate"}}
    for kind, names in read.items():
        assert {f.name for f in dataclasses.fields(kind)} == names, kind.__name__
    assert task_rule(Locomotion(s_weight=2.0, limit=3.0)) == (0, 2.0, 3.0, 1.0, 0.0)
    directed = task_rule(DirectedLocomotion(heading=0.5))
    assert directed is not None and directed[:2] == (1, 0.0) and math.isnan(directed[2])
    assert directed[3:] == (math.cos(0.5), math.sin(0.5))
    light = task_rule(LightFollowing())
    assert light is not None and light[0] == 2
