"""The evolution loop stepped from Python: no database, observers, ask/tell, the same numbers.

The loop without any observer must make exactly the records a stored run holds (the store
observer only writes what the loop hands it), offline and online; its observers are told in a
fixed order; ask/tell around one's own evaluation is a step. Physics: the fast stand-ins.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from experiment_fakes import (
    FakeWorld,
    fake_evaluate,
    fake_evaluate_with_losses,
    fake_world,
    small,
)

from evolution import experiments
from evolution.evaluation import LocalEvaluator
from evolution.experiments import (
    Evolution,
    ExperimentConfig,
    Member,
    Observer,
    ProgressEvent,
    ProgressObserver,
    Step,
    Store,
    preset,
    world_seed,
)
from evolution.experiments.loop.run import run_seed

SERIAL = LocalEvaluator(workers=1, function=fake_evaluate)
OFFLINE = small(preset("scenario1", births=40, population_size=6, offspring_size=6, runs=1,
                       diversity_interval=5, seed=4))
ONLINE = small(preset("scenario3", births=30, runs=1, checkpoint_interval=2,
                      diversity_interval=7, seed=4))


def _world(config: ExperimentConfig, run_id: int = 0) -> FakeWorld:
    return FakeWorld(config, world_seed(run_seed(config.seed, run_id)))


class Journal(Observer):
    """Writes down every hook the loop calls, and keeps the steps."""

    def __init__(self) -> None:
        self.calls: list[str] = []
        self.steps: list[Step] = []

    def started(self, evolution: Evolution) -> None:
        self.calls.append("started")

    def born(self, evolution: Evolution, member: Member) -> None:
        self.calls.append(f"born {member.robot_id}")

    def stepped(self, evolution: Evolution, step: Step) -> None:
        self.calls.append(f"stepped {step.births}")
        self.steps.append(step)

    def stopped(self, evolution: Evolution, status: str) -> None:
        self.calls.append(f"stopped {status}")


def _stored(db: Path) -> dict[str, list[Any]]:
    """What a database holds of run 0, in the loop's terms."""
    with Store.open(db) as store:
        return {
            "robots": [(r.robot_id, r.genome, r.parent_a, r.parent_b, r.origin, r.generation,
                        r.conceived_time, r.birth_time) for r in store.robots(0)],
            "fitness": [(s.robot_id, s.time, s.fitness, s.v, s.s)
                        for s in store.fitness_samples(0)],
            "population": [(b, t, members) for b, t, members in store.population_snapshots(0)],
            "transitions": store.transitions(0),
            "diversity": [(d.births, d.value) for d in store.diversity_over_births(0)],
            "failures": store.failures(0),
            "checkpoint": [store.checkpoint(0)],
        }


def _stepped(steps: list[Step]) -> dict[str, list[Any]]:
    """The same from the loop's steps alone."""
    robots = [r for s in steps for r in s.records.robots]
    fitness = [f for s in steps for f in s.records.fitness]
    return {
        "robots": [(r.robot_id, r.genome, r.parent_a, r.parent_b, r.origin, r.generation,
                    r.conceived_time, r.birth_time) for r in robots],
        "fitness": [(f.robot_id, f.time, f.fitness, f.v, f.s)
                    for f in sorted(fitness, key=lambda f: (f.time, f.robot_id))],
        "population": [(s.births, s.sim_time, s.records.population) for s in steps],
        "transitions": [t for s in steps for t in s.records.transitions],
        "diversity": [(s.births, s.records.diversity) for s in steps
                      if s.records.diversity is not None],
        "failures": [f for s in steps for f in s.records.failures],
        "checkpoint": [steps[-1].checkpoint],
    }


@pytest.mark.parametrize("config", [OFFLINE, ONLINE], ids=["offline", "online"])
def test_the_loop_alone_makes_the_records_a_stored_run_holds(
        config: ExperimentConfig, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Stepped in a notebook (no observer, no folder), the loop makes row for row what
    ``evolution.run`` stores; and it writes no file anywhere."""
    experiments.run(config, tmp_path / "stored", evaluator=SERIAL, world_factory=fake_world)
    here = tmp_path / "cwd"
    here.mkdir()
    monkeypatch.chdir(here)
    journal = Journal()
    with Evolution(config, evaluator=SERIAL, world=_world(config),
                   observers=[journal]) as evolution:
        fitness_after_each_step = []
        while not evolution.done:
            evolution.step()
            fitness_after_each_step.append(evolution.fitness)
            assert len(evolution.population) == len(evolution.fitness)
    assert _stepped(journal.steps) == _stored(tmp_path / "stored" / "results.sqlite")
    assert len(fitness_after_each_step) == len(journal.steps)
    assert os.listdir(here) == []


def test_observers_hear_every_hook_in_order() -> None:
    journal = Journal()
    with Evolution(OFFLINE, evaluator=SERIAL, observers=[journal]) as evolution:
        evolution.run()
        assert evolution.done and evolution.births == OFFLINE.births
    births = [c for c in journal.calls if c.startswith("born")]
    assert births == [f"born {i}" for i in range(OFFLINE.births)]
    steps = [c for c in journal.calls if c.startswith(("started", "stepped", "stopped"))]
    assert steps[0] == "started" and steps[-1] == "stopped finished"
    assert [c.split()[1] for c in steps[1:-1]] == [str(b) for b in range(6, 41, 6)] + ["40"]
    assert journal.calls.index("born 6") > journal.calls.index("stepped 6")  # births by step


def test_a_loop_closed_before_its_end_is_interrupted_and_stops() -> None:
    journal = Journal()
    evolution = Evolution(ONLINE, world=_world(ONLINE), observers=[journal])
    evolution.run(steps=2)
    assert evolution.births == 15 + 2 and not evolution.done
    evolution.close()
    assert journal.calls[-1] == "stopped interrupted"
    with pytest.raises(RuntimeError, match="run 0 has stopped"):
        evolution.step()


def test_an_observer_that_raises_stops_the_loop() -> None:
    class Failing(Observer):
        def stepped(self, evolution: Evolution, step: Step) -> None:
            if step.births > 20:
                raise KeyError("full disk")

    journal = Journal()
    with Evolution(OFFLINE, evaluator=SERIAL, observers=[journal, Failing()]) as evolution:
        with pytest.raises(KeyError, match="full disk"):
            evolution.run()
        assert journal.calls[-1] == "stopped interrupted" and evolution.births == 24
        with pytest.raises(RuntimeError, match="has stopped"):
            evolution.step()


def test_ask_and_tell_around_ones_own_evaluation_is_a_step() -> None:
    """Evaluating the asked tasks yourself gives the loop's own steps; generation 0 asks again
    for every robot lost in its evaluation."""
    config = OFFLINE.replace(births=30)
    lossy = LocalEvaluator(workers=1, function=fake_evaluate_with_losses)
    reference = Journal()
    with Evolution(config, evaluator=lossy, observers=[reference]) as evolution:
        evolution.run()
    journal = Journal()
    asks = 0
    with Evolution(config, observers=[journal]) as evolution:
        while not evolution.done:
            tasks = evolution.ask()
            asks += 1
            evolution.tell([fake_evaluate_with_losses(task) for task in tasks])
    assert _stepped(journal.steps) == _stepped(reference.steps)
    assert asks > len(journal.steps)  # generation 0 lost robots: asked again before its step


def test_ask_and_tell_misuse_is_one_clear_error() -> None:
    with Evolution(OFFLINE, evaluator=SERIAL) as evolution:
        with pytest.raises(RuntimeError, match="tell\\(\\) without ask\\(\\)"):
            evolution.tell([])
        tasks = evolution.ask()
        with pytest.raises(RuntimeError, match="ask\\(\\) again before tell\\(\\)"):
            evolution.ask()
    with Evolution(OFFLINE, evaluator=SERIAL) as evolution:
        tasks = evolution.ask()
        with pytest.raises(ValueError, match="one outcome per task asked \\(6\\), got 5"):
            evolution.tell([fake_evaluate(t) for t in tasks[:5]])
    with Evolution(ONLINE, world=_world(ONLINE)) as online, \
            pytest.raises(TypeError, match="ask\\(\\) is for offline evolution"):
        online.ask()


def test_a_finished_loop_refuses_another_step() -> None:
    with Evolution(OFFLINE.replace(births=6), evaluator=SERIAL) as evolution:
        evolution.step()
        assert evolution.done
        with pytest.raises(RuntimeError, match="run 0 is done"):
            evolution.step()


def test_progress_events_are_those_a_stored_run_sends(tmp_path: Path) -> None:
    """A progress observer in Python sees the events ``evolution.run`` sends (wall times
    aside): one per step, the last one finished."""
    sent: list[ProgressEvent] = []
    experiments.run(ONLINE, tmp_path / "run", sent.append, world_factory=fake_world)
    seen: list[ProgressEvent] = []
    with Evolution(ONLINE, world=_world(ONLINE),
                   observers=[ProgressObserver(seen.append)]) as evolution:
        evolution.run()

    def key(e: ProgressEvent) -> tuple[Any, ...]:
        return (e.births, e.sim_time, e.best, e.mean, e.population_size, e.replaying,
                e.finished, e.failures)

    assert [key(e) for e in seen] == [key(e) for e in sent]
    assert seen[-1].finished and np.isfinite(seen[-1].best)


def test_a_config_name_is_enough() -> None:
    with Evolution("quick", evaluator=SERIAL) as evolution:
        assert (evolution.mode, evolution.births, evolution.config.name) == ("offline", 0,
                                                                            "quick")
        assert evolution.world is None and evolution.population == ()
