"""Training Center: controller-parameter learners, the infancy hook, inheritance, bad learners.

The search logic is tested on cheap synthetic fitness functions (exact optima known); the claim
that CMA-ES improves a real robot is tested in the physics, on an example robot whose inborn gait
was weakened (amplitudes at 20 %), with short evaluations.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from evolution.config import EvolutionConfig
from evolution.evaluation import (
    EvalOutcome,
    EvalTask,
    LocalEvaluator,
    evaluate_after_infancy,
    run_infancy,
)
from evolution.learning import (
    CandidateEvaluation,
    CMAESLearner,
    LearnerError,
    LearningResult,
    RandomSearchLearner,
    TrainingCenter,
    evaluate_in_env,
)
from evolution.operators import mutate
from revolve_env.body.examples import EXAMPLES
from revolve_env.body.robot import Robot
from revolve_env.brain import get_params, param_bounds, param_names, set_params

# -- synthetic fitness (module level: picklable) --------------------------------------------------

_TARGET_SEED = 7


def _target(robot: Robot) -> np.ndarray:
    bounds = param_bounds(robot)
    u = np.random.default_rng(_TARGET_SEED).uniform(0.2, 0.8, len(bounds))
    return bounds[:, 0] + u * (bounds[:, 1] - bounds[:, 0])


def distance_fitness(task: EvalTask) -> EvalOutcome:
    """10 minus the normalised distance of the params to a fixed target (maximum 10 there)."""
    robot = task.robot
    bounds = param_bounds(robot)
    d = (get_params(robot) - _target(robot)) / (bounds[:, 1] - bounds[:, 0])
    return EvalOutcome(10.0 - float(np.linalg.norm(d)))


def inborn_is_best(task: EvalTask) -> EvalOutcome:
    """Peaks exactly at the gecko's inborn params: no candidate can beat them."""
    robot = task.robot
    d = get_params(robot) - get_params(EXAMPLES["gecko"]())
    return EvalOutcome(1.0 - float(np.abs(d).sum()))


def blow_up_every_other(task: EvalTask) -> EvalOutcome:
    """A blow-up for every candidate whose first param is above the inborn one."""
    robot = task.robot
    if get_params(robot)[0] > get_params(EXAMPLES["gecko"]())[0]:
        return EvalOutcome(None, failure="blow-up: test")
    return distance_fitness(task)


SYNTHETIC = CandidateEvaluation(insertion=0.0, seconds=1.0, function=distance_fitness)


def weak_gecko() -> Robot:
    """The example gecko with every oscillator amplitude cut to 20 %: a poor inborn gait."""
    g = EXAMPLES["gecko"]()
    p = get_params(g)
    scaled = [v * 0.2 if n.startswith("amplitude") else v
              for n, v in zip(param_names(g), p, strict=True)]
    return set_params(g, np.array(scaled))


# -- learners on synthetic fitness ----------------------------------------------------------------

def test_cma_es_approaches_a_known_optimum_and_accounts_the_budget() -> None:
    robot = EXAMPLES["gecko"]()
    learner = CMAESLearner(sigma0=0.2, popsize=8, evaluation=SYNTHETIC)
    result = learner.learn(robot, budget=81.0, rng=np.random.default_rng(0))
    # 1 inborn + 10 generations of 8 = 81 evaluations of 1 simulated second.
    assert result.evaluations == 81 == len(result.fitness)
    assert result.sim_seconds == pytest.approx(81.0)
    assert result.fitness[0] == result.inborn_fitness
    assert result.best_fitness == max(result.fitness)
    assert np.all(np.diff(result.best_so_far) >= 0)
    # The distance to the target shrank by more than half.
    assert 10.0 - result.best_fitness < 0.5 * (10.0 - result.inborn_fitness)
    np.testing.assert_array_equal(get_params(result.robot), result.params)
    bounds = param_bounds(robot)
    assert np.all(result.params >= bounds[:, 0]) and np.all(result.params <= bounds[:, 1])


def test_cma_es_beats_random_search_on_the_same_budget() -> None:
    robot = EXAMPLES["gecko"]()
    rng = np.random.default_rng(3)
    cma_result = CMAESLearner(sigma0=0.2, popsize=8, evaluation=SYNTHETIC).learn(robot, 81.0, rng)
    rs_result = RandomSearchLearner(sigma=0.2, evaluation=SYNTHETIC).learn(
        robot, 81.0, np.random.default_rng(3))
    assert rs_result.evaluations == 81
    assert rs_result.best_fitness > rs_result.inborn_fitness
    assert cma_result.best_fitness > rs_result.best_fitness


@pytest.mark.parametrize("learner", [
    CMAESLearner(popsize=4, evaluation=replace(SYNTHETIC, function=inborn_is_best)),
    RandomSearchLearner(batch_size=4, evaluation=replace(SYNTHETIC, function=inborn_is_best)),
], ids=["cma", "random"])
def test_learners_keep_the_inborn_controller_when_nothing_beats_it(learner) -> None:
    robot = EXAMPLES["gecko"]()
    result = learner.learn(robot, 9.0, np.random.default_rng(0))
    assert result.evaluations == 9
    assert result.best_fitness == result.inborn_fitness == 1.0
    np.testing.assert_array_equal(result.params, get_params(robot))
    assert result.robot == robot


def test_learning_is_reproducible_from_the_generator_state() -> None:
    robot = EXAMPLES["snake"]()
    for learner in (CMAESLearner(popsize=4, evaluation=SYNTHETIC),
                    RandomSearchLearner(batch_size=3, evaluation=SYNTHETIC)):
        a = learner.learn(robot, 13.0, np.random.default_rng(11))
        b = learner.learn(robot, 13.0, np.random.default_rng(11))
        c = learner.learn(robot, 13.0, np.random.default_rng(12))
        assert a.fitness == b.fitness and np.array_equal(a.params, b.params)
        assert a.fitness != c.fitness


def draws_from_global_numpy(task: EvalTask) -> EvalOutcome:
    """:func:`distance_fitness`, after drawing from NumPy's global generator (as a library
    might)."""
    np.random.random()
    return distance_fitness(task)


def test_cma_es_neither_uses_nor_changes_numpys_global_generator() -> None:
    # cma reseeds and samples np.random by default: an in-process evaluation drawing from it would
    # change the candidates (and the result would depend on the number of workers).
    robot = EXAMPLES["snake"]()
    learner = CMAESLearner(popsize=4, evaluation=SYNTHETIC)
    np.random.seed(5)
    state = np.random.get_state()[1].copy()
    a = learner.learn(robot, 13.0, np.random.default_rng(11))
    np.testing.assert_array_equal(np.random.get_state()[1], state)
    b = replace(learner, evaluation=replace(SYNTHETIC, function=draws_from_global_numpy)).learn(
        robot, 13.0, np.random.default_rng(11))
    assert a.fitness == b.fitness and np.array_equal(a.params, b.params)


def test_blown_up_candidates_score_zero_and_are_counted() -> None:
    evaluation = replace(SYNTHETIC, function=blow_up_every_other)
    result = RandomSearchLearner(batch_size=10, evaluation=evaluation).learn(
        EXAMPLES["gecko"](), 31.0, np.random.default_rng(0))
    zeros = sum(1 for f in result.fitness if f == 0.0)
    assert result.failures == zeros > 0
    assert result.best_fitness > 0


def test_budget_shorter_than_one_evaluation_only_reports_nothing_learned() -> None:
    robot = EXAMPLES["gecko"]()
    learner = CMAESLearner(evaluation=CandidateEvaluation(1.0, 6.0, function=distance_fitness))
    result = learner.learn(robot, 5.0, np.random.default_rng(0))
    assert result.evaluations == 0 and result.sim_seconds == 0.0
    assert math.isnan(result.best_fitness) and result.robot == robot


@pytest.mark.parametrize("budget", [0.0, -1.0, math.nan, math.inf])
def test_bad_budget_is_refused(budget: float) -> None:
    with pytest.raises(ValueError, match="budget"):
        CMAESLearner(evaluation=SYNTHETIC).learn(
            EXAMPLES["gecko"](), budget, np.random.default_rng(0))
    with pytest.raises(ValueError, match="budget"):
        TrainingCenter(CMAESLearner(), budget)


def test_bad_learner_settings_are_refused() -> None:
    with pytest.raises(ValueError, match="sigma0"):
        CMAESLearner(sigma0=0.0)
    with pytest.raises(ValueError, match="popsize"):
        CMAESLearner(popsize=1)
    with pytest.raises(ValueError, match="workers"):
        CandidateEvaluation(workers=0)
    with pytest.raises(ValueError, match="seconds"):
        CandidateEvaluation(seconds=0.0)
    with pytest.raises(ValueError, match="inheritance"):
        TrainingCenter(CMAESLearner(), 10.0, inheritance="baldwinian")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="learn"):
        TrainingCenter(object(), 10.0)  # type: ignore[arg-type]


# -- learners in the physics -----------------------------------------------------------------------

def test_cma_es_improves_a_weak_inborn_gait_in_the_physics() -> None:
    # On pybullet, where the figures below were measured.
    evaluation = CandidateEvaluation(insertion=0.25, seconds=2.0, function=evaluate_in_env,
                                     engine="pybullet")
    learner = CMAESLearner(sigma0=0.2, popsize=4, evaluation=evaluation)
    result = learner.learn(weak_gecko(), budget=9 * 2.25, rng=np.random.default_rng(1))
    assert result.evaluations == 9
    # Measured: inborn 0.357 m, best 0.991 m over a 2 s window (seed 1).
    assert result.improvement > 0.3
    # The returned robot really walks that well (an independent re-evaluation, same seed).
    task = EvalTask(0, result.robot, 0.25, 2.0, 0, engine="pybullet")
    again = evaluate_in_env(task).fitness
    assert again is not None and again > result.inborn_fitness + 0.3


def test_parallel_candidate_evaluation_does_not_change_the_result() -> None:
    def run(workers: int) -> LearningResult:
        evaluation = CandidateEvaluation(insertion=0.1, seconds=0.5, workers=workers,
                                         function=evaluate_in_env)
        return RandomSearchLearner(batch_size=4, evaluation=evaluation).learn(
            EXAMPLES["snake"](), 5 * 0.6, np.random.default_rng(5))

    one, two = run(1), run(2)
    assert one.evaluations == two.evaluations == 5
    assert one.fitness == two.fitness
    np.testing.assert_array_equal(one.params, two.params)


# -- the infancy hook, bad learners, inheritance ---------------------------------------------------

class _Raising:
    def learn(self, robot: Robot, budget: float, rng: np.random.Generator) -> LearningResult:
        raise RuntimeError("the learner crashed")


class _NaN:
    def learn(self, robot: Robot, budget: float, rng: np.random.Generator) -> LearningResult:
        params = get_params(robot)
        params[1] = np.nan
        return LearningResult(robot, params, (1.0,), 1.0, 1.0, 1, 1.0)


class _OtherBody:
    def learn(self, robot: Robot, budget: float, rng: np.random.Generator) -> LearningResult:
        other = EXAMPLES["snake"]()
        return LearningResult(other, get_params(robot), (1.0,), 1.0, 1.0, 1, 1.0)


class _Shifted:
    """Adds 0.05 to every phase offset: a known 'learned' controller."""

    def learn(self, robot: Robot, budget: float, rng: np.random.Generator) -> LearningResult:
        p = get_params(robot)
        learned = np.array([v + 0.05 if n.startswith("phase_offset") else v
                            for n, v in zip(param_names(robot), p, strict=True)])
        return LearningResult(set_params(robot, learned), learned, (0.0, 1.0), 0.0, 1.0, 2, budget)


@pytest.mark.parametrize(("learner", "message"), [
    (_Raising(), "the learner crashed"),
    (_NaN(), "nan"),
    (_OtherBody(), "another body"),
], ids=["raises", "nan", "other-body"])
def test_a_bad_learner_leaves_the_inborn_controller(learner, message: str) -> None:
    robot = EXAMPLES["gecko"]()
    center = TrainingCenter(learner, 10.0, "lamarckian")
    outcome = center.infancy(robot, np.random.default_rng(0))
    assert outcome.robot == robot and outcome.genome == robot and outcome.result is None
    assert outcome.failure is not None and message in outcome.failure.lower()
    with pytest.raises(LearnerError):
        center(robot, np.random.default_rng(0))
    # The engine's hook call keeps the inborn robot and reports the failure.
    report = run_infancy(center, robot, seed=0)
    assert report.robot == robot and not report.changed and report.learning is None
    assert report.failure is not None and "LearnerError" in report.failure


def _engine_evaluate(task: EvalTask) -> EvalOutcome:
    """The engine's infancy call, then the synthetic fitness of the robot that lives on."""
    return evaluate_after_infancy(task, distance_fitness)


def test_a_raising_learner_is_recorded_in_the_store_and_the_run_goes_on(tmp_path) -> None:
    from evolution.experiments import ExperimentConfig, run
    from evolution.experiments.store.database import Store

    config = ExperimentConfig(name="learning-fails", population_size=3, offspring_size=3,
                              births=6, evaluation_time=1.0, insertion=0.0, fertile_age=1.0,
                              diversity_interval=0)
    with LocalEvaluator(1, _engine_evaluate) as evaluator:
        summary = run(config, tmp_path / "out", evaluator=evaluator,
                      infancy=TrainingCenter(_Raising(), 5.0))
    assert summary.runs[0].status == "finished" and summary.runs[0].births == 6
    with Store.open(summary.db_path) as store:
        failures = store.failures(0, "learner")
    assert sorted(f.robot_id for f in failures) == list(range(6))
    assert all("the learner crashed" in f.detail for f in failures)


@pytest.mark.parametrize("inheritance", ["darwinian", "lamarckian"])
def test_lamarckian_children_inherit_learned_params_darwinian_ones_do_not(inheritance: str) -> None:
    parent = EXAMPLES["gecko"]()
    center = TrainingCenter(_Shifted(), 10.0, inheritance)  # type: ignore[arg-type]
    outcome = center.infancy(parent, np.random.default_rng(0))
    assert outcome.failure is None and outcome.result is not None
    learned = outcome.result.params
    assert not np.array_equal(learned, get_params(parent))
    np.testing.assert_array_equal(get_params(outcome.robot), learned)  # it lives with them
    # A child made by the mutation operators (structure and parameter changes switched off, so
    # every parameter is inherited unchanged) from the genome the parent passes on.
    no_change = EvolutionConfig(p_remove_subtree=0.0, p_duplicate_subtree=0.0,
                                p_swap_subtree=0.0, p_remove_hidden_neuron=0.0,
                                p_remove_connection=0.0, mutation_sigma=0.0)
    child = mutate(outcome.genome, np.random.default_rng(1), no_change).child
    assert child is not None
    expected = learned if inheritance == "lamarckian" else get_params(parent)
    np.testing.assert_array_equal(get_params(child), expected)
    assert center.genome_for_children(parent, outcome.robot) == outcome.genome


# -- configs and the default evaluation ------------------------------------------------------------

def test_the_default_candidate_evaluation_matches_the_env_path() -> None:
    from evolution.evaluation import evaluate_task

    task = EvalTask(0, weak_gecko(), 0.25, 1.0, 0)
    assert CandidateEvaluation().function is evaluate_task
    assert evaluate_task(task).fitness == pytest.approx(evaluate_in_env(task).fitness, abs=1e-12)


def test_shipped_learning_configs_add_learning_to_scenarios_1_and_3() -> None:
    from evolution.experiments import load_config, preset

    for scenario, inheritance in (("scenario1", "darwinian"), ("scenario3", "lamarckian")):
        config = load_config(f"{scenario}_learning")
        center = config.training_center()
        assert config.replace(name=scenario, learning=None) == preset(scenario)
        assert center is not None and center.inheritance == inheritance
        assert isinstance(center.learner, CMAESLearner) and center.budget == 119.0
        # The budget pays for exactly the inborn controller and 4 generations of 4.
        assert center.budget / center.learner.evaluation.cost == 17


def test_learning_table_errors_name_the_problem(tmp_path) -> None:
    from evolution.experiments import ConfigError, ExperimentConfig
    from evolution.learning import training_center_from_dict

    with pytest.raises(ValueError, match="learner must be one of"):
        training_center_from_dict({"learner": "hill-climb", "budget": 10.0})
    with pytest.raises(ValueError, match="unknown learning key.*popsiz"):
        training_center_from_dict({"learner": "cma-es", "budget": 10.0, "popsiz": 4})
    with pytest.raises(ValueError, match="budget"):
        training_center_from_dict({"learner": "random-search"})
    bad = tmp_path / "bad.toml"
    bad.write_text('preset = "scenario1"\n[learning]\nlearner = "cma-es"\nbudget = -1.0\n')
    with pytest.raises(ConfigError, match="bad.toml.*budget"):
        ExperimentConfig.from_toml(bad)
    plain = tmp_path / "plain.toml"
    plain.write_text('preset = "quick"\n')
    assert ExperimentConfig.from_toml(plain).training_center() is None
