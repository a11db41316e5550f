"""The population env's compiled periods give :meth:`PopulationEnv.advance`'s numbers, bit for bit.

``advance_periods(n)`` (many periods of brain-driven robots in one compiled call,
``Roster.compiled_periods``) against ``n`` calls of ``advance({})`` on MuJoCo: the same statuses,
observations, fitness windows, brains, world and snapshots, through births, removals, blow-ups,
a ring that grows (a push the compiled periods leave to Python) and brains whose outputs are not
finite; and the evolution loop's online world, which advances by them.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from revolve_env.body.examples import gecko, sensor_crawler, snake, spider
from revolve_env.envs.population import PopulationEnv, population_env
from revolve_env.fitness import FitnessWindows
from revolve_env.world import WorldConfig, compiled

pytest.importorskip("mujoco", reason="the mujoco package is not installed")
pytestmark = pytest.mark.skipif(compiled.windows_kernel() is None or not compiled.hypot_exact(),
                                reason="the compiled rollout is not built or not exact here")


def _same(a: Any, b: Any, where: str = "") -> None:
    """``a`` and ``b`` hold the same values, floats to the bit (NaN too)."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b), where
        for key in a:
            _same(a[key], b[key], f"{where}/{key}")
    elif isinstance(a, (list, tuple)):
        assert type(a) is type(b) and len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _same(x, y, f"{where}[{i}]")
    elif isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray) and a.dtype == b.dtype and a.shape == b.shape, where
        assert np.ascontiguousarray(a).tobytes() == np.ascontiguousarray(b).tobytes(), where
    elif isinstance(a, float):
        assert isinstance(b, float) and a.hex() == b.hex(), where
    else:
        assert a == b, where


def _fingerprint(env: PopulationEnv) -> dict[str, Any]:
    """Everything a run can read of the env now, and its whole snapshot."""
    world = env.world
    s = world.states
    ring = env._roster.living.windows.ring.ring()
    return {
        "steps": env.steps, "time": env.time, "world_time": world.time, "ids": env.robot_ids,
        "agents": list(env.agents),
        "statuses": {r: tuple(env.status(r)) for r in env.robot_ids},
        "observe": {r: env.observe(r) for r in env.robot_ids},
        "states": [s.core_pos, s.core_rot, s.core_vel, s.core_angvel, s.joint_pos, s.joint_vel],
        "sensors": world.sensor_values(), "targets": world.targets,
        "hinges": world.hinge_angles(),
        # the ring's counters (its samples are in the snapshot; the rest of its rows is unset)
        "ring": None if ring is None else list(ring[3:]),
        "snapshot": env.snapshot(),
    }


def _env(max_angular_speed: float, capacity: int | None) -> PopulationEnv:
    env = population_env(initial_robots=[], max_births=20, insertion_time=0.1,
                         fitness_window=0.5, engine="mujoco", trajectory_length=0,
                         world_config=replace(WorldConfig(), max_angular_speed=max_angular_speed))
    env.reset(seed=11)
    if capacity is not None:  # a small ring grows soon: pushes the compiled periods decline
        env._roster.living.windows.ring = FitnessWindows(0.5, capacity=capacity)
    return env


@pytest.fixture
def counted(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[tuple[int, int, int]]]:
    """Each compiled call's periods done whole, its stop and the world's outcome there."""
    done: list[tuple[int, int, int]] = []
    real: Callable[..., Any] = compiled.population_periods

    def spy(*args: Any) -> Any:
        periods = real(*args)
        if periods is not None:
            run = periods.run

            def counted_run(*a: Any) -> Any:
                out = run(*a)
                done.append(out[:3])
                return out

            periods.run = counted_run
        return periods

    monkeypatch.setattr(compiled, "population_periods", spy)
    yield done


def _episode(env: PopulationEnv, chunked: bool, nan_brain: bool) -> list[Any]:
    """Births, a removal, a brain made to diverge; the fingerprint after every chunk."""
    out: list[Any] = []
    robots = [spider(), gecko(), snake(3), sensor_crawler()]
    env.add_robot(robots[0])
    env.add_robot(robots[1])
    for chunk, n in enumerate((1, 7, 30, 3, 45, 60, 12, 90)):
        if chunk == 2:
            env.add_robot(robots[2])
        if chunk == 4 and env.robot_ids:
            env.remove_robot(env.robot_ids[0])
        if chunk == 5:
            env.add_robot(robots[3])
        if chunk == 6 and nan_brain:  # NaN sensor values: the crawler's sensing brain diverges
            living = env._roster.living
            living.obs = np.full(living.obs.shape, np.nan)
        target = env.steps + n
        while env.steps < target:
            ended = env.advance_periods(target - env.steps) if chunked else env.advance({})
            if ended:  # the period that ended lives, and their statuses
                out.append((env.steps, {r: tuple(s) for r, s in ended.items()}))
        out.append(_fingerprint(env))
    return out


@pytest.mark.parametrize(("max_angular_speed", "capacity", "nan_brain"),
                         [(200.0, None, False), (200.0, 8, True), (12.0, None, False)])
def test_advance_periods_is_advance_period_by_period(
        max_angular_speed: float, capacity: int | None, nan_brain: bool,
        counted: list[tuple[int, int, int]]) -> None:
    stepped, periods = (_env(max_angular_speed, capacity) for _ in range(2))
    try:
        want = _episode(stepped, False, nan_brain)
        assert not counted  # advance() alone never takes the compiled periods
        got = _episode(periods, True, nan_brain)
    finally:
        stepped.close()
        periods.close()
    _same(got, want)
    # most periods were compiled ones (where robots live: at 12 rad/s they blow up soon)
    assert sum(done for done, _, _ in counted) > (100 if max_angular_speed > 100 else 20)
    stops = {(stop, outcome) for _, stop, outcome in counted}
    if max_angular_speed < 100:  # blow-ups: periods not calm, lives ended on the way
        assert (2, compiled_outcome("unsettled")) in stops
        assert any(isinstance(entry, tuple) for entry in want)
    if capacity is not None:  # the ring grew: calm periods whose push Python made
        assert (2, compiled_outcome("calm")) in stops
    if nan_brain:  # a brain's outputs not finite: its robot flagged, the period Python's
        assert (1, 0) in stops
        assert any(isinstance(entry, tuple) for entry in want)


def compiled_outcome(name: str) -> int:
    """The extension's number of a world period's outcome."""
    return ("calm", "unsettled", "replay", "restart").index(name)


def test_the_compiled_periods_step_aside_for_a_learner_or_noise(
        counted: list[tuple[int, int, int]]) -> None:
    from revolve_env.conditions import EvaluationConditions

    env = population_env(initial_robots=[], engine="mujoco",
                         conditions=EvaluationConditions(sensor_noise=0.1))
    env.reset(seed=1)
    env.add_robot(spider())
    env.advance_periods(5)
    assert env.steps == 5 and not counted
    env.close()
    env = population_env(initial_robots=[], engine="mujoco", trajectory_length=0)
    env.reset(seed=1)
    env.add_robot(spider())
    env.add_robot(gecko(), controlled_by="agent")
    env.advance_periods(5)
    assert env.steps == 5 and not counted
    env.close()


class _Interrupted(Exception):
    """What the test's signal handler raises (Ctrl-C's KeyboardInterrupt, say)."""


def test_a_signal_stops_the_compiled_periods_with_the_env_whole() -> None:
    """Ctrl-C during a long compiled call is raised within a few periods, after the periods done
    are taken back: the env then continues to the very numbers of an uninterrupted one."""
    import signal
    import time

    def interrupt(signum: int, frame: object) -> None:
        raise _Interrupted

    stopped, straight = (_env(200.0, None) for _ in range(2))
    total = 9000
    try:
        for env in (stopped, straight):
            env.add_robot(spider())
            env.add_robot(gecko())
        previous = signal.signal(signal.SIGALRM, interrupt)
        start = time.process_time()
        try:
            signal.setitimer(signal.ITIMER_REAL, 0.1)
            with pytest.raises(_Interrupted):
                stopped.advance_periods(total)
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)
        assert time.process_time() - start < 1.0  # all 9000 periods: about 2 s of CPU
        assert 0 < stopped.steps < total
        stopped.advance_periods(total - stopped.steps)
        straight.advance_periods(total)
        _same(_fingerprint(stopped), _fingerprint(straight))
    finally:
        stopped.close()
        straight.close()


def test_statuses_after_compiled_periods_are_theirs() -> None:
    """A step's statuses, not read, do not outlive the compiled periods after it."""
    env = _env(200.0, None)
    try:
        env.add_robot(spider())
        env.step({})  # its statuses (every agent's) left unread
        assert env.advance_periods(3) == {}
        assert env.statuses == {}
        with pytest.raises(ValueError, match="n must be >= 1"):
            env.advance_periods(0)
    finally:
        env.close()
