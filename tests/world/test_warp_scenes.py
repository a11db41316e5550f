"""MuJoCo Warp (``engine="mujoco_warp"``): copies of one body stepped on Warp's device.

The stepping tests run on Warp's device: the CPU here, a GPU where there is one. They are
marked ``warp`` and ``slow`` (Warp compiles its kernels the first time a shape is stepped:
minutes on a CPU; they then live in Warp's own cache, ``~/.cache/warp``) and skip when the warp
extra is not installed::

    python -m pytest tests/world/test_warp_scenes.py -m warp -n0

The refusals and the engine's record run in the default suite (no Warp step).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest
from numpy.typing import NDArray

from evolution.learning import CandidateEvaluation
from evolution.learning.params import evaluate_params
from revolve_env import Setting
from revolve_env.body.examples import EXAMPLES
from revolve_env.body.robot import Robot
from revolve_env.brain import get_params, param_bounds
from revolve_env.evaluation import evaluate_many
from revolve_env.world import World, WorldConfig, engines
from revolve_env.world.backend import EngineUnavailableError
from revolve_env.world.config import DEFAULT_ENGINE

WARP = "mujoco_warp"
stepping = [pytest.mark.warp, pytest.mark.slow]


def _warp() -> None:
    pytest.importorskip("mujoco_warp", reason="the warp extra (mujoco-warp) is not installed")


# -- the record and the refusals (no Warp step) ---------------------------------------------------
def test_the_engine_declares_what_it_is_and_is_never_the_default() -> None:
    record = engines.engine(WARP)
    assert (record.deterministic, record.isolated_exact, record.exact_restore, record.gui,
            record.shared_world) == (False,) * 5
    assert record.extra == "warp" and record.device == "warp"
    assert DEFAULT_ENGINE == WorldConfig().engine == Setting().engine == "mujoco"
    assert WARP not in engines.capable("deterministic")


def test_what_it_lacks_is_refused_in_one_line_naming_the_flag() -> None:
    for kwargs, flag in (({}, "shared_world"), ({"gui": True}, "gui")):
        with pytest.raises(RuntimeError) as error:
            World(WorldConfig(engine=WARP), **kwargs)  # type: ignore[arg-type]
        assert "\n" not in str(error.value)
        assert f"its capability {flag} is False" in str(error.value)


def test_a_missing_or_broken_install_is_one_line_naming_the_extra(
        monkeypatch: pytest.MonkeyPatch) -> None:
    record = engines.engine(WARP)
    for broken in (dataclasses.replace(record, package="no_such_warp"),
                   dataclasses.replace(record, isolated="revolve_env.world.no_such:WarpScenes")):
        monkeypatch.setattr(engines, "TABLE", tuple(
            broken if e.name == WARP else e for e in engines.TABLE))
        with pytest.raises(EngineUnavailableError) as error:
            World(WorldConfig(engine=WARP), isolated=True)
        assert "\n" not in str(error.value)
        assert "pip install 'revolve-env[warp]'" in str(error.value)


def test_snapshots_are_refused_naming_the_flag() -> None:
    _warp()
    with World(WorldConfig(engine=WARP), isolated=True) as world:
        world.add_robot(EXAMPLES["spider"]())
        assert not world.exact_restore
        with pytest.raises(NotImplementedError, match="its capability exact_restore is False"):
            world.snapshot()


# -- stepping (Warp's device) ---------------------------------------------------------------------
def _run(engine: str, robots: list[Robot], periods: int,
         graphs: bool = True) -> tuple[NDArray[np.float64], ...]:
    """Core positions, hinge angles and sensor values after ``periods`` of swinging targets."""
    with World(WorldConfig(engine=engine), isolated=True) as world:
        if engine == WARP:
            world.backend.graphs = graphs  # type: ignore[attr-defined]
        handles = [world.add_robot(robot) for robot in robots]
        for t in range(periods):
            for h in handles:
                world.set_targets(h, 0.8 * np.sin(t / 10 + np.arange(world.n_outputs(h))))
            world.step(1)
        if engine == WARP:
            import warp as wp

            assert world.backend.device == str(wp.get_preferred_device())  # type: ignore[attr-defined]
            groups = world.backend._groups  # type: ignore[attr-defined]  # noqa: SLF001
            assert len(groups) == 2
            if periods > 1:  # recorded from the second period on, or never
                assert all((g.recorded[world.config.substeps] is not None) == graphs
                           for g in groups)
        return (world.core_positions(), world.hinge_angles(), world.sensor_values())


@pytest.mark.parametrize("_", [pytest.param(None, marks=stepping)])
def test_copies_of_the_spider_step_as_on_cpu_mujoco(_: None) -> None:
    """Three spiders (one batch) and the touch-sensing crawler (a batch of its own), 1 s."""
    _warp()
    robots = [EXAMPLES["spider"]() for _ in range(3)] + [EXAMPLES["sensor_crawler"]()]
    warp, cpu = _run(WARP, robots, 60), _run("mujoco", robots, 60)
    positions, angles, sensors = (np.abs(a - b).max() for a, b in zip(warp, cpu, strict=True))
    assert positions < 1e-3  # metres (measured 2026-11-27: see docs/engines.md)
    assert angles < 1e-2  # radians
    assert sensors < 1e-2  # IMU, touch and light values
    assert np.array_equal(warp[0][0], warp[0][1])  # copies of one start in one batch: alike


@pytest.mark.parametrize("_", [pytest.param(None, marks=stepping)])
def test_a_period_as_one_warp_graph_steps_as_its_kernels_launched_one_by_one(_: None) -> None:
    """The same kernels, 1 s: bit for bit on the CPU; on a GPU within float32 atomics' spread."""
    _warp()
    import warp as wp

    robots = [EXAMPLES["spider"]() for _ in range(3)] + [EXAMPLES["sensor_crawler"]()]
    graph, one_by_one = _run(WARP, robots, 60), _run(WARP, robots, 60, graphs=False)
    if not wp.get_preferred_device().is_cuda:
        for a, b in zip(graph, one_by_one, strict=True):
            assert np.array_equal(a, b)
        return
    positions, angles, sensors = (np.abs(a - b).max()
                                  for a, b in zip(graph, one_by_one, strict=True))
    assert positions < 1e-4  # metres
    assert angles < 1e-3  # radians
    assert sensors < 1e-3


@pytest.mark.parametrize("_", [pytest.param(None, marks=stepping)])
def test_a_diverged_world_is_put_at_rest_alone_and_reported(_: None) -> None:
    _warp()

    def run(poison: bool) -> tuple[NDArray[np.float64], list[str | None], NDArray[np.float64],
                                   NDArray[np.float64]]:
        with World(WorldConfig(engine=WARP), isolated=True) as world:
            handles = [world.add_robot(EXAMPLES["spider"]()) for _ in range(3)]
            for h in handles:
                world.set_targets(h, np.full(world.n_outputs(h), 0.5))
            world.step(5)
            before = world.core_positions()
            if poison:  # a NaN in the middle world's velocities, on the device
                data = world.backend._groups[0].data  # type: ignore[attr-defined]  # noqa: SLF001
                qvel = data.qvel.numpy()
                qvel[1, :] = np.nan
                data.qvel.assign(qvel)
            world.step(1)
            reasons = [world.blow_up(h) for h in handles]
            after = world.core_positions()
            world.step(3)  # the batch goes on
            return world.core_positions(), reasons, before, after

    poisoned, reasons, before, after = run(True)
    clean, clean_reasons, _, _ = run(False)
    assert clean_reasons == [None, None, None]
    assert reasons[0] is None and reasons[2] is None
    assert reasons[1] is not None and reasons[1].startswith("non-finite state")
    assert np.array_equal(after[1], before[1])  # at rest where its period started
    assert np.isfinite(poisoned).all()
    assert np.array_equal(poisoned[[0, 2]], clean[[0, 2]])  # the batch's other worlds untouched


def _candidates(robot: Robot, n: int, rng: np.random.Generator) -> list[NDArray[np.float64]]:
    low, high = param_bounds(robot).T
    inborn = get_params(robot)
    # around the inborn controller (a learner's search), so that most candidates walk
    return [np.clip(inborn + rng.normal(0.0, 0.15, inborn.shape) * (high - low), low, high)
            for _ in range(n)]


@pytest.mark.parametrize("_", [pytest.param(None, marks=stepping)])
def test_fitness_ranks_of_200_candidates_of_3_bodies_agree_with_cpu_mujoco(_: None) -> None:
    """The Training Center's route (``evaluate_params``: one batch per body) on both engines."""
    _warp()
    from scipy.stats import spearmanr

    rng = np.random.default_rng(30)
    fitness: dict[str, list[float]] = {"mujoco": [], WARP: []}
    for name, n in (("spider", 67), ("gecko", 67), ("snake", 66)):
        robot = EXAMPLES[name]()
        candidates = _candidates(robot, n, rng)
        for engine in fitness:
            evaluation = CandidateEvaluation(insertion=0.25, seconds=1.0, engine=engine)
            values, _ = evaluate_params(robot, candidates, 0, evaluation)
            fitness[engine] += values.tolist()
    rho = spearmanr(fitness["mujoco"], fitness[WARP]).statistic
    print(f"Spearman rho over 200 candidates of 3 bodies: {rho:.4f}")
    assert rho >= 0.95


@pytest.mark.parametrize("_", [pytest.param(None, marks=stepping)])
def test_each_example_walker_is_within_5_percent_of_cpu_mujoco(_: None) -> None:
    _warp()
    robots = [build() for build in EXAMPLES.values()]
    setting = {"insertion": 0.25, "seconds": 1.0}
    cpu = [r.fitness for r in evaluate_many(robots, engine="mujoco", **setting)]  # type: ignore[arg-type]
    warp = [r.fitness for r in evaluate_many(robots, engine=WARP, **setting)]  # type: ignore[arg-type]
    for name, a, b in zip(EXAMPLES, cpu, warp, strict=True):
        print(f"{name}: CPU MuJoCo {a:.5f}, Warp {b:.5f} ({(b - a) / a:+.2%})")
    for a, b in zip(cpu, warp, strict=True):
        assert a > 0.0 and abs(b - a) <= 0.05 * abs(a)


@pytest.mark.parametrize("_", [pytest.param(None, marks=stepping)])
def test_a_batch_out_of_room_for_contacts_gets_more_and_steps_again(
        _: None, monkeypatch: pytest.MonkeyPatch) -> None:
    _warp()
    from revolve_env.world import warp_scenes

    robots = [EXAMPLES["spider"]() for _ in range(2)] + [EXAMPLES["sensor_crawler"]()]
    ample = _run(WARP, robots, 8)
    rooms: list[tuple[int, int]] = []
    put = warp_scenes.WarpScenes._put  # noqa: SLF001

    def spy(self: warp_scenes.WarpScenes, group: Any, states: Any) -> None:
        rooms.append(group.room)
        put(self, group, states)

    monkeypatch.setattr(warp_scenes, "_FIRST_ROOM", (1, 4))  # a contact, 4 constraint rows
    monkeypatch.setattr(warp_scenes.WarpScenes, "_put", spy)
    tight = _run(WARP, robots, 8)
    assert rooms[:2] == [(1, 4), (1, 4)] and len(rooms) > 2  # both batches grew
    assert max(ncon for ncon, _ in rooms) > 1
    for a, b in zip(tight, ample, strict=True):  # the periods stepped again: no contact lost
        assert np.abs(a - b).max() < 1e-6


@pytest.mark.parametrize("_", [pytest.param(None, marks=stepping)])
def test_the_native_vector_env_runs_on_warp_as_on_cpu_mujoco(_: None) -> None:
    _warp()
    from revolve_env.envs.vector import LocomotionVectorEnv

    observations = {}
    for engine in ("mujoco", WARP):
        envs = LocomotionVectorEnv(3, robot=EXAMPLES["spider"](), engine=engine,
                                   proprioception=True)
        obs, _ = envs.reset(seed=0)
        actions = np.random.default_rng(0).uniform(-1, 1, (10, *envs.action_space.shape))
        for action in actions:
            obs, reward, terminated, truncated, _ = envs.step(action.astype(np.float32))
        assert not (terminated.any() or truncated.any())
        observations[engine] = obs
        envs.close()
    assert np.abs(observations[WARP] - observations["mujoco"]).max() < 1e-2
