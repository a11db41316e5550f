"""RL infancy inside evolution runs: SB3 policies saved with the run, driving the robots,
killed and resumed to the same database, budgets checked at config time."""

from __future__ import annotations

import hashlib
import json
import shutil
import sqlite3
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from experiment_fakes import Kill
from experiment_fakes import dump_results as dump
from experiment_fakes import kill_after as killer

from evolution import experiments
from evolution.evaluation import LocalEvaluator, evaluate_task
from evolution.experiments import ConfigError, ExperimentConfig, ProgressEvent, preset
from evolution.experiments.loop.config import WorldSettings
from evolution.experiments.store.database import Store, StoreError

pytest.importorskip("stable_baselines3")

SERIAL = LocalEvaluator(workers=1, function=evaluate_task)
# One PPO rollout of 16 steps (1/60 s each) and the learner's two 1.5 s evaluations: 3.27 s.
LEARNING = {"learner": "sb3", "algorithm": "PPO", "n_envs": 1, "vec_env": "dummy",
            "insertion": 0.5, "seconds": 1.0, "budget": 3.3,
            "algorithm_kwargs": {"n_steps": 16, "batch_size": 16, "n_epochs": 1}}


def offline_config() -> ExperimentConfig:
    return (preset("scenario1", runs=1, births=6, population_size=4, offspring_size=2,
                        insertion=0.5, evaluation_time=1.0, fertile_age=1.0,
                        learning=LEARNING))


def online_config() -> ExperimentConfig:
    # On pybullet, which cannot restore a world snapshot: a resumed run replays from birth 0,
    # the route (policies driving the replayed robots) these tests check.
    return (preset("scenario3", runs=1, births=6, population_size=4, min_alive=2, max_alive=8,
                        insertion=0.5, evaluation_time=1.0, fertile_age=1.0,
                        conception_interval=0.5, checkpoint_interval=1, learning=LEARNING,
                        world=WorldSettings(engine="pybullet")))


def _check_policies(out: Path) -> None:
    with Store.open(out / "results.sqlite") as store:
        records = store.learning(0)
        failures = store.failures(0)
    # Every infant learned, except robots without a hinge (nothing to control: a learner failure).
    assert len(records) >= 3
    assert sorted([r.robot_id for r in records]
                  + [f.robot_id for f in failures if f.kind == "learner"]) == list(range(6))
    assert all("no active hinge" in f.detail for f in failures if f.kind == "learner")
    for r in records:
        assert r.policy is not None and r.learned_genome is None
        assert r.inborn_fitness is not None and r.learned_fitness is not None
        assert r.sim_seconds is not None and r.sim_seconds <= LEARNING["budget"]
        assert (out / json.loads(r.policy)["file"]).is_file()


@pytest.fixture(scope="module")
def offline_ref(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("offline") / "ref"
    experiments.run(offline_config(), out, evaluator=SERIAL)
    return out


@pytest.fixture(scope="module")
def online_ref(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("online") / "ref"
    experiments.run(online_config(), out, evaluator=SERIAL)
    return out


@pytest.fixture(scope="module")
def online_killed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An online run killed after its checkpoint at 5 births (not to be resumed in place)."""
    out = tmp_path_factory.mktemp("online") / "killed"
    with pytest.raises(Kill):
        experiments.run(online_config(), out, killer(5), evaluator=SERIAL)
    return out


def test_offline_ppo_infancy_saves_policies_and_resumes(offline_ref: Path, tmp_path: Path) -> None:
    _check_policies(offline_ref)
    out = tmp_path / "killed"
    with pytest.raises(Kill):
        experiments.run(offline_config(), out, killer(4), evaluator=SERIAL)
    experiments.resume(out, evaluator=SERIAL)
    assert dump(out / "results.sqlite") == dump(offline_ref / "results.sqlite")


def test_offline_evaluation_is_driven_by_the_saved_policy(offline_ref: Path) -> None:
    """The stored fitness of a learned robot is its saved policy's evaluation (same seed and
    window), not its network's."""
    from evolution.evaluation import EvalTask, evaluate_robot, evaluation_seed
    from evolution.experiments.loop.run import run_seed
    from evolution.learning import load_policy

    config = offline_config()
    with Store.open(offline_ref / "results.sqlite") as store:
        record = store.learning(0)[0]
        robot = store.robots(0, [record.robot_id])[0]
    assert record.policy is not None
    ref = json.loads(record.policy)
    agent = load_policy(offline_ref / ref["file"], robot.robot(), ref["digest"])
    task = EvalTask(robot.robot_id, robot.robot(), config.insertion, config.evaluation_time,
                    evaluation_seed(run_seed(config.seed, 0), robot.robot_id),
                    conditions=config.evaluation)
    driven = evaluate_robot(replace(task, policy=agent))
    assert robot.fitness is not None and driven.fitness is not None
    with sqlite3.connect(offline_ref / "results.sqlite") as con:
        stored = con.execute("SELECT fitness FROM fitness WHERE robot_id = ?",
                             (robot.robot_id,)).fetchone()[0]
    assert stored == driven.fitness
    assert stored != evaluate_robot(task).fitness


def test_online_ppo_infancy_saves_policies_and_resumes(
        online_ref: Path, online_killed: Path, tmp_path: Path) -> None:
    _check_policies(online_ref)
    out = tmp_path / "killed"
    shutil.copytree(online_killed, out)
    events: list[ProgressEvent] = []
    experiments.resume(out, events.append, evaluator=SERIAL)
    assert any(e.replaying for e in events) and events[-1].finished
    assert dump(out / "results.sqlite") == dump(online_ref / "results.sqlite")


def _policies(out: Path) -> list[Path]:
    with Store.open(out / "results.sqlite") as store:
        return [out / json.loads(r.policy)["file"] for r in store.learning(0)
                if r.policy is not None]


@pytest.mark.parametrize("damage", ["truncated", "garbage", "another body", "missing"])
def test_a_bad_policy_file_is_one_line_naming_it_and_changes_nothing(
        online_killed: Path, tmp_path: Path, damage: str) -> None:
    out = tmp_path / "killed"
    shutil.copytree(online_killed, out)
    first, second = _policies(out)[:2]
    if damage == "truncated":
        second.write_bytes(second.read_bytes()[:200])
    elif damage == "garbage":
        second.write_bytes(b"not a policy at all")
    elif damage == "another body":
        # The record's SHA-256 follows the file, so that the body is what differs.
        second.write_bytes(first.read_bytes())
        with sqlite3.connect(out / "results.sqlite") as con:
            con.execute("UPDATE learning SET policy = json_set(policy, '$.sha256', ?) WHERE "
                        "json_extract(policy, '$.file') = ?",
                        (hashlib.sha256(first.read_bytes()).hexdigest(),
                         str(second.relative_to(out))))
        con.close()
    else:
        second.unlink()
    before = dump(out / "results.sqlite")
    with pytest.raises(StoreError) as error:
        experiments.resume(out, evaluator=SERIAL)
    message = str(error.value)
    assert str(second) in message and "\n" not in message
    if damage == "another body":
        assert "another body" in message
    assert dump(out / "results.sqlite") == before


@pytest.mark.parametrize("scenario", ["scenario1", "scenario3"])
def test_policies_that_observe_the_hinges_drive_their_robots_offline_and_online(
        tmp_path: Path, scenario: str) -> None:
    """With ``learning.proprioception = true`` the policies observe hinge angles and speeds:
    the offline evaluation and the online world give them those observations, and a resume
    reloads them as they were."""
    from evolution.experiments.loop.online_world import PopulationWorld
    from evolution.learning import load_policy

    config = online_config() if scenario == "scenario3" else offline_config()
    assert config.learning is not None
    config = preset(scenario, runs=1, births=6, population_size=4, min_alive=2, max_alive=8,
                    insertion=0.5, evaluation_time=1.0, fertile_age=1.0,
                    conception_interval=0.5, checkpoint_interval=1,
                    learning={**config.learning, "proprioception": True})
    out = tmp_path / "run"
    experiments.run(config, out, evaluator=SERIAL)
    with Store.open(out / "results.sqlite") as store:
        records = store.learning(0)
        robots = {r.robot_id: r.robot() for r in store.robots(0, [r.robot_id for r in records])}
        failures = store.failures(0)
    assert records
    # Every policy-driven evaluation ran (a wrong observation would be a failure): only robots
    # without a hinge fail, in their infancy (and online, conceptions without mature parents).
    assert all("no active hinge" in f.detail if f.kind == "learner" else f.kind == "no-parents"
               for f in failures)
    for record in records:
        assert record.policy is not None
        ref = json.loads(record.policy)
        agent = load_policy(out / ref["file"], robots[record.robot_id], ref["digest"])
        assert agent.proprioception and agent.normalization is not None
    world = PopulationWorld(config, 0)
    try:  # the online world observes the hinges exactly when the run's policies do
        assert world._env.proprioception
    finally:
        world.close()


def test_report_shows_inborn_vs_learned(offline_ref: Path) -> None:
    from evolution.reporting import find_experiments, summary_rows

    [row] = summary_rows(find_experiments(offline_ref))
    with Store.open(offline_ref / "results.sqlite") as store:
        records = store.learning(0)
    assert row["learning"] == "sb3 darwinian"
    assert row["infants_learned"] == len(records)
    assert row["inborn_fitness_mean"] == pytest.approx(
        sum(r.inborn_fitness or 0.0 for r in records) / len(records))
    assert row["learned_fitness_mean"] == pytest.approx(
        sum(r.learned_fitness or 0.0 for r in records) / len(records))


@pytest.mark.parametrize("learning, needs", [
    ({"learner": "cma-es", "budget": 21}, "at least 63 s"),
    ({"learner": "random-search", "budget": 13}, "at least 14 s"),
    ({**LEARNING, "budget": 3.2}, "at least 3.26667 s"),
    # PPO's rollout: 128 steps in each of 2 envs (revolve_env.rl.ppo_settings), + 2 x 4.5 s
    ({"learner": "sb3", "budget": 13}, "at least 13.2667 s"),
])
def test_a_budget_too_small_for_one_learning_step_is_a_config_error(
        learning: dict[str, Any], needs: str) -> None:
    with pytest.raises(ConfigError, match=f"too small for one learning step.*{needs}"):
        preset("scenario1", learning=learning)


def test_mujoco_online_resume_restores_policy_driven_robots_from_the_snapshot(
        tmp_path: Path) -> None:
    """On MuJoCo the resume starts from the snapshot (no replay): the agent-driven robots get
    their policies back from their files, with their networks' states, to the same database."""
    pytest.importorskip("mujoco", reason="the mujoco package is not installed")
    from evolution.experiments import load_config

    config = load_config("scenario3", {
        "world": {"engine": "mujoco"}, "runs": 1, "births": 6, "population_size": 4,
        "min_alive": 2, "max_alive": 8, "insertion": 0.5, "evaluation_time": 1.0,
        "fertile_age": 1.0, "conception_interval": 0.5, "checkpoint_interval": 1,
        "learning": LEARNING})
    experiments.run(config, tmp_path / "ref", evaluator=SERIAL)
    out = tmp_path / "killed"
    with pytest.raises(Kill):
        experiments.run(config, out, killer(5), evaluator=SERIAL)
    assert list((out / "checkpoints").glob("*.snapshot"))
    events: list[ProgressEvent] = []
    experiments.resume(out, events.append, evaluator=SERIAL)
    assert not any(e.replaying for e in events) and events[-1].finished
    assert dump(out / "results.sqlite") == dump(tmp_path / "ref" / "results.sqlite")


def test_the_online_world_asks_the_policy_every_control_step() -> None:
    """A robot added with a policy is agent-controlled: every step the world passes the policy
    the robot's observation and sets its hinge targets to the answer."""
    import numpy as np

    from evolution.experiments.loop.online_world import PopulationWorld
    from revolve_env.body.examples import EXAMPLES
    from revolve_env.body.robot import Layer

    class Recording:
        control_period = 1 / 60

        def __init__(self, n: int) -> None:
            self.n, self.seen = n, 0

        def reset(self) -> None:
            pass

        def act(self, observation: np.ndarray) -> np.ndarray:
            assert observation.ndim == 1 and np.all(np.isfinite(observation))
            self.seen += 1
            return np.full(self.n, 0.5)

    config = online_config()
    world = PopulationWorld(config, 0)
    try:
        robot = EXAMPLES["spider"]()
        policy = Recording(len(robot.neurons_of(Layer.OUTPUT)))
        birth = world.add(robot, 0, policy)
        assert world._env.status(birth.robot_id).controlled_by == "agent"
        world.advance_to(0.5)
        assert policy.seen == round(0.5 / world._env.config.control_period)
        world.remove(birth.robot_id)
        world.advance_to(0.6)
        assert policy.seen == round(0.5 / world._env.config.control_period)
    finally:
        world.close()


# -- results folders that must not run code (issue 20) ------------------------------------------


class _Evil:
    """Unpickled, it creates ``marker``: what a policy file from a stranger could do."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple[Any, ...]:
        return (open, (str(self.marker), "w"))


def _as_pickle(out: Path, robot_id: int, content: Any, digest: str = "0" * 64) -> None:
    """Robot ``robot_id``'s policy replaced by a pickle as older versions wrote them."""
    import pickle

    (out / "policies" / f"run0_robot{robot_id}.pkl").write_bytes(pickle.dumps(content))
    reference = json.dumps({"file": f"policies/run0_robot{robot_id}.pkl", "digest": digest})
    with sqlite3.connect(out / "results.sqlite") as con:
        con.execute("UPDATE learning SET policy = ? WHERE run_id = 0 AND robot_id = ?",
                    (reference, robot_id))
    con.close()


def _cli_error(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    from evolution.cli import main

    status = main(argv)
    err = capsys.readouterr().err
    assert status == 2 and "Traceback" not in err, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


def test_resume_refuses_a_pickled_policy_without_running_it(
        online_killed: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    from evolution.experiments.app import api

    monkeypatch.setattr(api, "make_evaluator", lambda *a, **k: SERIAL)
    out = tmp_path / "killed"
    shutil.copytree(online_killed, out)
    marker = tmp_path / "marker"
    with Store.open(out / "results.sqlite") as store:
        robot_id = store.learning(0)[0].robot_id
    _as_pickle(out, robot_id, {"format": 1, "agent": _Evil(marker)})
    before = dump(out / "results.sqlite")
    line = _cli_error(capsys, ["resume", str(out)])
    assert "older pickled policy" in line and "--trust-pickled-policies" in line, line
    assert not marker.exists()
    assert dump(out / "results.sqlite") == before


def test_a_policy_file_that_is_a_pickle_in_disguise_is_damaged_and_runs_nothing(
        online_killed: Path, tmp_path: Path) -> None:
    """The new format's reference, its SHA-256 right, but the file a pickle: never unpickled."""
    import pickle

    out = tmp_path / "killed"
    shutil.copytree(online_killed, out)
    marker = tmp_path / "marker"
    target = _policies(out)[0]
    blob = pickle.dumps({"format": 1, "agent": _Evil(marker)})
    target.write_bytes(blob)
    with sqlite3.connect(out / "results.sqlite") as con:
        con.execute("UPDATE learning SET policy = json_set(policy, '$.sha256', ?) WHERE "
                    "json_extract(policy, '$.file') = ?",
                    (hashlib.sha256(blob).hexdigest(), str(target.relative_to(out))))
    con.close()
    before = dump(out / "results.sqlite")
    with pytest.raises(StoreError, match="is damaged") as error:
        experiments.resume(out, evaluator=SERIAL)
    assert str(target) in str(error.value) and "\n" not in str(error.value)
    assert not marker.exists()
    assert dump(out / "results.sqlite") == before


def test_a_trusted_pickled_policy_resumes_to_the_same_results(
        online_ref: Path, online_killed: Path, tmp_path: Path) -> None:
    """A folder of an older version (pickled policies) continues with the opt-in, as before."""
    from evolution.learning import load_policy

    out = tmp_path / "killed"
    shutil.copytree(online_killed, out)
    with Store.open(out / "results.sqlite") as store:
        records = store.learning(0)
        robots = {r.robot_id: r.robot() for r in store.robots(0)}
    for record in records:
        assert record.policy is not None
        ref = json.loads(record.policy)
        agent = load_policy(out / ref["file"], robots[record.robot_id], ref["digest"])
        _as_pickle(out, record.robot_id, {"format": 1, "agent": agent}, ref["digest"])
        (out / ref["file"]).unlink()
    with pytest.raises(StoreError, match="older pickled policy"):
        experiments.resume(out, evaluator=SERIAL)
    experiments.resume(out, evaluator=SERIAL, trust_pickled_policies=True)
    resumed, reference = dump(out / "results.sqlite"), dump(online_ref / "results.sqlite")
    assert {t: rows for t, rows in resumed.items() if t != "learning"} == {
        t: rows for t, rows in reference.items() if t != "learning"}
    # The learning rows are the same but for the older rows' references to their pickles.
    assert [r[:-1] for r in resumed["learning"]] == [r[:-1] for r in reference["learning"]]


def test_reevaluate_refuses_a_pickled_policy_before_evaluating_anything(
        offline_ref: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "exp"
    shutil.copytree(offline_ref, out)
    marker = tmp_path / "marker"
    with Store.open(out / "results.sqlite") as store:
        final = {rid for rid, _ in store.final_population(0)}
        robot_id = next(r.robot_id for r in store.learning(0) if r.robot_id in final)
    _as_pickle(out, robot_id, {"format": 1, "agent": _Evil(marker)})
    line = _cli_error(capsys, ["reevaluate", str(out), "--k", "1", "--workers", "1"])
    assert "older pickled policy" in line and "--trust-pickled-policies" in line
    assert not marker.exists()
    with Store.open(out / "results.sqlite") as store:
        assert store.reevaluations() == []


@pytest.mark.parametrize("file", ["/etc/passwd", "../outside.safetensors",
                                  "policies/../../outside.safetensors", "link/p.safetensors"])
def test_a_policy_reference_leading_outside_the_folder_is_refused(
        offline_ref: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str],
        file: str) -> None:
    out = tmp_path / "exp"
    shutil.copytree(offline_ref, out)
    (tmp_path / "elsewhere").mkdir()
    (out / "link").symlink_to(tmp_path / "elsewhere")
    with sqlite3.connect(out / "results.sqlite") as con:
        con.execute("UPDATE learning SET policy = json_set(policy, '$.file', ?) WHERE rowid = "
                    "(SELECT MIN(rowid) FROM learning WHERE policy IS NOT NULL)", (file,))
    con.close()
    for argv in (["reevaluate", str(out), "--k", "1"], ["report", str(out)],
                 ["show", "--db", str(out), "--best", "--out", str(tmp_path / "x.gif")]):
        line = _cli_error(capsys, argv)
        assert "policy" in line and repr(file) in line, line
    assert not (tmp_path / "x.gif").exists() and not (out / "report").exists()
