"""The online engine's real world (evolution.experiments.loop.online_world over PopulationEnv)."""

from __future__ import annotations

import pickle
from pathlib import Path
from typing import Any

import pytest

import evolution
from evolution.experiments import preset
from evolution.experiments.loop.config import WorldSettings
from evolution.experiments.loop.online_world import PopulationWorld
from evolution.experiments.store.database import Store
from revolve_env.body.examples import gecko, snake
from revolve_env.status import RobotStatus


def _tiny_online(**changes: object) -> evolution.ExperimentConfig:
    values: dict[str, object] = dict(
        births=7, population_size=3, min_alive=2, max_alive=4, conception_interval=2.0,
        insertion=0.5, evaluation_time=2.0, fertile_age=2.5, diversity_interval=0, workers=1,
        runs=1)
    values.update(changes)
    return preset("scenario3", **values)


def test_the_world_holds_only_the_runs_robots() -> None:
    world = PopulationWorld(_tiny_online(), seed=0)
    try:
        assert world._env.agents == []  # no default example robots join the population
        # The engine's robot ids are the env's (one id from the world to the store): a gap
        # (a robot born dead in between) is kept.
        a = world.add(gecko(), 3).robot_id
        birth = world.add(snake(), 5)
        b = birth.robot_id
        assert (a, b) == (3, 5) and world._env.robot_ids == [3, 5]  # in the world at once
        # The position recorded is the one the env used (the shared placement rule).
        assert birth.inside and world._env.status(b).birth_position == birth.position
        statuses = world.advance_to(0.5)
        assert set(statuses) == {a, b}
        assert all(s.robot_id == k and s.death is None for k, s in statuses.items())
        world.remove(a)
        assert set(world.advance_to(1.0)) == {b}
    finally:
        world.close()


def test_a_crowded_birth_disc_never_stops_an_online_run(tmp_path: Path) -> None:
    """Large immobile robots fill a tiny birth disc: later newborns go outside it, the event is
    stored, and the run reaches its births."""
    config = _tiny_online(birth_radius=0.05, births=6, population_size=2, min_alive=2,
                          max_alive=6, death_threshold=0.0)
    summary = evolution.run(config, tmp_path / "crowded")
    assert [r.births for r in summary.runs] == [6]
    with Store.open(tmp_path / "crowded" / "results.sqlite") as store:
        crowded = store.failures(0, "crowded")
        assert crowded and all("nearest free spot" in f.detail for f in crowded)


def test_a_tiny_online_run_with_real_physics_finishes_with_exact_births(tmp_path: Path) -> None:
    config = _tiny_online()
    summary = evolution.run(config, tmp_path / "online")
    assert [r.births for r in summary.runs] == [7]
    with Store.open(tmp_path / "online" / "results.sqlite") as store:
        assert len(store.robots(0)) == 7


def test_advance_to_on_mujoco_gives_the_numbers_of_one_step_at_a_time(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The world's periods up to an event in compiled calls (``advance_periods``) leave it where
    steps one at a time (``advance``) do: statuses, deaths and the snapshot, to the bit."""
    from revolve_env.envs.population import PopulationEnv
    from revolve_env.world import compiled

    if compiled.windows_kernel() is None or not compiled.hypot_exact():
        pytest.skip("the compiled rollout is not built or not exact here")
    config = _tiny_online(world=WorldSettings(engine="mujoco"))

    def events(world: PopulationWorld) -> list[object]:
        out: list[object] = []
        world.add(gecko(), 0)
        world.add(snake(), 1)
        for k, t in enumerate((0.4, 1.3, 2.0, 3.7)):
            if k == 2:
                world.remove(0)
                world.add(gecko(), 2)
            out.append(sorted((r, tuple(s)) for r, s in world.advance_to(t).items()))
        out.append(pickle.dumps(world.snapshot()))
        return out

    made: list[bool] = []
    real = compiled.population_periods

    def spy(*args: Any) -> Any:
        periods = real(*args)
        made.append(periods is not None)
        return periods

    fast = PopulationWorld(config, seed=5)
    try:
        with monkeypatch.context() as m:
            m.setattr(compiled, "population_periods", spy)
            got = events(fast)
    finally:
        fast.close()
    assert sum(made) >= 4  # the compiled periods ran
    def stepwise(env: PopulationEnv, n: int) -> dict[int, RobotStatus]:
        for _ in range(n):
            ended = env.advance({})
            if ended:
                return ended
        return {}

    monkeypatch.setattr(PopulationEnv, "advance_periods", stepwise)
    slow = PopulationWorld(config, seed=5)
    try:
        want = events(slow)
    finally:
        slow.close()
    assert repr(got[:-1]) == repr(want[:-1])
    assert got[-1] == want[-1]
