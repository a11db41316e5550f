"""Infancy learning inside the engine: Lamarckian/Darwinian inheritance, the learning records,
the online Training Center, learner failures, and exact resume with learning on.

The learners are the real ones (CMA-ES, random search) with a cheap synthetic candidate fitness
(:func:`experiment_fakes.param_distance_fitness`); the physics is replaced by the fakes of
:mod:`experiment_fakes`, so these tests check the engine's rules, fast.
"""

from __future__ import annotations

import sqlite3
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from experiment_fakes import (
    SMALL_ROBOTS,
    FakeWorld,
    fake_evaluate,
    fake_evaluate_after_infancy,
    param_distance_fitness,
)

from evolution import experiments
from evolution.evaluation import LocalEvaluator
from evolution.experiments import Birth, ConfigError, ExperimentConfig, ProgressEvent
from evolution.experiments.store.database import Store
from evolution.learning import (
    CandidateEvaluation,
    CMAESLearner,
    LearningResult,
    RandomSearchLearner,
    TrainingCenter,
)
from revolve_env.body.robot import Layer, Robot
from revolve_env.body.serialize import from_json
from revolve_env.brain import get_params

SERIAL = LocalEvaluator(workers=1, function=fake_evaluate_after_infancy)
CANDIDATES = CandidateEvaluation(insertion=0.0, seconds=1.0, function=param_distance_fitness)

# Reproduction that copies parameters unchanged: crossover grafts a subtree of one parent onto
# the other (parameters kept), and every mutation step is switched off. A child's controller
# parameters then all come from the genomes its parents passed on.
NO_MUTATION = replace(SMALL_ROBOTS, p_remove_subtree=0.0, p_duplicate_subtree=0.0,
                      p_swap_subtree=0.0, p_remove_hidden_neuron=0.0, p_remove_connection=0.0,
                      mutation_sigma=0.0)


def offline_config(**kw: Any) -> ExperimentConfig:
    base: dict[str, Any] = {
        "name": "learning", "population_size": 4, "offspring_size": 4, "births": 16,
        "insertion": 0.0, "evaluation_time": 1.0, "fertile_age": 1.0, "diversity_interval": 4,
        "evolution": NO_MUTATION}
    return ExperimentConfig(**{**base, **kw})


def cma(inheritance: str) -> TrainingCenter:
    # Budget: the inborn controller and one generation of 4.
    return TrainingCenter(CMAESLearner(sigma0=0.2, popsize=4, evaluation=CANDIDATES), 5.0,
                          inheritance)  # type: ignore[arg-type]


def random_search(inheritance: str) -> TrainingCenter:
    return TrainingCenter(RandomSearchLearner(sigma=0.2, batch_size=3, evaluation=CANDIDATES),
                          4.0, inheritance)  # type: ignore[arg-type]


def controller_values(robot: Robot) -> set[tuple[Any, ...]]:
    """Every learnable controller value of a robot, keyed by what it is (not by neuron ids,
    which crossover renumbers): the parameters of each non-input neuron, each weight."""
    neurons = {("neuron", n.activation, n.bias, n.gain, n.period, n.phase_offset, n.amplitude)
               for n in robot.neurons() if n.layer is not Layer.INPUT}
    return neurons | {("weight", c.weight) for c in robot.connections}


def passed_on(store: Store, run_id: int) -> tuple[dict[int, Robot], dict[int, Robot]]:
    """Each robot's inborn genome, and its learned one (the inborn one when nothing changed)."""
    inborn = {r.robot_id: from_json(r.genome) for r in store.robots(run_id)}
    learned = dict(inborn)
    for record in store.learning(run_id):
        if record.learned_genome is not None:
            learned[record.robot_id] = from_json(record.learned_genome)
    return inborn, learned


def check_inheritance(store: Store, lamarckian: bool) -> int:
    """Every child's controller values come from the genomes its parents passed on (learned
    ones when Lamarckian, inborn ones when Darwinian); returns how many children would have
    been impossible under the other rule (the test needs some, or it proves nothing)."""
    inborn, learned = passed_on(store, 0)
    given, other = (learned, inborn) if lamarckian else (inborn, learned)
    distinguishing = 0
    children = [r for r in store.robots(0) if r.origin == "reproduction"]
    assert children
    for child in children:
        values = controller_values(inborn[child.robot_id])
        pa, pb = child.parent_a, child.parent_b
        assert pa is not None and pb is not None
        assert values <= controller_values(given[pa]) | controller_values(given[pb]), child.robot_id
        if not values <= controller_values(other[pa]) | controller_values(other[pb]):
            distinguishing += 1
    return distinguishing


def assert_every_infant_accounted_for(store: Store, records: list[Any], births: int) -> None:
    failures = store.failures(0, "learner")
    assert all("no learnable parameters" in f.detail for f in failures)
    for f in failures:
        assert get_params(from_json(store.robot(0, f.robot_id).genome)).size == 0
    assert sorted([r.robot_id for r in records] + [f.robot_id for f in failures]) == list(
        range(births))
    assert len(failures) <= births // 4


@pytest.mark.parametrize("center", [cma, random_search], ids=["cma-es", "random-search"])
@pytest.mark.parametrize("inheritance", ["lamarckian", "darwinian"])
def test_offline_children_inherit_the_genome_the_rule_says(
        tmp_path: Path, center: Any, inheritance: str) -> None:
    summary = experiments.run(offline_config(), tmp_path / "out", evaluator=SERIAL,
                             infancy=center(inheritance))
    assert summary.runs[0].births == 16
    with Store.open(summary.db_path) as store:
        records = store.learning(0)
        # Every infant learned (one record each, with the learner's numbers), except robots
        # whose network has nothing to learn (the learner refuses them: a recorded failure).
        assert_every_infant_accounted_for(store, records, 16)
        for r in records:
            assert r.inheritance == inheritance
            assert r.evaluations == (5 if center is cma else 4)
            assert r.sim_seconds == r.evaluations * CANDIDATES.cost
            assert r.learned_fitness >= r.inborn_fitness  # the best evaluated, inborn included
            assert (r.learned_genome is None) == (r.learned_fitness == r.inborn_fitness)
        assert sum(r.learned_genome is not None for r in records) >= 8
        # The robots table keeps the genome as conceived: its params are not the learned ones.
        for r in records:
            if r.learned_genome is not None:
                assert store.robot(0, r.robot_id).genome != r.learned_genome
        assert check_inheritance(store, inheritance == "lamarckian") > 0


def test_offline_fitness_is_measured_on_the_learned_controller(tmp_path: Path) -> None:
    experiments.run(offline_config(births=4), tmp_path / "out", evaluator=SERIAL,
                   infancy=cma("darwinian"))
    with Store.open(tmp_path / "out" / "results.sqlite") as store:
        learned = {r.robot_id: r.learned_genome for r in store.learning(0)}
        for robot in store.robots(0):
            genome = learned[robot.robot_id] or robot.genome
            from evolution.evaluation import EvalTask, evaluation_seed

            task = EvalTask(robot.robot_id, from_json(genome), 0.0, 1.0,
                            evaluation_seed(store.runs()[0].seed, robot.robot_id))
            assert robot.fitness == fake_evaluate(task).fitness


class Kill(Exception):
    pass


def killer(after_births: int) -> Any:
    def progress(event: ProgressEvent) -> None:
        if event.births >= after_births and not event.replaying:
            raise Kill
    return progress


def dump(db: Path) -> dict[str, list[tuple[Any, ...]]]:
    tables = ("runs", "checkpoints", "robots", "fitness", "transitions", "population",
              "diversity", "failures", "learning")
    con = sqlite3.connect(db)
    try:
        return {t: sorted(con.execute(f"SELECT * FROM {t}").fetchall(), key=repr) for t in tables}
    finally:
        con.close()


def test_offline_kill_and_resume_with_lamarckian_learning_is_exact(tmp_path: Path) -> None:
    config = offline_config(births=24, runs=2)
    center = cma("lamarckian")
    experiments.run(config, tmp_path / "ref", evaluator=SERIAL, infancy=center)
    out = tmp_path / "killed"
    with pytest.raises(Kill):
        experiments.run(config, out, killer(8), evaluator=SERIAL, infancy=center)
    with pytest.raises(Kill):
        experiments.resume(out, killer(16), evaluator=SERIAL, infancy=center)
    with Store.open(out / "results.sqlite") as store:
        checkpoint = store.checkpoint(0)
        assert checkpoint is not None and checkpoint.engine_state.get("learned")
    experiments.resume(out, evaluator=SERIAL, infancy=center)
    reference = dump(tmp_path / "ref" / "results.sqlite")
    assert reference["learning"]
    assert dump(out / "results.sqlite") == reference


# -- online ----------------------------------------------------------------------------------------

class RecordingWorld(FakeWorld):
    """A fake world that keeps every robot it is given, in order."""

    def __init__(self, config: ExperimentConfig, seed: int, added: list[Robot]) -> None:
        super().__init__(config, seed)
        self.added = added

    def add(self, robot: Robot, robot_id: int, policy: Any = None) -> Birth:
        self.added.append(robot)
        return super().add(robot, robot_id, policy)


def online_config(**kw: Any) -> ExperimentConfig:
    base: dict[str, Any] = {
        "name": "online-learning", "mode": "online", "population_size": 8, "min_alive": 8,
        "max_alive": 12, "births": 20, "insertion": 1.0, "evaluation_time": 4.0,
        "fertile_age": 5.0, "conception_interval": 5.0, "checkpoint_interval": 4,
        "diversity_interval": 0, "evolution": NO_MUTATION}
    return ExperimentConfig(**{**base, **kw})


def test_online_infants_learn_before_entering_the_world(tmp_path: Path) -> None:
    added: list[Robot] = []
    summary = experiments.run(
        online_config(), tmp_path / "out", evaluator=SERIAL, infancy=random_search("lamarckian"),
        world_factory=lambda config, seed: RecordingWorld(config, seed, added))
    assert summary.runs[0].status == "finished" and summary.runs[0].births == 20
    with Store.open(summary.db_path) as store:
        records = store.learning(0)
        assert_every_infant_accounted_for(store, records, 20)
        assert sum(r.learned_genome is not None for r in records) >= 10
        _, learned = passed_on(store, 0)
        # The world got each robot with its learned controller (agent k is robot k).
        assert added == [learned[k] for k in range(20)]
        # Births happen at the conception ticks: learning took no world time, and maturity
        # still comes fertile_age seconds after birth.
        for r in records:
            birth = store.robot(0, r.robot_id).birth_time
            assert r.time == birth
            mature = [t.time for t in store.transitions(0, r.robot_id)
                      if t.target.value == "maturity"]
            assert mature in ([], [birth + 5.0])
        assert check_inheritance(store, lamarckian=True) > 0


class _Crashing:
    def learn(self, robot: Robot, budget: float, rng: np.random.Generator) -> LearningResult:
        raise RuntimeError("the learner crashed")


def test_online_failing_learner_keeps_the_inborn_robot_and_the_run_goes_on(tmp_path: Path) -> None:
    added: list[Robot] = []
    summary = experiments.run(
        online_config(), tmp_path / "out", evaluator=SERIAL,
        infancy=TrainingCenter(_Crashing(), 5.0, "lamarckian"),
        world_factory=lambda config, seed: RecordingWorld(config, seed, added))
    assert summary.runs[0].status == "finished" and summary.runs[0].births == 20
    with Store.open(summary.db_path) as store:
        failures = store.failures(0, "learner")
        assert [f.robot_id for f in failures] == list(range(20))
        assert all("the learner crashed" in f.detail for f in failures)
        assert store.learning(0) == []
        assert added == [from_json(r.genome) for r in store.robots(0)]


class DrawsButKeeps:
    """A learner that draws from its generator and keeps the inborn controller."""

    def learn(self, robot: Robot, budget: float, rng: np.random.Generator) -> LearningResult:
        rng.random(5)
        return LearningResult(robot, get_params(robot), (0.0,), 0.0, 0.0, 1, budget)


def test_learning_changes_nothing_else_in_the_run(tmp_path: Path) -> None:
    """A learner that learns nothing leaves the run as it was without learning (the learner's
    generator is not the run's): same robots, same fitness."""
    experiments.run(offline_config(), tmp_path / "plain", evaluator=SERIAL)
    nothing = TrainingCenter(DrawsButKeeps(), 0.5, "lamarckian")
    experiments.run(offline_config(), tmp_path / "learning", evaluator=SERIAL, infancy=nothing)
    plain, learning = (dump(tmp_path / d / "results.sqlite") for d in ("plain", "learning"))
    assert len(learning["learning"]) == 16
    assert all(row[4] is None for row in learning["learning"])  # no learned genome
    assert {k: v for k, v in learning.items() if k != "learning"} == {
        k: v for k, v in plain.items() if k != "learning"}


def test_a_budget_below_one_learning_step_is_refused_before_anything_is_written(
        tmp_path: Path) -> None:
    """Before, such a budget gave every infant one evaluation of its inborn controller and no
    learning, without a word."""
    for learning in ({"learner": "random-search", "budget": 13.0},  # inborn + 1 candidate: 14 s
                     {"learner": "sb3", "budget": 10.0}):  # 2 evaluations + a 2048-step rollout
        with pytest.raises(ConfigError, match="too small for one learning step"):
            experiments.run(offline_config(learning=learning), tmp_path / "out",
                            evaluator=SERIAL)
    with pytest.raises(ValueError, match="too small for one learning step"):
        TrainingCenter(RandomSearchLearner(evaluation=CANDIDATES), 0.5)
    assert not (tmp_path / "out").exists()


def test_real_physics_run_with_learning_measures_the_learned_robot(tmp_path: Path) -> None:
    """The default evaluator with a Training Center: every candidate and every robot in the
    physics (short times); each robot's fitness is the evaluation of the controller it learned."""
    from evolution.evaluation import EvalTask, evaluate_robot, evaluation_seed

    physics = CandidateEvaluation(insertion=0.25, seconds=0.5)
    center = TrainingCenter(RandomSearchLearner(sigma=0.3, batch_size=2, evaluation=physics),
                            3 * physics.cost, "lamarckian")
    config = offline_config(population_size=2, offspring_size=2, births=4, insertion=0.5,
                            evaluation_time=1.0, fertile_age=1.5, evolution=SMALL_ROBOTS)
    summary = experiments.run(config, tmp_path / "out", evaluator=LocalEvaluator(1),
                             infancy=center)
    with Store.open(summary.db_path) as store:
        records = store.learning(0)
        assert_every_infant_accounted_for(store, records, 4)
        assert all(r.evaluations == 3 and r.sim_seconds == 3 * physics.cost for r in records)
        learned = {r.robot_id: r.learned_genome for r in records}
        seed = store.runs()[0].seed
        for robot in store.robots(0):
            genome = learned.get(robot.robot_id) or robot.genome
            outcome = evaluate_robot(EvalTask(robot.robot_id, from_json(genome), 0.5, 1.0,
                                              evaluation_seed(seed, robot.robot_id),
                                              conditions=config.evaluation))
            assert robot.fitness == outcome.fitness


def test_online_kill_and_resume_with_learning_replays_to_the_same_result(tmp_path: Path) -> None:
    config = online_config(births=24)
    center = random_search("lamarckian")

    def world(c: ExperimentConfig, seed: int) -> RecordingWorld:
        return RecordingWorld(c, seed, [])

    experiments.run(config, tmp_path / "ref", evaluator=SERIAL, infancy=center,
                   world_factory=world)
    out = tmp_path / "killed"
    with pytest.raises(Kill):
        experiments.run(config, out, killer(14), evaluator=SERIAL, infancy=center,
                       world_factory=world)
    experiments.resume(out, evaluator=SERIAL, infancy=center, world_factory=world)
    reference = dump(tmp_path / "ref" / "results.sqlite")
    assert reference["learning"]
    assert dump(out / "results.sqlite") == reference
