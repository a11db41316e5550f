"""``evolution.reevaluate`` and ``revolve reevaluate``: stored robots evaluated again.

Tiny real runs (pybullet, 1 s windows): rows stored with the documented seeds and conditions,
idempotent, a larger K adds only the missing repeats, deterministic, Ctrl-C loses nothing
committed, the best of each generation, later windows and a shared world; a v3 database upgraded
in place; the command line end to end with one-line errors.
"""

from __future__ import annotations

import json
import math
import shutil
import sqlite3
from dataclasses import fields
from pathlib import Path

import pytest
from experiment_fakes import Kill, dump_results, fake_world, kill_after, small

from evolution.cli import main
from evolution.evaluation import evaluation_seed
from evolution.experiments import ExperimentConfig, preset, resume, run, run_seed
from evolution.experiments.app.reevaluate import (
    choose,
    reevaluate,
    reevaluation_conditions,
    reevaluation_seed,
    shared_world_seed,
)
from evolution.experiments.store.database import (
    DB_NAME,
    Batch,
    Checkpoint,
    LearningRecord,
    RobotRecord,
    Store,
    StoreError,
)
from revolve_env.body.examples import example
from revolve_env.body.serialize import to_json
from revolve_env.conditions import EvaluationConditions

CONFIG = preset("quick", births=16, evaluation_time=1.0, insertion=0.5, fertile_age=1.5, runs=2,
                workers=1, population_size=6, offspring_size=5, diversity_interval=5)
RANDOM = json.dumps(EvaluationConditions(heading="random").to_dict(), sort_keys=True)


@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two finished runs of a tiny offline experiment (read-only: tests copy it)."""
    root = tmp_path_factory.mktemp("study")
    run(CONFIG, root / "quick")
    return root


@pytest.fixture
def results(study: Path, tmp_path: Path) -> Path:
    """A fresh copy of the study."""
    shutil.copytree(study, tmp_path / "results")
    return tmp_path / "results"


def _rows(root: Path) -> list[tuple[object, ...]]:
    return dump_results(root / "quick" / DB_NAME, ("reevaluations",))["reevaluations"]


def test_rows_are_stored_with_fresh_seeds_and_a_random_heading(results: Path) -> None:
    summary = reevaluate(results, k=2, workers=1)
    with Store.open(results / "quick" / DB_NAME) as store:
        finals = {r.run_id: dict(store.final_population(r.run_id)) for r in store.runs()}
        rows = store.reevaluations()
    robots = sum(len(f) for f in finals.values())
    assert summary.planned == summary.evaluated == summary.added == len(rows) == 2 * robots
    for row in rows:
        assert row.kind == "final" and row.controller == "inborn" and not row.shared_world
        assert row.stored_fitness == finals[row.run_id][row.robot_id]
        assert (row.insertion, row.seconds, row.conditions) == (0.5, 1.0, RANDOM)
        assert row.seed == reevaluation_seed(CONFIG.seed, row.run_id, row.robot_id, row.repeat)
        assert row.seed != evaluation_seed(run_seed(CONFIG.seed, row.run_id), row.robot_id)
        assert row.fitness is not None and math.isfinite(row.fitness) and row.failure is None
    # Fresh headings: the repeats of one robot differ.
    by_robot: dict[tuple[int, int], list[float]] = {}
    for row in rows:
        assert row.fitness is not None
        by_robot.setdefault((row.run_id, row.robot_id), []).append(row.fitness)
    assert any(a != b for a, b in by_robot.values())


def test_idempotent_and_a_larger_k_adds_only_the_missing_repeats(results: Path) -> None:
    reevaluate(results, k=2, workers=1)
    first = _rows(results)
    again = reevaluate(results, k=2, workers=1)
    assert (again.evaluated, again.added) == (0, 0) and _rows(results) == first
    more = reevaluate(results, k=3, workers=1)
    rows = _rows(results)
    assert more.added == more.evaluated == len(first) // 2 == len(rows) - len(first)
    assert set(first) <= set(rows)
    assert {r[3] for r in set(rows) - set(first)} == {2}  # column 3: repeat


def test_two_copies_give_identical_rows(results: Path, study: Path, tmp_path: Path) -> None:
    other = tmp_path / "other"
    shutil.copytree(study, other)
    reevaluate(results, k=2, workers=1)
    reevaluate(other, k=2, workers=2)  # the number of workers changes nothing
    assert _rows(results) == _rows(other)


def test_ctrl_c_loses_nothing_committed(results: Path, study: Path, tmp_path: Path) -> None:
    def stop(done: int, total: int) -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        reevaluate(results, k=2, workers=1, progress=stop)
    kept = _rows(results)
    assert 0 < len(kept) < 2 * 12
    reevaluate(results, k=2, workers=1)
    whole = tmp_path / "whole"
    shutil.copytree(study, whole)
    reevaluate(whole, k=2, workers=1)
    assert _rows(results) == _rows(whole)


def test_best_of_each_generation_later_windows_and_a_shared_world(results: Path) -> None:
    reevaluate(results, k=1, which="best", window_offsets=(0.0, 1.5), workers=1)
    with Store.open(results / "quick" / DB_NAME) as store:
        best = {}
        for r in store.runs():
            for _, _, members in store.population_snapshots(r.run_id):
                fitness, robot_id = max((f, rid) for rid, f in members)
                best[(r.run_id, robot_id)] = max(fitness, best.get((r.run_id, robot_id), 0.0))
        rows = store.reevaluations("best")
    assert {(r.run_id, r.robot_id) for r in rows} == set(best)
    assert sorted({r.insertion for r in rows}) == [0.5, 2.0]
    assert all(r.stored_fitness == best[(r.run_id, r.robot_id)] for r in rows)

    reevaluate(results, k=2, shared_world=True, workers=1)
    with Store.open(results / "quick" / DB_NAME) as store:
        shared = [r for r in store.reevaluations("final") if r.shared_world]
        finals = {r.run_id: len(store.final_population(r.run_id)) for r in store.runs()}
    assert len(shared) == 2 * sum(finals.values())
    assert reevaluate(results, k=2, shared_world=True, workers=1).evaluated == 0
    # Conditions reach the shared world: the same worlds with actuator noise move otherwise.
    noisy = EvaluationConditions(heading="random", actuator_noise=0.3)
    reevaluate(results, k=1, shared_world=True, conditions=noisy, workers=1)
    with Store.open(results / "quick" / DB_NAME) as store:
        rows = [r for r in store.reevaluations("final") if r.shared_world and r.repeat == 0]
    plain = {(r.run_id, r.robot_id): r.fitness for r in rows if r.conditions == RANDOM}
    loud = {(r.run_id, r.robot_id): r.fitness for r in rows if r.conditions != RANDOM}
    assert plain.keys() == loud.keys() and plain != loud
    for row in shared:  # one world per run and repeat, all its robots in it
        assert row.seed == shared_world_seed(CONFIG.seed, row.run_id, row.repeat)
        assert row.fitness is not None or row.failure is not None


def test_online_infants_are_left_out(tmp_path: Path) -> None:
    """An online robot younger than fertile_age at the last snapshot has no full window: it is
    not chosen. The online runs' robots (here made by the fast stand-in world) reevaluate like
    offline ones, alone or together."""
    config = small(preset("scenario3", births=20, runs=1, insertion=0.5, evaluation_time=1.0,
                          fertile_age=1.5, conception_interval=1.0, diversity_interval=10))
    run(config, tmp_path / "s3", world_factory=fake_world)
    with Store.open(tmp_path / "s3" / DB_NAME) as store:
        _, sim_time, members = store.population_snapshots(0)[-1]
        born = {r.robot_id: r.birth_time for r in store.robots(0)}
        adults = [rid for rid, f in members if f is not None and sim_time - born[rid] >= 1.5]
        everyone = [rid for rid, f in members if f is not None]
        assert [c.robot_id for c in choose(store, 0, "final", 1.5)] == adults != everyone
    assert reevaluate(tmp_path, k=1, shared_world=True, workers=1).added == len(adults)


def test_run_conditions_with_a_random_heading() -> None:
    noisy = {"heading": 0.0, "position_jitter": 0.1, "sensor_noise": 0.05, "actuator_noise": 0.0}
    assert reevaluation_conditions({"evaluation": noisy}) == EvaluationConditions(
        "random", 0.1, 0.05, 0.0)
    assert reevaluation_conditions({}) == EvaluationConditions(heading="random")
    given = EvaluationConditions(heading=1.0)
    assert reevaluation_conditions({"evaluation": noisy}, given) is given
    with pytest.raises(StoreError, match="stored evaluation conditions are not valid"):
        reevaluation_conditions({"evaluation": {"sensor_noise": -1.0}})


def test_a_robot_that_learned_is_reevaluated_with_its_learned_genome(tmp_path: Path) -> None:
    spider, gecko = to_json(example("spider")), to_json(example("gecko"))
    with Store.create(tmp_path / DB_NAME, {"name": "hand"}, 3) as store:
        store.add_run(0, 11)
        robots = [RobotRecord(0, i, spider, None, None, "random", 0, 0.0, 0.0) for i in range(3)]
        store.commit(0, Batch(robots=robots, population=[(0, 2.0), (1, 1.0), (2, None)],
                              learning=[LearningRecord(1, 0.0, "darwinian", gecko, 0.5, 1.0,
                                                       4, 20.0)]),
                     Checkpoint(3, 9.0, 0, {}, {}))
        chosen = choose(store, 0, "final")
    assert [(c.robot_id, c.controller, c.stored_fitness) for c in chosen] == [
        (0, "inborn", 2.0), (1, "learned", 1.0)]  # robot 2 has no fitness to compare
    assert to_json(chosen[1].robot) == gecko and to_json(chosen[0].robot) == spider
    with pytest.raises(ValueError, match="which must be one of"):
        choose(store, 0, "all")


def test_bad_arguments(results: Path, tmp_path: Path) -> None:
    import evolution

    assert evolution.reevaluate is reevaluate  # the lazy facade
    with pytest.raises(ValueError, match="k must be an integer from 1 to 1000"):
        reevaluate(results, k=0)
    with pytest.raises(ValueError, match="k must be an integer from 1 to 1000"):
        reevaluate(results, k=10**9)  # hours of evaluations that no interval needs
    with pytest.raises(ValueError, match="window offsets"):
        reevaluate(results, window_offsets=(-1.0,))
    with pytest.raises(ValueError, match="window offsets"):
        reevaluate(results, window_offsets=(1e9,))
    with pytest.raises(StoreError, match="no such results directory"):
        reevaluate(tmp_path / "missing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(StoreError, match="no results database"):
        reevaluate(tmp_path / "empty")


# -- a database written before reevaluations (schema 3) ---------------------------------------


def _as_version_3(db: Path) -> None:
    con = sqlite3.connect(db)
    con.execute("DROP TABLE reevaluations")
    con.execute("ALTER TABLE fitness DROP COLUMN shaking")  # added by schema 7
    config = json.loads(con.execute("SELECT value FROM meta WHERE key = 'config'").fetchone()[0])
    config.pop("evaluation", None)
    config.pop("task", None)  # schema 3 had none (its fitness sampled every control period)
    config["engine"] = config.pop("mode")  # what schema 3 called it
    con.execute("UPDATE meta SET value = ? WHERE key = 'config'", (json.dumps(config),))
    con.execute("UPDATE meta SET value = '3' WHERE key = 'schema_version'")
    con.commit()
    con.close()


CONFIG_HAS_CONDITIONS = "evaluation" in {f.name for f in fields(ExperimentConfig)}


def test_version_3_run_is_upgraded_and_keeps_every_row(study: Path, tmp_path: Path) -> None:
    db = tmp_path / "old" / DB_NAME
    shutil.copytree(study / "quick", db.parent)
    _as_version_3(db)
    before = dump_results(db)
    with Store.open(db) as store:
        assert store.meta()["schema_version"] == "8"
        assert store.config["evaluation"]["heading"] == 0.0  # an offline run: heading 0
        assert store.config["mode"] == "offline" and "engine" not in store.config
        assert store.config["task"] == {"name": "locomotion", "pose_rate": "every-period"}
    after = dump_results(db)
    assert all(row[-1] is None for row in after["fitness"])  # schema 7's shaking, not measured
    after["fitness"] = [row[:-1] for row in after["fitness"]]
    assert after == before


@pytest.mark.skipif(not CONFIG_HAS_CONDITIONS,
                    reason="needs ExperimentConfig.evaluation (the [evaluation] table)")
def test_version_3_run_resumes_and_reevaluates_after_the_upgrade(tmp_path: Path) -> None:
    """An interrupted v3 run is upgraded, resumes to the numbers of an uninterrupted run under
    the conditions it lived (heading 0), and can then be reevaluated."""
    # What a v3 database holds: a run under heading 0 (offline before conditions), its config
    # without the evaluation table.
    # Its fitness sampled the core every control period (before pose rates, schema 7).
    lived = ExperimentConfig.from_dict({**CONFIG.to_dict(), "evaluation": {"heading": 0.0},
                                        "task": {"name": "locomotion",
                                                 "pose_rate": "every-period"}})
    killed = tmp_path / "killed" / "quick"
    with pytest.raises(Kill):
        run(lived, killed, kill_after(11))
    _as_version_3(killed / DB_NAME)
    resume(killed)
    whole = tmp_path / "whole" / "quick"
    run(lived, whole)
    resumed, uninterrupted = dump_results(killed / DB_NAME), dump_results(whole / DB_NAME)
    # schema 7's shaking measure: not in a v3 database's rows, 1 for every resumed evaluation
    # (poses every control period); the rest to the bit
    shaking = [row[-1] for row in resumed["fitness"]]
    assert None in shaking and set(shaking) == {None, 1.0}
    for dump in (resumed, uninterrupted):
        dump["fitness"] = [row[:-1] for row in dump["fitness"]]
    assert resumed == uninterrupted
    assert reevaluate(killed, k=1, workers=1).added > 0


# -- the command line ---------------------------------------------------------------------------


def test_cli_end_to_end(results: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["reevaluate", str(results), "--k", "2", "--workers", "1"]) == 0
    out = capsys.readouterr().out
    assert "| quick | final, window 0.5-1.5 s, alone, heading random | inborn | 2 | 12 | 2 |" in out
    assert out.rstrip().endswith(f"next: revolve report {results}")
    assert main(["reevaluate", str(results), "--k", "2", "--workers", "1"]) == 0
    assert "0 new, 24 stored already" in capsys.readouterr().out


@pytest.mark.parametrize(("argv", "message"), [
    (["missing"], "no such results directory"),
    (["empty"], "no results database"),
])
def test_cli_errors_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                 argv: list[str], message: str) -> None:
    (tmp_path / "empty").mkdir()
    assert main(["reevaluate", str(tmp_path / argv[0])]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0] and err[0].startswith("revolve reevaluate: error")


def test_cli_bad_numbers(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    for argv in (["--k", "0"], ["--window-offset", "-2"], ["--workers", "x"]):
        with pytest.raises(SystemExit) as exit_info:
            main(["reevaluate", str(tmp_path), *argv])
        assert exit_info.value.code == 2
        assert "error: argument" in capsys.readouterr().err


def test_cli_help_shows_the_defaults(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["reevaluate", "--help"])
    assert exit_info.value.code == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "reevaluations per robot (default: 10)" in out
    assert "worker processes, 0: all cores (default: 0)" in out


@pytest.mark.slow
def test_a_robot_driven_by_a_saved_policy_is_reevaluated_with_it(tmp_path: Path) -> None:
    """An SB3 infant lived driven by its saved policy: its reevaluation loads the policy and
    gives what the policy gives (not the inborn network), under the same conditions and seed."""
    pytest.importorskip("stable_baselines3")
    from evolution.evaluation import EvalTask, evaluate_robot
    from evolution.learning import load_policy

    learning = {"learner": "sb3", "algorithm": "PPO", "n_envs": 1, "vec_env": "dummy",
                "insertion": 0.5, "seconds": 1.0, "budget": 3.3,
                "algorithm_kwargs": {"n_steps": 16, "batch_size": 16, "n_epochs": 1}}
    config = preset("scenario1", runs=1, births=6, population_size=4, offspring_size=2,
                    insertion=0.5, evaluation_time=1.0, fertile_age=1.0, workers=1,
                    learning=learning)
    run(config, tmp_path / "rl")
    ideal = EvaluationConditions()
    reevaluate(tmp_path, k=1, conditions=ideal, workers=1)
    with Store.open(tmp_path / "rl" / DB_NAME) as store:
        rows = {r.robot_id: r for r in store.reevaluations()}
        learned = {r.robot_id: r for r in store.learning(0, list(rows)) if r.policy is not None}
        robots = {r.robot_id: r.robot() for r in store.robots(0, list(learned))}
    assert learned, "no robot of the final population learned a policy"
    for robot_id, record in learned.items():
        row = rows[robot_id]
        assert row.controller == "policy" and record.policy is not None
        ref = json.loads(record.policy)
        agent = load_policy(tmp_path / "rl" / ref["file"], robots[robot_id], ref["digest"])
        task = EvalTask(robot_id, robots[robot_id], 0.5, 1.0, row.seed, conditions=ideal)
        assert row.fitness == evaluate_robot(EvalTask(
            robot_id, robots[robot_id], 0.5, 1.0, row.seed, policy=agent,
            conditions=ideal)).fitness != evaluate_robot(task).fitness


def test_unfinished_runs_are_skipped_unless_asked_and_said(
        results: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A run still running (or interrupted) has no final population yet: left out, and said."""
    with sqlite3.connect(results / "quick" / DB_NAME) as con:
        con.execute("UPDATE runs SET status = 'running' WHERE run_id = 1")
    con.close()
    assert main(["reevaluate", str(results), "--k", "1", "--workers", "1"]) == 0
    out = capsys.readouterr().out
    assert f"skipped run 1 of {results / 'quick'}: running at 16 of 16 births" in out
    assert "--include-unfinished" in out
    assert {row[0] for row in _rows(results)} == {0}
    summary = reevaluate(results, k=1, workers=1, include_unfinished=True)
    assert summary.skipped == () and summary.added > 0
    assert {row[0] for row in _rows(results)} == {0, 1}
