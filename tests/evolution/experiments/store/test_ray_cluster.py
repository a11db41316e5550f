"""Runs on a two-node Ray cluster: the driver alone writes the database; nothing is shared.

The cluster is Ray's own test cluster (two nodes on this machine, one CPU each). Every Ray
worker process starts with :func:`refuse_sqlite_off_the_host`, which makes opening any SQLite
database fail except in an actor on the driver's node (the store host): a run task that opened
the results file itself, as before, fails the tests. Results must equal a local run's, row for
row, and so must the progress events (but for their wall-clock fields).

About 20 s by default (the cluster, the guard, an offline and an online study); the crash,
interrupt and snapshot tests are marked slow (about 10 s each): ``-m slow``.
"""

from __future__ import annotations

import os
import sqlite3
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from experiment_fakes import (
    RESULT_TABLES,
    Kill,
    dump_results,
    fake_evaluate,
    fake_world,
    kill_after,
    small,
)

from evolution import experiments
from evolution.evaluation import EvalOutcome, EvalTask, LocalEvaluator, RayEvaluator, evaluate_task
from evolution.experiments import (
    ExperimentConfig,
    OnlineWorld,
    ProgressEvent,
    RobotStatus,
    Store,
    load_config,
    preset,
)
from evolution.experiments.loop.online_world import PopulationWorld

ray = pytest.importorskip("ray")

_HOST_NODE = "REVOLVE_TEST_DB_NODE"
"""Environment variable (set for the Ray workers): the only node whose actors may open SQLite."""


def _on_the_host() -> bool:
    context = ray.get_runtime_context()
    return context.get_actor_id() is not None and context.get_node_id() == os.environ[_HOST_NODE]


def refuse_sqlite_off_the_host() -> None:
    """Ray worker setup hook: only an actor on the driver's node may open SQLite or put a
    written file in place (``os.replace``: how snapshots and policies are written)."""
    connect, replace = sqlite3.connect, os.replace

    def guarded_connect(*args: Any, **kwargs: Any) -> sqlite3.Connection:
        if not _on_the_host():
            raise RuntimeError(f"a Ray worker opened SQLite {args[:1]}: only the driver's store "
                               "host may")
        return connect(*args, **kwargs)

    def guarded_replace(source: Any, target: Any, **kwargs: Any) -> None:
        if not _on_the_host():
            raise RuntimeError(f"a Ray worker wrote {target}: only the driver's store host may")
        replace(source, target, **kwargs)

    sqlite3.connect = guarded_connect  # type: ignore[assignment]
    os.replace = guarded_replace


def slow_fake_evaluate(task: EvalTask) -> EvalOutcome:
    """:func:`fake_evaluate`, 0.2 s of wall-clock time per robot (a run to interrupt)."""
    time.sleep(0.2)
    return fake_evaluate(task)


def failing_fake_evaluate(task: EvalTask) -> EvalOutcome:
    """:func:`fake_evaluate`, but the evaluation of robot 9 of every run crashes."""
    if task.robot_id == 9:
        raise RuntimeError("evaluation crashed")
    return fake_evaluate(task)


@pytest.fixture(scope="module")
def cluster() -> Iterator[None]:
    """A head and a second node, one CPU each; Ray initialised in this process (the driver)."""
    from ray.cluster_utils import Cluster

    nodes = Cluster(initialize_head=True, head_node_args={"num_cpus": 1})
    try:
        nodes.add_node(num_cpus=1)
        here = Path(__file__).resolve()
        # The test's folder, tests/ and the repository, then the driver's own path (a worktree
        # imported ahead of an installed copy is imported by the workers too).
        path = os.pathsep.join(filter(None, [*(str(p) for p in (here.parent, here.parents[3],
                                                                   here.parents[4])),
                                             os.environ.get("PYTHONPATH")]))
        ray.init(address=nodes.address, include_dashboard=False, log_to_driver=False,
                 runtime_env={
                     "env_vars": {"PYTHONPATH": path, _HOST_NODE: nodes.head_node.node_id},
                     "worker_process_setup_hook": f"{here.stem}.refuse_sqlite_off_the_host",
                 })
        yield
    finally:
        ray.shutdown()
        nodes.shutdown()


def _offline() -> ExperimentConfig:
    return small(preset("scenario1", births=16, runs=2, population_size=4, offspring_size=4,
                        insertion=0.5, evaluation_time=1.0, fertile_age=1.5))


def _online() -> ExperimentConfig:
    return small(load_config("scenario3", {
        "runs": 2, "births": 16, "population_size": 3, "insertion": 0.5, "evaluation_time": 1.0,
        "fertile_age": 1.5, "min_alive": 2, "max_alive": 5, "conception_interval": 1.0,
        "checkpoint_interval": 2, "diversity_interval": 3}))


def _ray(function: Any) -> RayEvaluator:
    """A Ray evaluator on the fixture's cluster (Ray initialised already: it is not shut down)."""
    return RayEvaluator(function=function)


def _progress(events: list[ProgressEvent]) -> dict[int, list[tuple[Any, ...]]]:
    """Each run's events without their wall-clock fields."""
    out: dict[int, list[tuple[Any, ...]]] = {}
    for e in events:
        out.setdefault(e.run_id, []).append((e.births, e.sim_time, repr(e.best), repr(e.mean),
                                             e.population_size, e.replaying, e.finished))
    return out


def _local(config: ExperimentConfig, out: Path) -> list[ProgressEvent]:
    events: list[ProgressEvent] = []
    experiments.run(config, out, events.append, evaluator=LocalEvaluator(1, fake_evaluate),
                    world_factory=fake_world)
    return events


def test_the_guard_refuses_sqlite_in_ray_tasks(cluster: None) -> None:
    """The check below is real: a Ray task that opens SQLite fails."""
    assert len([n for n in ray.nodes() if n["Alive"]]) == 2
    opened = ray.remote(lambda: sqlite3.connect(":memory:").close())
    with pytest.raises(RuntimeError, match="only the driver's store host"):
        ray.get(opened.remote())
    moved = ray.remote(lambda: os.replace("/nonexistent/a", "/nonexistent/b"))
    with pytest.raises(RuntimeError, match="only the driver's store host"):
        ray.get(moved.remote())


@pytest.mark.parametrize("make_config", [_offline, _online], ids=["offline", "online"])
def test_a_study_on_two_nodes_equals_the_local_one(
        cluster: None, tmp_path: Path, make_config: Any) -> None:
    config = make_config()
    local_events = _local(config, tmp_path / "local")
    events: list[ProgressEvent] = []
    evaluator = _ray(fake_evaluate)
    summary = experiments.run(config, tmp_path / "ray", events.append, evaluator=evaluator,
                              world_factory=fake_world)
    assert [s.status for s in summary.runs] == ["finished", "finished"]
    assert (dump_results(tmp_path / "ray" / "results.sqlite")
            == dump_results(tmp_path / "local" / "results.sqlite"))
    assert _progress(events) == _progress(local_events)  # every event, in each run's order


@pytest.mark.slow  # about 10 s on two cores
def test_a_crashed_ray_study_keeps_its_commits_and_resumes_to_the_local_result(
        cluster: None, tmp_path: Path) -> None:
    config = _offline()
    _local(config, tmp_path / "local")
    out = tmp_path / "ray"
    with pytest.raises(RuntimeError, match="evaluation crashed"):
        experiments.run(config, out, evaluator=_ray(failing_fake_evaluate))
    with Store.open(out / "results.sqlite") as store:
        # Generations of 4: robots 0-7 were committed; the generation of robot 9 was not.
        assert [(r.status, r.births) for r in store.runs()] == [("interrupted", 8)] * 2
    experiments.resume(out, evaluator=_ray(fake_evaluate))
    assert dump_results(out / "results.sqlite") == dump_results(
        tmp_path / "local" / "results.sqlite")


@pytest.mark.slow  # about 10 s on two cores
def test_an_interrupted_ray_study_stops_its_runs_and_resumes(
        cluster: None, tmp_path: Path) -> None:
    """A progress callback raising in the driver (as Ctrl-C would) stops the remote runs."""
    config = _offline()
    _local(config, tmp_path / "local")
    out = tmp_path / "ray"

    def kill(event: ProgressEvent) -> None:
        if event.births >= 8:
            raise Kill(f"killed at {event.births} births")

    with pytest.raises(Kill):
        experiments.run(config, out, kill, evaluator=_ray(slow_fake_evaluate))
    with Store.open(out / "results.sqlite") as store:
        runs = store.runs()
    assert {r.status for r in runs} <= {"interrupted", "finished"}
    assert any(r.status == "interrupted" and r.births < 16 for r in runs)
    experiments.resume(out, evaluator=_ray(fake_evaluate))
    assert dump_results(out / "results.sqlite", RESULT_TABLES) == dump_results(
        tmp_path / "local" / "results.sqlite", RESULT_TABLES)


def _mujoco() -> ExperimentConfig:
    """A tiny online MuJoCo study: its checkpoints write snapshot files for an exact resume."""
    return small(load_config("scenario3", {
        "world": {"engine": "mujoco"}, "runs": 1, "births": 12, "population_size": 3,
        "insertion": 0.5, "evaluation_time": 1.0, "fertile_age": 1.5, "min_alive": 2,
        "max_alive": 5, "conception_interval": 1.0, "checkpoint_interval": 2,
        "diversity_interval": 3, "workers": 1}))


class _SlowWorld(PopulationWorld):
    """The MuJoCo population world, 0.3 s of wall-clock time per conception tick."""

    def advance_to(self, t: float) -> dict[int, RobotStatus]:
        time.sleep(0.3)
        return super().advance_to(t)


def slow_world(config: ExperimentConfig, seed: int) -> OnlineWorld:
    """A world factory (picklable) of :class:`_SlowWorld`: a run to interrupt."""
    return _SlowWorld(config, seed)


@pytest.mark.slow  # about 10 s on two cores
def test_snapshots_of_a_ray_run_reach_the_driver_and_resume_exactly(
        cluster: None, tmp_path: Path) -> None:
    pytest.importorskip("mujoco")
    config = _mujoco()
    experiments.run(config, tmp_path / "local", evaluator=LocalEvaluator(1))
    out = tmp_path / "ray"
    with pytest.raises(Kill):
        experiments.run(config, out, kill_after(7), evaluator=_ray(fake_evaluate),
                        world_factory=slow_world)
    with Store.open(out / "results.sqlite") as store:
        checkpoint = store.checkpoint(0)
    assert checkpoint is not None and checkpoint.births < 12
    (written,) = (out / "checkpoints").iterdir()  # written and pruned by the driver's host
    assert written.name == checkpoint.engine_state["snapshot"]["file"]
    events: list[ProgressEvent] = []
    experiments.resume(out, events.append, evaluator=_ray(fake_evaluate))
    assert not any(e.replaying for e in events)  # from the snapshot, not a replay
    assert events[0].births == checkpoint.births
    assert dump_results(out / "results.sqlite") == dump_results(
        tmp_path / "local" / "results.sqlite")
    assert not list((out / "checkpoints").iterdir())


@pytest.mark.slow  # about 30 s on two cores: PPO in the infants' Training Center
def test_policies_of_a_ray_run_reach_the_driver_and_serve_its_replay(
        cluster: None, tmp_path: Path) -> None:
    """Online SB3 infancy on pybullet: the policies are written on the driver's node, and a
    resume (a replay) reads them back from there."""
    pytest.importorskip("stable_baselines3")
    config = preset("scenario3", runs=1, births=6, population_size=4, min_alive=2,
                    max_alive=8, insertion=0.5, evaluation_time=1.0, fertile_age=1.0,
                    conception_interval=0.5, checkpoint_interval=1, learning={
                        "learner": "sb3", "algorithm": "PPO", "n_envs": 1, "vec_env": "dummy",
                        "insertion": 0.5, "seconds": 1.0, "budget": 3.3,
                        "algorithm_kwargs": {"n_steps": 16, "batch_size": 16, "n_epochs": 1}})
    torch = pytest.importorskip("torch")
    threads = torch.get_num_threads()
    # PPO's numbers depend on torch's thread count; Ray runs a task with one thread.
    torch.set_num_threads(1)
    try:
        experiments.run(config, tmp_path / "local", evaluator=LocalEvaluator(1))
    finally:
        torch.set_num_threads(threads)
    out = tmp_path / "ray"
    with pytest.raises(Kill):
        experiments.run(config, out, kill_after(5), evaluator=_ray(evaluate_task),
                        world_factory=slow_world)
    assert list((out / "policies").iterdir())
    events: list[ProgressEvent] = []
    experiments.resume(out, events.append, evaluator=_ray(evaluate_task))
    assert any(e.replaying for e in events)
    assert dump_results(out / "results.sqlite") == dump_results(
        tmp_path / "local" / "results.sqlite")
    assert (sorted(p.name for p in (out / "policies").iterdir())
            == sorted(p.name for p in (tmp_path / "local" / "policies").iterdir()))
