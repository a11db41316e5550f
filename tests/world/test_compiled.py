"""The compiled rollout (revolve_env.world.compiled) gives the NumPy rules' numbers, bit for bit."""

from __future__ import annotations

import importlib
import logging
import signal
import time
from pathlib import Path
from types import ModuleType, SimpleNamespace
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from random_robots import random_robots

import revolve_env.envs  # noqa: F401  (registers the envs)
from revolve_env import LOCOMOTION_V1_ID
from revolve_env._controller import BatchController
from revolve_env.body.examples import example
from revolve_env.body.robot import Robot
from revolve_env.brain._registry import as_spec
from revolve_env.conditions import EvaluationConditions
from revolve_env.evaluation import EvaluationResult, evaluate_many
from revolve_env.world import WorldConfig, build_model, compiled
from revolve_env.world.model import LightSensorModel

pytest.importorskip("mujoco", reason="the mujoco package is not installed")
pytestmark = pytest.mark.skipif(not compiled.available(),
                                reason="the compiled rollout is not built or not exact here")


def _key(r: EvaluationResult) -> tuple[Any, ...]:
    return (r.fitness.hex(), r.v.hex(), r.s.hex(), r.shaking.hex(), r.blow_up,
            r.trajectory.shape, r.trajectory.tobytes())


def _numpy(monkeypatch: pytest.MonkeyPatch, robots: list[Robot],
           **kwargs: Any) -> list[EvaluationResult]:
    """evaluate_many on the NumPy rules (the compiled rollout declines)."""
    with monkeypatch.context() as m:
        m.setattr(compiled, "rollout", lambda *a, **k: None)
        return evaluate_many(robots, engine="mujoco", **kwargs)


def _compiled(monkeypatch: pytest.MonkeyPatch, robots: list[Robot],
              **kwargs: Any) -> list[EvaluationResult]:
    """evaluate_many, asserting that the compiled rollout ran it."""
    calls = []
    run = compiled.rollout

    def spy(*a: Any, **k: Any) -> Any:
        out = run(*a, **k)
        calls.append(out is not None)
        return out

    with monkeypatch.context() as m:
        m.setattr(compiled, "rollout", spy)
        results = evaluate_many(robots, engine="mujoco", **kwargs)
    assert calls == [True]
    return results


def test_examples_and_random_robots_with_sensors_are_the_numpy_rules_bit_for_bit(
        monkeypatch: pytest.MonkeyPatch) -> None:
    robots = [example("spider"), example("gecko"), example("sensor_crawler")] + random_robots(20, 7)
    models = [build_model(r) for r in robots]
    lights = [s for m in models for _, s in m.sensors if isinstance(s, LightSensorModel)]
    assert any(s.link > 0 for s in lights) and any(s.link == 0 for s in lights)
    assert any(kind == "touch" for m in models for kind, _ in m.sensors)
    timing = {"seconds": 1.0, "insertion": 0.5, "seeds": list(range(len(robots)))}
    fast = _compiled(monkeypatch, robots, **timing)
    slow = _numpy(monkeypatch, robots, **timing)
    assert [_key(a) for a in fast] == [_key(b) for b in slow]
    assert all(r.blow_up is None for r in fast)


def test_blow_ups_are_judged_by_the_numpy_rules_and_leave_the_others_exact(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A low speed limit: some robots' screens fail, some of those blow up (at various times),
    some robots do not; a brain stride of 2 and random starts on the way."""
    robots = random_robots(10, 11) + [example("spider")]
    kwargs: dict[str, Any] = {
        "seconds": 1.0, "insertion": 0.5,
        "config": WorldConfig(max_linear_speed=0.5, brain_period=2 / 60),
        "conditions": EvaluationConditions(heading="random", position_jitter=0.1)}
    fast = _compiled(monkeypatch, robots, **kwargs)
    slow = _numpy(monkeypatch, robots, **kwargs)
    assert [_key(a) for a in fast] == [_key(b) for b in slow]
    blown = [r.blow_up is not None for r in fast]
    assert any(blown) and not all(blown)
    assert len({r.trajectory.shape[0] for r in fast if r.blow_up}) > 1  # at different times


def test_a_robot_whose_physics_turns_nan_is_evaluated_on_the_numpy_path(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from revolve_env.world.mujoco_backend import MujocoBackend

    monkeypatch.chdir(tmp_path)  # MuJoCo logs its NaN warning to ./MUJOCO_LOG.TXT
    spider = example("spider")
    robots = [example("gecko"), spider, example("sensor_crawler")]
    links = len(build_model(spider).links)
    assert [len(build_model(r).links) == links for r in robots] == [False, True, False]
    add = MujocoBackend.add

    def poisoned(self: MujocoBackend, model: Any, *args: Any) -> int:
        key = add(self, model, *args)
        if len(model.links) == links:  # a force that makes the spider's dynamics NaN
            self._data.xfrc_applied[2, 0] = np.nan
        return key

    monkeypatch.setattr(MujocoBackend, "add", poisoned)
    timing = {"seconds": 0.5, "insertion": 0.25}
    fast = _compiled(monkeypatch, robots, **timing)
    slow = _numpy(monkeypatch, robots, **timing)
    assert [_key(a) for a in fast] == [_key(b) for b in slow]
    assert fast[1].blow_up is not None and "non-finite" in fast[1].blow_up
    assert fast[0].blow_up is None and fast[2].blow_up is None


def test_threads_change_no_number(monkeypatch: pytest.MonkeyPatch) -> None:
    """1, 3 and 16 threads (more than robots), on rugged ground with no insertion: the same
    numbers, the NumPy rules'."""
    robots = random_robots(7, 5) + [example("spider")]
    kwargs: dict[str, Any] = {"seconds": 1.0, "insertion": 0.0, "terrain": "rugged",
                              "config": WorldConfig(max_linear_speed=0.8)}
    one = _compiled(monkeypatch, robots, threads=1, **kwargs)
    three = _compiled(monkeypatch, robots, threads=3, **kwargs)
    many = _compiled(monkeypatch, robots, threads=16, **kwargs)
    slow = _numpy(monkeypatch, robots, **kwargs)
    assert [_key(a) for a in one] == [_key(b) for b in three] == [_key(c) for c in many] \
        == [_key(d) for d in slow]


def test_threads_must_be_a_positive_whole_number() -> None:
    for bad in (0, -1, 1.5, True):
        with pytest.raises(ValueError, match="threads"):
            evaluate_many([example("spider")], engine="mujoco", threads=bad)  # type: ignore[arg-type]


def test_the_light_signal_is_the_numpy_rules_bit_for_bit(monkeypatch: pytest.MonkeyPatch) -> None:
    """The light-following task's signal: robots with light sensors (on the core, on moving
    links) and without; one blows up."""
    robots = [example("sensor_crawler"), example("spider")] + random_robots(8, 7)
    kwargs: dict[str, Any] = {"seconds": 1.0, "insertion": 0.5, "task": "light-following",
                              "config": WorldConfig(max_linear_speed=0.6)}
    fast = _compiled(monkeypatch, robots, **kwargs)
    slow = _numpy(monkeypatch, robots, **kwargs)
    assert [_key(a) for a in fast] == [_key(b) for b in slow]
    assert len({r.fitness for r in fast}) > 2


def test_noise_and_pybullet_keep_the_numpy_path(monkeypatch: pytest.MonkeyPatch) -> None:
    """Noise draws from each robot's NumPy generator: the compiled rollout is not asked; on
    pybullet it declines."""
    seen: list[bool] = []
    run = compiled.rollout

    def spy(*a: Any, **k: Any) -> Any:
        out = run(*a, **k)
        seen.append(out is not None)
        return out

    monkeypatch.setattr(compiled, "rollout", spy)
    robot = example("spider")
    evaluate_many([robot], seconds=0.2, insertion=0.1, engine="mujoco",
                  conditions=EvaluationConditions(sensor_noise=0.1))
    evaluate_many([robot], seconds=0.2, insertion=0.1, engine="pybullet")
    assert seen == [False]


def test_without_the_extension_the_numpy_rules_run_and_say_so_once(
        monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    """Not built (no compiler or no mujoco wheel at install), or built for another mujoco:
    one log line, then the NumPy path, to the same numbers."""
    want = _numpy(monkeypatch, [example("spider")], seconds=0.3, insertion=0.1)
    real = importlib.import_module

    def missing(name: str, package: str | None = None) -> ModuleType:
        if name == "revolve_env._rollout":
            raise ImportError("No module named 'revolve_env._rollout'")
        return real(name, package)

    try:
        for broken in ("missing", "other mujoco"):
            compiled._extension.cache_clear()
            caplog.clear()
            with monkeypatch.context() as m:
                if broken == "missing":
                    m.setattr(importlib, "import_module", missing)
                else:
                    m.setattr(real("revolve_env._rollout"), "MUJOCO_VERSION", "0.0.1")
                with caplog.at_level(logging.WARNING, logger=compiled.__name__):
                    got = [evaluate_many([example("spider")], engine="mujoco", seconds=0.3,
                                         insertion=0.1)[0] for _ in range(2)]
                    assert not compiled.available()
            lines = [r.getMessage() for r in caplog.records]
            assert len(lines) == 1 and "NumPy rules" in lines[0], lines
            assert [_key(g) for g in got] == [_key(want[0])] * 2
    finally:
        compiled._extension.cache_clear()
    assert compiled.available()


class _Interrupted(Exception):
    pass


def test_a_signal_interrupts_a_long_compiled_evaluation() -> None:
    """Ctrl-C (here a timer's signal handler that raises) is not held up until the whole batch
    is done: the compiled rollout looks for signals between robots."""
    def interrupt(signum: int, frame: object) -> None:
        raise _Interrupted

    robots = random_robots(12, 9)
    previous = signal.signal(signal.SIGALRM, interrupt)
    start = time.process_time()
    try:
        signal.setitimer(signal.ITIMER_REAL, 0.3)
        with pytest.raises(_Interrupted):
            evaluate_many(robots, engine="mujoco", seconds=60.0, insertion=0.0)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    assert time.process_time() - start < 2.0  # the whole batch: about 4 s of CPU


@pytest.mark.slow
def test_a_whole_evaluation_of_a_generation_is_exact(monkeypatch: pytest.MonkeyPatch) -> None:
    """The paper's 3 s + 12 s, 10 random robots and the spider."""
    robots = random_robots(10, 3) + [example("spider")]
    fast = _compiled(monkeypatch, robots, threads=2)
    slow = _numpy(monkeypatch, robots)
    assert [_key(a) for a in fast] == [_key(b) for b in slow]


def test_both_extensions_read_a_networks_arrays_by_one_rule(monkeypatch: pytest.MonkeyPatch
                                                            ) -> None:
    """The controller's BatchController.add and the compiled env step's brain take a network's
    arrays through one function (revolve/network_view.hpp): the same checks, the same errors."""
    spec = as_spec(example("spider"))
    arrays = {f: getattr(spec, f) for f in ("kinds", "neuron_params", "src", "dst", "weight")}
    bad = [{**arrays, "weight": np.append(arrays["weight"], 0.5)},
           {**arrays, "neuron_params": arrays["neuron_params"][:-1]}]
    messages = []
    for broken in bad:
        with pytest.raises(ValueError) as controller:
            BatchController(0.1).add(*broken.values(), spec.n_inputs, spec.n_outputs)
        network = SimpleNamespace(**broken, n_inputs=spec.n_inputs, n_outputs=spec.n_outputs)
        monkeypatch.setattr(compiled, "as_spec", lambda _robot, net=network: net)
        env = gym.make(LOCOMOTION_V1_ID, controller="brain", insertion_time=0.25,
                       evaluation_time=0.5)
        with pytest.raises(ValueError) as env_step:
            env.reset(seed=0)  # the compiled env step is made at reset
        env.close()
        assert str(env_step.value) == str(controller.value)
        messages.append(str(controller.value))
    assert messages == ["src, dst and weight must have the same length",
                        f"neuron_params must have shape ({len(spec.kinds)}, 5)"]
