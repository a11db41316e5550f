"""The population env's compiled window push gives NumPy's numbers, bit for bit.

``FitnessWindows.push_compiled`` (the extension's ``windows_push``, used by the population env on
MuJoCo) against ``TaskWindows.push`` on NumPy: the same windows and the same ring, step after
step, through births, deaths, insertion, held poses, a robot joining the latest sample time, a
ring that grows and a path rebased past 1 km; and whole population episodes with and without it.
"""

from __future__ import annotations

import pickle
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from revolve_env.body.examples import example
from revolve_env.envs.population import population_env
from revolve_env.fitness import Window
from revolve_env.rollout import TaskWindows
from revolve_env.tasks import Locomotion
from revolve_env.world import compiled

pytest.importorskip("mujoco", reason="the mujoco package is not installed")
KERNEL = compiled.windows_kernel()
pytestmark = pytest.mark.skipif(KERNEL is None,
                                reason="the compiled rollout is not built or not exact here")


def _same(a: Window, b: Window) -> None:
    for x, y in zip(a, b, strict=True):
        if x is None or y is None:
            assert x is None and y is None
        else:
            assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes()


def _same_ring(a: TaskWindows, b: TaskWindows) -> None:
    ra, rb = a.ring, b.ring
    assert (ra._seq, ra._start, ra._all_started) == (rb._seq, rb._start, rb._all_started)
    assert ra._first.tobytes() == rb._first.tobytes() and ra._last.tobytes() == rb._last.tobytes()
    for col in range(len(ra)):
        for x, y in zip(ra.samples(col), rb.samples(col), strict=True):
            assert x.tobytes() == y.tobytes()


@pytest.mark.parametrize(("stride", "capacity", "scale"), [
    (1, 1024, 1.0), (3, 1024, 1.0), (2, 4, 1.0), (1, 1024, 400.0)],
    ids=["every-period", "held-poses", "ring-grows", "rebased-past-1-km"])
def test_the_compiled_push_is_numpys_bit_for_bit(stride: int, capacity: int,
                                                 scale: float) -> None:
    """Random walks of robots born and dying, 400 periods: windows and rings equal each step."""
    assert KERNEL is not None
    dt = 1 / 60
    task = Locomotion(pose_rate=1 / (stride * dt) if stride > 1 else "every-period")
    fast, slow = (TaskWindows(task, 0.5, dt, 5) for _ in range(2))
    for w in (fast, slow):
        w.ring = type(w.ring)(0.5, capacity=capacity)
    rng = np.random.default_rng(stride * 7 + capacity)
    pos, ages = np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
    compiled_pushes = 0
    t = 0.0
    for step in range(400):
        before, t = t, step * dt
        if step % 37 == 0 or len(ages) < 2:  # a birth
            for w in (fast, slow):
                w.add(1)
            pos = np.concatenate((pos, rng.normal(size=(1, 3))))
            ages = np.append(ages, 0)
        if step % 53 == 20 and len(ages) > 2:  # a death
            keep = np.ones(len(ages), dtype=bool)
            keep[rng.integers(len(ages))] = False
            for w in (fast, slow):
                w.remove(keep)
            pos, ages = pos[keep], ages[keep]
        ages = ages + 1
        pos = np.ascontiguousarray(pos + rng.normal(scale=0.05 * scale, size=pos.shape))
        sampling = ages >= 5
        if step % 41 == 40:  # a robot joins the latest sample time (no insertion) first
            sampling_now = np.zeros(len(ages), dtype=bool)
            sampling_now[-1] = True
            for w in (fast, slow):
                w.ring.push(before, pos, sampling_now, None)
        a = fast.push(t, pos, ages, sampling, None, KERNEL)
        b = slow.push(t, pos, ages, sampling, None)
        _same(a, b)
        _same_ring(fast, slow)
        compiled_pushes += fast.ring._rows_now is None  # push_compiled leaves no cached rows
    assert compiled_pushes > 300


def _episode(steps: int) -> list[Any]:
    """A population episode on MuJoCo: births, a removal, statuses of every step (exact bits)."""
    robots = [example(name) for name in ("spider", "gecko", "snake", "sensor_crawler")]
    env = population_env(initial_robots=[{"robot": r} for r in robots[:2]], max_births=10,
                         insertion_time=0.2, fitness_window=1.0, engine="mujoco")
    out: list[Any] = []
    try:
        env.reset(seed=3)
        for t in range(steps):
            if t in (15, 70):
                env.add_robot(robots[2 if t == 15 else 3])
            if t == 120:
                env.remove_robot(env.robot_ids[0])
            ended = env.advance({}) if t % 2 else env.step({})[4]
            out.append(sorted(str(x) for x in ended.items()))
            out.append([(s.robot_id, s.fitness.hex(), s.v.hex(), s.s.hex(), s.age)
                        for s in (env.status(r) for r in env.robot_ids)])
    finally:
        env.close()
    return out


def test_population_episodes_are_the_same_with_the_compiled_push(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Whole episodes (advance and step) with the compiled push and with NumPy's agree."""
    used: list[int] = []
    real: Callable[..., Any] = KERNEL  # type: ignore[assignment]

    def counted(*a: Any) -> Any:
        out = real(*a)
        used.append(bool(out[0]))
        return out

    with monkeypatch.context() as m:
        m.setattr(compiled, "windows_kernel", lambda: counted)
        fast = _episode(200)
    assert sum(used) > 150
    with monkeypatch.context() as m:
        m.setattr(compiled, "windows_kernel", lambda: None)
        slow = _episode(200)
    assert fast == slow


def test_an_env_with_the_compiled_push_pickles_and_keeps_it() -> None:
    """SuperSuit's vector envs send the env to other processes: the push is looked up again."""
    kernel = compiled.windows_kernel()
    if kernel is None:
        pytest.skip("the compiled window push is not usable here")
    again = pickle.loads(pickle.dumps(kernel))
    assert isinstance(again, compiled.WindowsPush)
