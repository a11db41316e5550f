"""Locomotion's compiled step (one C++ call a step) against its general Python step: the same bits.

:class:`~revolve_env.world.compiled.EnvStep` does the action, the brain, the world's period, the
task's window, the reward and the observation in one call; ``_fast_step = False`` puts the env
on its general path (the NumPy rules' world step aside, the same world). Every observation,
reward, flag and info value of whole episodes must be the same bytes on both, for every kind of
step the compiled one takes (and for blow-ups, which it hands back to Python), and its window and
``math.hypot`` must be :class:`~revolve_env.rollout.RobotWindow`'s and CPython's.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from episode_hashes import episodes, make, sensor_robot, value
from hypothesis import given, settings
from hypothesis import strategies as st

from revolve_env import LOCOMOTION_ID, LOCOMOTION_V1_ID
from revolve_env.body.examples import example
from revolve_env.rollout import RobotWindow, task_rule
from revolve_env.tasks import DirectedLocomotion, LightFollowing, Locomotion, Task
from revolve_env.world import World, WorldConfig, compiled

pytest.importorskip("mujoco", reason="the mujoco package is not installed")
pytestmark = pytest.mark.skipif(not (compiled.available() and compiled.hypot_exact()),
                                reason="the compiled rollout is not built or not exact here")

SHORT = {"insertion_time": 0.25, "evaluation_time": 1.0}
BLOWS = {"world_config": WorldConfig(max_linear_speed=0.4)}
CASES: dict[str, tuple[str, dict[str, Any]]] = {
    "agent": (LOCOMOTION_V1_ID, {}),
    "brain": (LOCOMOTION_V1_ID, {"controller": "brain"}),
    "limit": (LOCOMOTION_V1_ID, {"task": {"name": "locomotion", "limit": 0.05}}),
    "directed": (LOCOMOTION_V1_ID, {"task": {"name": "directed-locomotion", "heading": 1.0}}),
    "light-sensors-brain": (LOCOMOTION_V1_ID, {"robot": "sensors", "controller": "brain",
                                               "task": "light-following",
                                               "fitness_window": 0.5}),
    "light-no-sensor": (LOCOMOTION_V1_ID, {"task": "light-following"}),
    "every-period-short-window": (LOCOMOTION_V1_ID, {
        "task": {"name": "locomotion", "pose_rate": "every-period"}, "fitness_window": 0.3}),
    "no-insertion": (LOCOMOTION_V1_ID, {"insertion_time": 0.0, "controller": "brain"}),
    "v0-brain": (LOCOMOTION_ID, {"controller": "brain"}),
    "v0-sensors": (LOCOMOTION_ID, {"robot": "sensors"}),
    "blow-up-brain": (LOCOMOTION_V1_ID, {"robot": "sensors", "controller": "brain", **BLOWS}),
    "blow-up-agent": (LOCOMOTION_V1_ID, {"robot": "sensors", **BLOWS}),
}


def _episodes(case: str, fast: bool) -> tuple[str, int]:
    """A hash of two episodes (random actions, seeds 0 and 1) and how many blew up."""
    env_id, kwargs = CASES[case]
    env = make(env_id, {**SHORT, **kwargs}, fast)
    inner: Any = env.unwrapped

    def on_its_step() -> None:
        assert (inner._fast is not None) == fast

    try:
        return episodes(env, after_reset=on_its_step)
    finally:
        env.close()


@pytest.mark.parametrize("case", sorted(CASES))
def test_the_compiled_step_gives_the_general_steps_episodes(case: str) -> None:
    fast, blown = _episodes(case, fast=True)
    assert (fast, blown) == _episodes(case, fast=False)
    assert (blown > 0) == case.startswith("blow-up")


@pytest.mark.parametrize("kwargs", [
    {"sensor_noise": 0.1}, {"actuator_noise": 0.1}, {"action": "modulate"},
    {"task": {"name": "locomotion", "pose_rate": 5.0}, "engine": "pybullet"},
], ids=["sensor-noise", "actuator-noise", "modulate", "pybullet"])
def test_the_general_step_takes_what_the_compiled_one_does_not(kwargs: dict[str, Any]) -> None:
    if kwargs.get("engine") == "pybullet":
        pytest.importorskip("pybullet")
    env = gym.make(LOCOMOTION_V1_ID, **SHORT, **kwargs)
    env.reset(seed=0)
    assert env.unwrapped._fast is None  # type: ignore[attr-defined]
    env.step(env.action_space.sample())
    env.close()


def test_a_bad_action_is_refused_as_ever_and_other_shapes_are_read_as_ever() -> None:
    env = gym.make(LOCOMOTION_V1_ID, **SHORT)
    twin = gym.make(LOCOMOTION_V1_ID, **SHORT)
    twin.unwrapped._fast_step = False  # type: ignore[attr-defined]
    for e in (env, twin):
        e.reset(seed=0)
    n = env.action_space.shape[0]  # type: ignore[index]
    for bad in (np.zeros(n + 1, dtype=np.float32), np.full(n, np.nan)):
        for e in (env, twin):
            with pytest.raises(ValueError, match="action"):
                e.step(bad)
    # a list, a column, float64, a strided view and ints are read as the general step reads them
    for action in ([0.5] * n, np.full((n, 1), -0.25), np.linspace(-2, 2, n),
                   np.linspace(-1, 1, 2 * n)[::2], np.zeros(n, dtype=np.int64)):
        a, b = env.step(action), twin.step(action)
        assert value(a[0]) == value(b[0]) and a[1:4] == b[1:4]
        assert repr(sorted(a[4].items())) == repr(sorted(b[4].items()))
    env.close()
    twin.close()


@pytest.mark.parametrize("case", ["agent", "blow-up-brain"])
def test_both_steps_give_the_same_info_dicts(case: str) -> None:
    """The same keys in the same order, the same types and bits, step after step (reset, the
    compiled step's own steps, the blow-up that Python finishes)."""
    env_id, kwargs = CASES[case]
    envs = [make(env_id, {**SHORT, **kwargs}, fast) for fast in (True, False)]
    infos: list[list[list[tuple[str, type, str]]]] = [[], []]
    for e, got in zip(envs, infos, strict=True):
        got.append([(k, type(v), value(v)) for k, v in e.reset(seed=0)[1].items()])
        assert (e.unwrapped._fast is not None) == (e is envs[0])  # type: ignore[attr-defined]
        rng, done = np.random.default_rng(0), False
        while not done:
            out = e.step(rng.uniform(-1.0, 1.0, e.action_space.shape).astype(np.float32))
            got.append([(k, type(v), value(v)) for k, v in out[4].items()])
            done = out[2] or out[3]
        e.close()
    assert infos[0] == infos[1]
    assert [k for k, _, _ in infos[0][-1]] == ["fitness", "fitness_v", "fitness_s",
                                              "reward_fitness", "time", "evaluating",
                                              "x_position", "y_position", "blow_up"]
    assert (infos[0][-1][-1][2] != "None") == case.startswith("blow-up")


def test_the_world_is_the_general_steps_after_compiled_steps() -> None:
    """The world's states, sensors, targets and clock as the general step leaves them."""
    envs = [gym.make(LOCOMOTION_V1_ID, robot=sensor_robot(), controller="brain", **SHORT)
            for _ in range(2)]
    envs[1].unwrapped._fast_step = False  # type: ignore[attr-defined]
    for e in envs:
        e.reset(seed=3)
        for _ in range(20):
            e.step(np.zeros(e.action_space.shape, dtype=np.float32))
    a, b = (e.unwrapped._world for e in envs)  # type: ignore[attr-defined]
    assert a.time == b.time
    assert np.array_equal(a.targets, b.targets)
    assert np.array_equal(a.sensor_values(), b.sensor_values())
    for field in ("core_pos", "core_rot", "core_vel", "core_angvel", "joint_pos", "joint_vel",
                  "diverged"):
        assert np.array_equal(getattr(a.states, field), getattr(b.states, field))
    assert envs[0].unwrapped._run.periods == envs[1].unwrapped._run.periods  # type: ignore
    for e in envs:
        e.close()


def test_the_brain_has_one_owner_and_what_the_env_reads_of_it_is_shared() -> None:
    """The compiled step steps the brain (compiled.EnvStep's doc): the held outputs the env
    reads are the Rollout's own array, written in place, and the general step's to the bit, as
    are the periods; the Rollout's controller is not stepped beside it (it stays as reset)."""
    envs = [gym.make(LOCOMOTION_V1_ID, robot=sensor_robot(), controller="brain", **SHORT)
            for _ in range(2)]
    envs[1].unwrapped._fast_step = False  # type: ignore[attr-defined]
    runs: list[Any] = []
    for e in envs:
        e.reset(seed=3)
        run = e.unwrapped._run  # type: ignore[attr-defined]
        held = run.outputs
        for _ in range(25):
            e.step(np.zeros(e.action_space.shape, dtype=np.float32))
        assert run.outputs is held and e.unwrapped._brain_out is held  # type: ignore
        runs.append(run)
    fast, general = runs
    assert envs[0].unwrapped._fast is not None  # type: ignore[attr-defined]
    assert fast.outputs.tobytes() == general.outputs.tobytes() and fast.outputs.any()
    assert fast.periods == general.periods == 25
    net = fast.network(envs[0].unwrapped._handle)  # type: ignore[attr-defined]
    assert fast.brain.time(net) == 0.0 and not np.any(fast.brain.get_state(net))
    assert general.brain.time(net) > 0.0
    for e in envs:
        e.close()


def test_a_period_replayed_for_a_nan_force_is_the_general_steps(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A NaN force: the backend replays the period (the compiled step hands it back), the robot
    blows up as on the general step; the next episode steps on the compiled step again."""
    monkeypatch.chdir(tmp_path)  # MuJoCo logs its NaN warning to ./MUJOCO_LOG.TXT
    runs = []
    for fast in (True, False):
        env = gym.make(LOCOMOTION_V1_ID, controller="brain", **SHORT)
        inner: Any = env.unwrapped
        inner._fast_step = fast
        out = []
        for seed in (0, 1):
            env.reset(seed=seed)
            for t in range(60):
                data = inner._world.backend._data
                data.xfrc_applied[-1, 0] = np.nan if (seed, t) == (0, 30) else 0.0
                step = env.step(np.zeros(env.action_space.shape, dtype=np.float32))
                out.append(value(step[0]) + repr(step[1:4]) + repr(sorted(
                    (k, value(v)) for k, v in step[4].items())))
                if step[2] or step[3]:
                    break
        runs.append(out)
        env.close()
    assert runs[0] == runs[1]
    assert "non-finite" in runs[0][30] and len(runs[0]) == 31 + 60


def test_the_compiled_step_holds_only_the_world_step_it_steps() -> None:
    """A remade scene hands the env step the world's new step (adopt, as after a replay): the
    one it stepped before is let go, however often that happens; a reset makes a new env step
    and lets the last one's go. (Each extension world step below is referenced by the test's
    variable and getrefcount's argument only once nothing else holds it: a count of 2.)"""
    env = gym.make(LOCOMOTION_V1_ID, controller="brain", **SHORT)
    inner: Any = env.unwrapped
    action = np.zeros(env.action_space.shape, dtype=np.float32)
    env.reset(seed=0)
    fast, world = inner._fast, inner._world
    for _ in range(30):
        old = fast._run.extension_step
        world._compiled = None  # the world's compiled step made again, as a replay makes it
        fast.adopt(world.compiled_step())
        assert sys.getrefcount(old) == 2
        assert env.step(action)[4]["blow_up"] is None  # it steps the new one
    assert sys.getrefcount(fast._run.extension_step) > 2  # the live one is held
    del fast, world
    for seed in range(1, 30):
        old = inner._fast._run.extension_step
        env.reset(seed=seed)
        env.step(action)
        assert sys.getrefcount(old) == 2
    env.close()


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.floats(allow_nan=False, allow_infinity=False),
                          st.floats(allow_nan=False, allow_infinity=False)), min_size=1,
                max_size=20))
def test_the_extensions_hypot_is_cpythons(pairs: list[tuple[float, float]]) -> None:
    ext: Any = compiled._extension()
    a, b = (np.array(v, dtype=np.float64) for v in zip(*pairs, strict=True))
    got = ext.py_hypots(a, b)
    assert [x.hex() for x in got.tolist()] == [math.hypot(x, y).hex() for x, y in pairs]


TASKS: list[Task] = [Locomotion(), Locomotion(limit=0.3), Locomotion(s_weight=2.5, limit=0.05),
                     DirectedLocomotion(heading=2.0), LightFollowing()]


@settings(max_examples=60, deadline=None)
@given(task=st.sampled_from(TASKS), rate=st.sampled_from([60.0, 30.0, 15.0, 5.0]),
       window=st.sampled_from([0.05, 0.2, 1.0]), insertion=st.integers(0, 3),
       seed=st.integers(0, 2**32 - 1), far=st.booleans())
def test_the_compiled_window_is_robot_windows(task: Task, rate: float, window: float,
                                              insertion: int, seed: int, far: bool) -> None:
    """Pushes of random poses and signals (far: past 1 km, its rebase): the same terms."""
    rng = np.random.default_rng(seed)
    dt = 1 / 60
    task = dataclasses.replace(task, pose_rate=rate)  # type: ignore[type-var]
    rule = task_rule(task)
    assert rule is not None
    theirs = RobotWindow(task, window, dt, insertion)
    with World(WorldConfig()) as world:
        handle = world.add_robot(example("spider"))
        state, _ = world.plan(handle)
        run = compiled.env_step(world, 8, 6, state.joint_start + state.active_local, True,
                                -np.ones(22), np.ones(22), rule, window, insertion,
                                theirs.stride, np.zeros(0, dtype=np.intp), None, None,
                                world.compiled_step())
        assert run is not None
        ours = run.window
        x, y, t = 0.0, 0.0, 0.0
        for age in range(insertion, insertion + 40):
            t += dt
            x += float(rng.normal()) * (300.0 if far else 0.01)
            y += float(rng.normal()) * 0.01
            signal = float(rng.uniform()) if task.signal is not None else None
            ours.push(t, x, y, age, signal)
            theirs.push(t, x, y, age, signal)
            want = theirs.terms()
            got = ours.terms()
            assert [v.hex() for v in got] == [want.fitness.hex(), want.v.hex(), want.s.hex()]
            assert ours.holds(age) == theirs.holds(age) and len(ours) == len(theirs)
