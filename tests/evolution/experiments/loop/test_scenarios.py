"""Each scenario's rules, on fast stand-ins for the physics (tests/evolution/experiment_fakes.py).

The engine's rules do not depend on the physics, so these tests give robots deterministic
genome-derived speeds instead of simulating them; test_evaluators.py runs the real physics.
"""

from __future__ import annotations

from collections import Counter
from itertools import pairwise
from pathlib import Path

import pytest
from experiment_fakes import (
    dump_results,
    fake_evaluate,
    fake_evaluate_with_losses,
    fake_evaluate_with_nan,
    fake_world,
    fake_world_with_blow_ups,
    fake_world_with_blow_ups_at_huge_fitness,
    picky_world,
    small,
)

from evolution import experiments
from evolution.evaluation import LocalEvaluator
from evolution.experiments import ConfigError, ExperimentConfig, preset
from evolution.experiments.store.database import Store
from evolution.lifecycle import Stage


def small_preset(name: str, **kw: object) -> ExperimentConfig:
    """A shipped config with small robots and, unless told otherwise, one run."""
    kw.setdefault("runs", 1)
    return small(preset(name, **kw))


SERIAL = LocalEvaluator(workers=1, function=fake_evaluate)


def _run(config: ExperimentConfig, tmp_path: Path, **kwargs: object) -> Store:
    events: list[object] = []
    experiments.run(config, tmp_path / "out", events.append,
                   evaluator=kwargs.pop("evaluator", SERIAL), **kwargs)
    store = Store.open(tmp_path / "out" / "results.sqlite")
    store.events = events  # type: ignore[attr-defined]
    return store


def _check_lifecycles(store: Store, run_id: int = 0) -> None:
    """Every robot: conception -> delivery -> (infancy -> maturity) -> death, times ascending."""
    by_robot: dict[int, list] = {}
    for t in store.transitions(run_id):
        by_robot.setdefault(t.robot_id, []).append(t)
    robots = store.robots(run_id)
    assert sorted(by_robot) == [r.robot_id for r in robots]
    for r in robots:
        stages = [t.target for t in by_robot[r.robot_id]]
        assert stages[:2] == [Stage.CONCEPTION, Stage.DELIVERY]
        times = [t.time for t in by_robot[r.robot_id]]
        assert times == sorted(times)
        assert times[1] == r.birth_time
        if r.death_time is not None:
            assert stages[-1] is Stage.DEATH and times[-1] == r.death_time


@pytest.mark.parametrize("offspring, births", [(15, 60), (1, 40), (15, 52)])
def test_offline_keeps_the_population_and_counts_births_exactly(
        tmp_path: Path, offspring: int, births: int) -> None:
    config = small_preset("scenario1", offspring_size=offspring, births=births,
                          diversity_interval=5)
    store = _run(config, tmp_path)
    robots = store.robots(0)
    assert [r.robot_id for r in robots] == list(range(births))
    assert store.runs()[0].births == births and store.runs()[0].status == "finished"
    snapshots = store.population_snapshots(0)
    assert all(len(members) == 15 for _, _, members in snapshots)
    assert [b for b, _, _ in snapshots] == list(range(15, births, offspring)) + [births]
    # Survivors are the fittest of parents + children: nobody dropped beats the weakest kept.
    fitness = {r.robot_id: r.fitness for r in robots}
    for (b0, _, before), (b1, _, after) in pairwise(snapshots):
        pool = {rid for rid, _ in before} | set(range(b0, b1))
        kept = {rid for rid, _ in after}
        assert kept <= pool and len(pool) == 15 + (b1 - b0)
        weakest = min(fitness[rid] for rid in kept)
        assert all(fitness[rid] <= weakest for rid in pool - kept)
    # Parents are members of the population (mature) when their child was conceived.
    by_id = {r.robot_id: r for r in robots}
    for r in robots[15:]:
        assert r.origin == "reproduction" and r.parent_a != r.parent_b
        for p in (r.parent_a, r.parent_b):
            parent = by_id[p]
            assert parent.birth_time + config.fertile_age <= r.conceived_time
            assert parent.death_time is None or parent.death_time >= r.conceived_time
    assert store.diversity_over_births(0)
    _check_lifecycles(store)
    # One fitness sample per evaluated robot, at the end of its evaluation.
    assert len(store.fitness_samples(0)) == births


def test_offline_time_limit_stops_early(tmp_path: Path) -> None:
    config = small_preset("scenario2", births=1000, max_sim_time=20 * 15.0)
    store = _run(config, tmp_path)
    assert store.runs()[0].births == 20
    assert store.runs()[0].sim_time == pytest.approx(20 * 15.0)


def test_baseline_a_makes_only_random_robots(tmp_path: Path) -> None:
    store = _run(small_preset("baseline_a", births=45), tmp_path)
    robots = store.robots(0)
    assert {r.origin for r in robots} == {"random"}
    assert all(r.parent_a is None for r in robots)
    assert all(len(m) == 15 for _, _, m in store.population_snapshots(0))


def test_baseline_b_survivors_are_random_not_the_fittest(tmp_path: Path) -> None:
    store = _run(small_preset("baseline_b", births=90), tmp_path)
    evolved = _run(small_preset("scenario1", births=90), tmp_path / "b")
    killed_better = 0
    for b, _, members in store.population_snapshots(0)[1:]:
        weakest = min(f for _, f in members)
        killed_better += sum(1 for r in store.robots(0)
                             if r.death_time is not None and r.death_cause == "survivor selection"
                             and r.fitness > weakest and r.robot_id < b)
    assert killed_better > 0  # random selection kills robots fitter than some survivors
    assert all(len(m) == 15 for _, _, m in store.population_snapshots(0))
    assert evolved.fitness_over_births(0).mean[-1] > store.fitness_over_births(0).mean[-1]


def test_evaluation_losses_are_recorded_and_the_population_stays_full(tmp_path: Path) -> None:
    evaluator = LocalEvaluator(workers=1, function=fake_evaluate_with_losses)
    store = _run(small_preset("scenario1", births=75), tmp_path, evaluator=evaluator)
    lost = store.failures(0, kind="evaluation")
    assert lost and all(f.detail.startswith("blow-up") for f in lost)
    for f in lost:
        record = store.robot(0, f.robot_id)
        assert record.fitness is None and record.death_cause.startswith("blow-up")
        assert Stage.MATURITY not in [t.target for t in store.transitions(0, f.robot_id)]
    assert all(len(m) == 15 for _, _, m in store.population_snapshots(0))
    assert store.runs()[0].births == 75
    _check_lifecycles(store)


def test_a_nan_fitness_is_a_lost_evaluation_not_a_crash(tmp_path: Path) -> None:
    evaluator = LocalEvaluator(workers=1, function=fake_evaluate_with_nan)
    store = _run(small_preset("scenario1", births=60), tmp_path, evaluator=evaluator)
    lost = store.failures(0, kind="evaluation")
    assert lost and all("no finite fitness (nan)" in f.detail for f in lost)
    for f in lost:
        assert store.robot(0, f.robot_id).fitness is None
    assert all(len(m) == 15 for _, _, m in store.population_snapshots(0))
    assert store.runs()[0].births == 60 and store.runs()[0].status == "finished"


def test_a_robot_the_engine_cannot_build_is_born_dead_and_the_run_goes_on(
        tmp_path: Path) -> None:
    store = _run(small_preset("scenario3", births=40), tmp_path, world_factory=picky_world)
    assert [r.births for r in store.runs()] == [40]
    refused = store.failures(0, "birth")
    assert refused and all("fake refusal" in f.detail for f in refused)
    dead = {r.robot_id: r for r in store.robots(0)}
    assert all(dead[f.robot_id].death_cause.startswith("not built") for f in refused)


def test_online_population_bounds_births_and_mature_parents(tmp_path: Path) -> None:
    config = small_preset("scenario3", births=120, diversity_interval=10)
    store = _run(config, tmp_path, world_factory=fake_world)
    robots = store.robots(0)
    assert [r.robot_id for r in robots] == list(range(120))
    sizes = [len(m) for _, _, m in store.population_snapshots(0)]
    assert min(sizes) >= 8 and max(sizes) <= 30
    assert max(sizes) == 30 or min(sizes) < 15  # the rules did act
    by_id = {r.robot_id: r for r in robots}
    for r in robots[15:]:
        assert r.conceived_time == pytest.approx(15.0 * (r.robot_id - 14))  # one every 15 s
        for p in (r.parent_a, r.parent_b):
            parent = by_id[p]
            assert r.conceived_time - parent.birth_time >= config.fertile_age
            assert parent.death_time is None or parent.death_time >= r.conceived_time
    deaths = Counter(r.death_cause for r in robots if r.death_cause)
    assert deaths["survivor selection"] > 0
    # Nobody dies before maturity through selection.
    for r in robots:
        if r.death_cause == "survivor selection":
            assert r.death_time - r.birth_time >= config.fertile_age
    _check_lifecycles(store)
    samples = store.fitness_samples(0)
    assert samples and all(s.time % 15.0 == 0 for s in samples)


def test_online_blow_ups_are_recorded_and_minimum_kept(tmp_path: Path) -> None:
    config = small_preset("scenario3", births=80)
    store = _run(config, tmp_path, world_factory=fake_world_with_blow_ups)
    blown = store.failures(0, kind="blow-up")
    assert blown
    sizes = [len(m) for _, _, m in store.population_snapshots(0)]
    assert min(sizes) >= 8 and max(sizes) <= 30
    assert store.runs()[0].births == 80


def test_online_blow_ups_are_stored_as_lost_without_a_fitness(tmp_path: Path) -> None:
    """A robot lost to a blow-up in the shared world is stored with no fitness (the world's
    0 m after a blow-up is no measurement), its cause and a failure record."""
    store = _run(small_preset("scenario3", births=80), tmp_path,
                 world_factory=fake_world_with_blow_ups)
    blown = store.failures(0, kind="blow-up")
    assert blown
    for f in blown:
        record = store.robot(0, f.robot_id)
        assert record.fitness is None
        assert record.death_cause == f"blow-up: {f.detail}" and record.death_time == f.time
        later = [m for _, t, m in store.population_snapshots(0) if t >= f.time]
        assert all(f.robot_id not in dict(members) for members in later)


def test_what_the_world_reports_at_a_blow_up_never_reaches_evolution(tmp_path: Path) -> None:
    """Evolution is the same whether the world reports 0 m or 1e9 m for a robot that blows
    up: a lost robot leaves the population before selection, and is stored without fitness."""
    dumps = []
    for world in (fake_world_with_blow_ups, fake_world_with_blow_ups_at_huge_fitness):
        folder = tmp_path / world.__name__
        _run(small_preset("scenario3", births=80), folder, world_factory=world).close()
        dumps.append(dump_results(folder / "out" / "results.sqlite"))
    assert dumps[0] == dumps[1]
    assert any(cause and cause.startswith("blow-up") for *_, cause, _ in dumps[0]["robots"])


def test_progress_reports_births_fitness_and_speed(tmp_path: Path) -> None:
    store = _run(small_preset("scenario1", births=45), tmp_path)
    events = store.events  # type: ignore[attr-defined]
    assert [e.births for e in events] == [15, 30, 45, 45]
    assert events[-1].finished and not events[0].finished
    assert all(e.population_size == 15 and e.best >= e.mean for e in events)
    assert events[-1].sim_time == pytest.approx(45 * 15.0)


def test_presets_are_the_papers_experiments() -> None:
    s1, s2, s3 = (preset("scenario1", runs=1), preset("scenario2", runs=1),
                  preset("scenario3", runs=1))
    assert ((s1.mode, s1.population_size, s1.offspring_size, s1.births)
            == ("offline", 15, 15, 3000))
    assert (s2.offspring_size, s3.mode, s3.min_alive, s3.max_alive) == (1, "online", 8, 30)
    assert ((s1.tournament_size, s1.insertion, s1.evaluation_time, s1.fertile_age)
            == (4, 3.0, 12.0, 15.0))
    assert preset("baseline_a", runs=1).new_robots == "random"
    assert preset("baseline_b", runs=1).survivor_selection == "random"


def test_config_round_trips_through_dict_and_toml(tmp_path: Path) -> None:
    config = preset("scenario3", births=500, max_sim_time=600.0, seed=3, runs=1)
    assert ExperimentConfig.from_dict(config.to_dict()) == config
    path = tmp_path / "exp.toml"
    path.write_text('preset = "scenario2"\nbirths = 100\nseed = 7\n[evolution]\nmax_parts = 20\n')
    loaded = ExperimentConfig.from_toml(path)
    assert ((loaded.name, loaded.offspring_size, loaded.births, loaded.seed)
            == ("scenario2", 1, 100, 7))
    assert loaded.evolution.max_parts == 20


@pytest.mark.parametrize("data, message", [
    ({"birth": 10}, "unknown experiment config key\\(s\\): birth"),
    ({"preset": "scenario9"}, "unknown scenario 'scenario9'"),
    ({"mode": "hybrid"}, "mode must be one of 'offline', 'online'"),
    ({"births": 0}, "births must be >= 1"),
    ({"births": 10}, "births \\(10\\) must be >= population_size \\(15\\)"),
    ({"tournament_size": 2.5}, "tournament_size must be an integer"),
    ({"death_threshold": -0.1}, "death_threshold must be >= 0"),
    ({"death_threshold": 1.5}, "death_threshold must be <= 1"),
    ({"cull_fraction": 1.5}, "cull_fraction must be <= 1"),
    ({"mode": "online", "population_size": 40}, "must lie within \\[min_alive, max_alive\\]"),
    ({"min_alive": 31}, "min_alive \\(31\\) must be <= max_alive \\(30\\)"),
    ({"max_sim_time": -5.0}, "max_sim_time must be a positive"),
    ({"evolution": {"max_part": 3}}, "unknown evolution config key\\(s\\): max_part"),
    ({"evolution": {"p_swap_subtree": 2.0}}, "evolution: .*probability"),
])
def test_config_errors_name_the_problem(data: dict, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        ExperimentConfig.from_dict(data)


def test_bad_toml_names_the_file(tmp_path: Path) -> None:
    path = tmp_path / "bad.toml"
    path.write_text("births = = 3\n")
    with pytest.raises(ConfigError, match="bad.toml is not valid TOML"):
        ExperimentConfig.from_toml(path)
    path.write_text("births = 3\n")
    with pytest.raises(ConfigError, match="bad.toml: births \\(3\\)"):
        ExperimentConfig.from_toml(path)


def test_the_papers_scenarios_are_shipped_configs_in_the_papers_order() -> None:
    """The one table the study, its CLI and the reports read."""
    from evolution.experiments.loop.registry import PAPER_SCENARIOS, shipped_configs

    assert PAPER_SCENARIOS == ("scenario1", "scenario2", "scenario3", "baseline_a", "baseline_b")
    assert set(PAPER_SCENARIOS) <= set(shipped_configs())
    assert experiments.PAPER_SCENARIOS is PAPER_SCENARIOS
