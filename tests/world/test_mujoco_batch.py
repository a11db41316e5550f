"""Scenes of one model in mujoco.batch: bit for bit the loop over their own MjData."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mujoco")

from evolution.config import EvolutionConfig  # noqa: E402
from evolution.random_robot import random_robot  # noqa: E402
from revolve_env.body.examples import EXAMPLES  # noqa: E402
from revolve_env.body.robot import Robot  # noqa: E402
from revolve_env.world import World, WorldConfig  # noqa: E402
from revolve_env.world.model import LightSensorModel, build_model  # noqa: E402
from revolve_env.world.mujoco_batch import MujocoBatchScenes  # noqa: E402
from revolve_env.world.mujoco_scenes import MujocoScenes  # noqa: E402

CONFIG = WorldConfig(engine="mujoco")


def _light_off_the_core() -> Robot:
    """A random robot with a light sensor on a link other than the core, no touch sensor."""
    rng = np.random.default_rng(0)
    while True:
        robot = random_robot(rng, EvolutionConfig())
        model = build_model(robot)
        kinds = [kind for kind, _ in model.sensors]
        lights = [s for kind, s in model.sensors if isinstance(s, LightSensorModel)]
        if "touch" not in kinds and any(s.link != 0 for s in lights) and model.n_outputs:
            return robot


def _run(world: World, robots: list[Robot], steps: int, blow: int | None = None
         ) -> list[np.ndarray]:
    handles = [world.add_robot(r) for r in robots]
    rng = np.random.default_rng(0)
    out = []
    for t in range(steps):
        if t == blow:  # a hinge flung at an absurd speed: that scene diverges alone
            n = world.n_outputs(handles[1])
            world.set_hinge_state(handles[1], np.zeros(n), np.full(n, 1e200))
        world.set_all_targets(rng.uniform(-1, 1, world.targets.shape))
        world.step(1)
        s = world.states
        out.append(np.concatenate((s.core_pos.ravel(), s.core_rot.ravel(), s.core_vel.ravel(),
                                   s.joint_pos, s.joint_vel, world.sensor_values(),
                                   world.blown_up.astype(float))))
    return out


def _pair(robots: list[Robot], steps: int, blow: int | None = None) -> tuple[
        list[np.ndarray], list[np.ndarray], int]:
    """Both routes' periods, and the simulations the batch held (0: none)."""
    batched = World(CONFIG, isolated=True)
    assert isinstance(batched.backend, MujocoBatchScenes)
    loop = World(CONFIG, isolated=True)
    loop._backend = MujocoScenes(CONFIG)  # the loop over each scene's MjData
    a, b = _run(batched, robots, steps, blow), _run(loop, robots, steps, blow)
    batch = batched.backend._batch  # type: ignore[attr-defined]
    nsim = 0 if batch is None else batch.nsim
    batched.close()
    loop.close()
    return a, b, nsim


def test_copies_of_one_body_step_in_the_batch_bit_for_bit() -> None:
    robot = _light_off_the_core()  # its light sensor reads a link's pose from the batch
    a, b, nsim = _pair([robot] * 3, 40)
    assert nsim == 3  # the batch stepped them
    for t, (x, y) in enumerate(zip(a, b, strict=True)):
        assert np.array_equal(x, y), f"period {t} differs"


def test_a_diverging_scene_is_replayed_alone_as_in_the_loop() -> None:
    a, b, nsim = _pair([EXAMPLES["spider"]()] * 3, 12, blow=5)
    assert nsim == 3
    assert a[-1][-3:].tolist() == [0.0, 1.0, 0.0]  # the second robot blew up, alone
    for t, (x, y) in enumerate(zip(a, b, strict=True)):
        assert np.array_equal(x, y, equal_nan=True), f"period {t} differs"


def test_other_models_and_touch_sensors_fall_back_to_the_loop() -> None:
    mixed = World(CONFIG, isolated=True)
    mixed.add_robot(EXAMPLES["spider"]())
    mixed.add_robot(EXAMPLES["gecko"]())
    assert mixed.backend._batch is None  # type: ignore[attr-defined]
    mixed.close()
    touch = World(CONFIG, isolated=True)
    for _ in range(2):
        touch.add_robot(EXAMPLES["sensor_crawler"]())
    assert touch.backend._batch is None  # type: ignore[attr-defined]
    touch.close()
    with pytest.raises(ValueError, match="threads must be an integer >= 1"):
        MujocoBatchScenes(CONFIG, threads=0)


def _births_and_deaths(world: World, robots: list[Robot]) -> list[np.ndarray]:
    """Births one by one, a hinge reset, steps, a death, more births and steps: every period."""
    rng = np.random.default_rng(1)
    out = []

    def period() -> None:
        world.set_all_targets(rng.uniform(-1, 1, world.targets.shape))
        world.step(1)
        s = world.states
        out.append(np.concatenate((s.core_pos.ravel(), s.core_rot.ravel(), s.core_vel.ravel(),
                                   s.core_angvel.ravel(), s.joint_pos, s.joint_vel,
                                   world.sensor_values(), world.blown_up.astype(float))))

    handles = [world.add_robot(r, (0.1 * i, 0.0)) for i, r in enumerate(robots[:3])]
    n = world.n_outputs(handles[1])
    world.set_hinge_state(handles[1], np.full(n, 0.3), np.full(n, -0.5))
    for _ in range(6):
        period()
    world.remove_robot(handles[0])
    for i, r in enumerate(robots[3:]):
        world.add_robot(r, (0.0, 0.1 * i), 0.2 * i)
    for _ in range(6):
        period()
    return out


@pytest.mark.parametrize("kind", ["copies", "mixed"])
def test_births_extend_the_arrays_as_a_whole_relayout_would(
        kind: str, monkeypatch: pytest.MonkeyPatch) -> None:
    # A birth appends its scene to the shared buffers (and drops the batch until the next
    # step) instead of laying every scene out again: the same numbers, period by period.
    spider, light = EXAMPLES["spider"](), _light_off_the_core()
    robots = [spider] * 5 if kind == "copies" else [spider, light, spider, light, spider]
    new = World(CONFIG, isolated=True)
    a = _births_and_deaths(new, robots)
    new.close()
    monkeypatch.setattr(MujocoScenes, "_grown", lambda self, key: self._changed())
    monkeypatch.setattr(MujocoBatchScenes, "set_hinges", _relayout_after_hinges)
    old = World(CONFIG, isolated=True)
    b = _births_and_deaths(old, robots)
    old.close()
    assert len(a) == len(b) == 12
    for t, (x, y) in enumerate(zip(a, b, strict=True)):
        assert np.array_equal(x, y), f"period {t} differs"


def _relayout_after_hinges(self: MujocoBatchScenes, key: int, hinges: np.ndarray,
                           angles: np.ndarray, velocities: np.ndarray) -> None:
    """set_hinges as before: every scene laid out again."""
    self._sync()
    MujocoScenes.set_hinges(self, key, hinges, angles, velocities)
    self._layout_scenes()


def test_n_births_make_one_batch_and_no_whole_relayout(monkeypatch: pytest.MonkeyPatch) -> None:
    import mujoco  # noqa: PLC0415

    made: list[int] = []
    relayouts: list[int] = []
    batch = mujoco.batch.Batch

    def counted(model: mujoco.MjModel, nsim: int, **kwargs: object) -> mujoco.batch.Batch:
        made.append(nsim)
        return batch(model, nsim=nsim, **kwargs)

    whole = MujocoScenes._layout_scenes

    def spied(self: MujocoScenes) -> None:
        relayouts.append(len(self._scenes))
        whole(self)

    monkeypatch.setattr(mujoco.batch, "Batch", counted)
    monkeypatch.setattr(MujocoScenes, "_layout_scenes", spied)
    with World(CONFIG, isolated=True) as world:
        spider = EXAMPLES["spider"]()
        handles = [world.add_robot(spider) for _ in range(6)]
        for h in handles:
            world.set_hinge_state(h, np.full(8, 0.1), np.zeros(8))
        world.step(2)
        assert made == [6]  # one batch, made at the first step
        assert relayouts == [0]  # the empty world's only
