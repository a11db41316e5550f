"""pybullet's worlds take their rules from the compiled extension (compiled.Rules), to the bit.

A pybullet World keeps its engine calls in Python and computes the target clipping, the servo
law, the blow-up screen, the IMU and the light sensors in C++ when the extension is usable; these
tests run the same periods twice, once so and once on the NumPy rules (``compiled.rules``
declining), and ask for the same states, sensor values, targets and blow-ups to the bit: brains
(at two brain periods), touch and light sensors on cores and moving links, blow-ups, deaths, a
diverged controller.
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable
from dataclasses import fields
from typing import Any

import numpy as np
import pytest
from random_robots import has_sensors, random_robots

from revolve_env.body.robot import Robot
from revolve_env.evaluation import EvaluationResult, evaluate_many
from revolve_env.rollout import Rollout
from revolve_env.world import World, WorldConfig, compiled
from revolve_env.world.backend import BodyStates
from revolve_env.world.blowups import Screen, all_calm
from revolve_env.world.sensing import IMU_HIGH

pytest.importorskip("pybullet", reason="the pybullet package is not installed")
pytestmark = pytest.mark.skipif(not compiled.available(),
                                reason="the compiled rollout is not built or not exact here")


def _both(monkeypatch: pytest.MonkeyPatch, run: Callable[[], Any]) -> tuple[Any, Any]:
    """``run()`` on the compiled rules (asserting that they were used), then on NumPy's."""
    made: list[bool] = []
    real = compiled.rules

    def spy(c: WorldConfig) -> compiled.Rules | None:
        out = real(c)
        made.append(out is not None)
        return out

    with monkeypatch.context() as m:
        m.setattr(compiled, "rules", spy)
        fast = run()
    assert made and all(made)
    with monkeypatch.context() as m:
        m.setattr(compiled, "rules", lambda c: None)
        slow = run()
    return fast, slow


def _states(s: BodyStates) -> tuple[bytes, ...]:
    return tuple(np.ascontiguousarray(getattr(s, f.name)).tobytes() for f in fields(s))


def _periods(robots: list[Robot], config: WorldConfig, periods: int) -> list[Any]:
    """Every period's states, sensor values, targets and blow-ups of brain-driven robots in one
    pybullet world; a blown robot leaves; one robot's controller diverges at period 20."""
    out: list[Any] = []
    with World(config) as world:
        run = Rollout(world)
        for i, r in enumerate(robots):
            run.add(r, (1.5 * i, 0.0), 0.3 * i, network=r, relayout=False)
        run.relayout()
        for t in range(periods):
            if t == 20:  # a diverged controller: flagged, its hinges held at 0
                h = world.handles[-1]
                world.set_targets(h, np.full(world.n_outputs(h), np.nan))
            values = world.sensor_values() if run.thinking else None
            blown = run.period(values)
            out.append((_states(world.states), world.sensor_values().tobytes(),
                        world.targets.tobytes(), [world.blow_up(h) for h in world.handles]))
            if blown is not None:
                run.remove([h for h, b in zip(world.handles, blown.tolist(), strict=True) if b])
    return out


@pytest.mark.parametrize("brain_period", [1 / 60, 2 / 60])
def test_pybullet_periods_on_the_compiled_rules_equal_the_numpy_rules(
        monkeypatch: pytest.MonkeyPatch, brain_period: float) -> None:
    robots = random_robots(8, 11)
    has_sensors(robots)
    config = WorldConfig(engine="pybullet", max_linear_speed=0.6, brain_period=brain_period)
    fast, slow = _both(monkeypatch, lambda: _periods(robots, config, 90))
    assert fast == slow
    reasons = [r for *_, blown in fast for r in blown if r is not None]
    assert any("non-finite hinge targets" in r for r in reasons)
    assert any("core speed" in r for r in reasons)  # the screen failed and a robot blew up
    assert len(fast[-1][3]) < len(robots)  # and left


def _key(r: EvaluationResult) -> tuple[Any, ...]:
    return (r.fitness.hex(), r.v.hex(), r.s.hex(), r.shaking.hex(), r.blow_up,
            r.trajectory.shape, r.trajectory.tobytes())


def test_evaluate_many_on_pybullet_is_the_same_on_either_rules(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Isolated worlds (evaluate_many), the light task's signal, blow-ups at various times."""
    robots = random_robots(6, 3)
    kwargs: dict[str, Any] = {"engine": "pybullet", "seconds": 1.5, "insertion": 0.5,
                              "task": "light-following",
                              "config": WorldConfig(engine="pybullet", max_linear_speed=0.5)}
    fast, slow = _both(monkeypatch, lambda: evaluate_many(robots, **kwargs))
    assert [_key(r) for r in fast] == [_key(r) for r in slow]
    assert any(r.blow_up for r in fast) and not all(r.blow_up for r in fast)


def test_the_compiled_screen_is_all_calm(monkeypatch: pytest.MonkeyPatch) -> None:
    """The screen on random states with entries near and past its limits, NaN, infinities and
    a diverged robot: the same verdict as blowups.all_calm every time."""
    c = WorldConfig(engine="pybullet")
    rules = compiled.rules(c)
    assert rules is not None
    rng = np.random.default_rng(5)
    verdicts = set()
    for trial in range(400):
        n = int(rng.integers(1, 5))
        joints = rng.integers(0, 4, size=n)
        offsets = np.concatenate(([0], np.cumsum(joints))).astype(np.intp)
        J = int(offsets[-1])
        scale = rng.choice([0.1, 10.0, 40.0])
        s = BodyStates(rng.normal(size=(n, 3)) * scale, rng.normal(size=(n, 3, 3)),
                       rng.normal(size=(n, 3)) * scale, rng.normal(size=(n, 3)) * scale,
                       rng.normal(size=J) * scale, rng.normal(size=J) * scale,
                       np.zeros(n, dtype=bool))
        odd = trial % 8
        field = [s.core_pos, s.core_rot, s.core_vel, s.core_angvel][odd % 4]
        if odd < 4 and trial % 3 == 0:
            field.reshape(-1)[0] = [np.nan, np.inf, -np.inf][trial % 3 // 1 % 3]
        elif odd == 5:
            s.core_pos[0, 2] = -0.999 - rng.random() * 1e-3
        elif odd == 6:
            s.diverged[-1] = True
        elif odd == 7 and J:
            s.joint_vel[-1] = np.nan
        want = all_calm(s, Screen(n, J, c))
        assert rules.calm(s, offsets, Screen(n, J, c)) == want
        verdicts.add(want)
    assert verdicts == {True, False}


def test_the_compiled_targets_and_servo_law_are_the_numpy_rules() -> None:
    c = WorldConfig(engine="pybullet")
    rules = compiled.rules(c)
    assert rules is not None
    rng = np.random.default_rng(9)
    t = rng.normal(size=200) * 2
    out = np.full(200, 7.0)
    assert rules.clip_targets(t, out)
    scale = np.radians(c.range_deg)
    assert out.tobytes() == (np.minimum(np.maximum(t, -1.0), 1.0) * scale).tobytes()
    bad = t.copy()
    bad[17] = np.nan
    before = out.copy()
    assert not rules.clip_targets(bad, out) and out.tobytes() == before.tobytes()
    joint_pos = rng.normal(size=300)
    active = rng.choice(300, size=200, replace=False).astype(np.intp)
    joint_pos[active[3]] = np.nan
    k = c.servo_gain / c.control_period
    want = np.minimum(np.maximum(k * (out - joint_pos[active]), -c.max_velocity),
                      c.max_velocity)
    assert rules.servo(out, joint_pos, active).tobytes() == want.tobytes()
    with pytest.raises(ValueError, match="active hinge out of range"):
        rules.servo(out[:1], joint_pos, np.array([300], dtype=np.intp))


def test_mujoco_worlds_do_not_take_the_array_rules() -> None:
    assert compiled.rules(WorldConfig(engine="mujoco")) is None


def test_the_compiled_sensors_saturate_and_let_nan_through_as_numpy_does() -> None:
    """IMU values past full scale (saturated) and NaN (kept), touch and light sensors on cores
    and links: the compiled sensor values of states made up for it are the NumPy rules'."""
    robots = random_robots(8, 11)
    with World(WorldConfig(engine="pybullet")) as world:
        for i, r in enumerate(robots):
            world.add_robot(r, (1.5 * i, 0.0))
        world.step(3)
        rules = world._rules
        assert rules is not None
        s = world.states
        rng = np.random.default_rng(4)
        n = s.core_pos.shape[0]
        spin = rng.normal(size=(n, 3)) * 60.0
        spin[2, 1] = np.nan
        world._now = BodyStates(s.core_pos, s.core_rot, s.core_vel + rng.normal(size=(n, 3)) * 5,
                                spin, s.joint_pos, s.joint_vel, s.diverged)
        world._sensors = world._imu = None
        fast = world.sensor_values().copy()
        world._rules = None
        world._sensors = world._imu = None
        slow = world.sensor_values()
        imu = fast[world.input_offsets[:-1, None] + np.arange(6)]
    assert fast.tobytes() == slow.tobytes()
    assert (np.abs(imu) == IMU_HIGH).any() and np.isnan(imu[2, 3:]).all()  # robot 2 gyro


def test_without_mujoco_pybullet_keeps_the_numpy_rules() -> None:
    """The extension links MuJoCo's library: a pybullet-only install steps on NumPy's rules; with
    ``mujoco`` installed, a pybullet world takes the compiled rules without importing it."""
    code = (
        "import importlib.util, sys\n"
        "from revolve_env.world import World, WorldConfig, compiled\n"
        "with World(WorldConfig(engine='pybullet')) as world:\n"
        "    assert world._rules is not None\n"
        "assert 'mujoco' not in sys.modules\n"
        "compiled._rules_extension.cache_clear()\n"
        "real = importlib.util.find_spec\n"
        "importlib.util.find_spec = lambda name, *a: None if name == 'mujoco' else real(name, *a)\n"
        "with World(WorldConfig(engine='pybullet')) as world:\n"
        "    assert world._rules is None\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)
