"""Tasks: the paper's fitness to the bit, each shipped task against its definition computed
independently, a user's task in every entry point, and one-line refusals of bad tasks."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from user_tasks import AliveBonus, Sideways, Straighter

import revolve_env
from evolution.evaluation import EvalTask, evaluate_robot, evaluate_robots
from evolution.learning import CandidateEvaluation, RandomSearchLearner
from evolution.learning.sb3 import _make_env
from revolve_env import evaluate, example
from revolve_env.body.parts import light_inputs
from revolve_env.envs.population import PopulationEnv, PopulationKeywords
from revolve_env.fitness import fitness_terms
from revolve_env.setting import Setting, SettingKeywords
from revolve_env.tasks import (
    TASKS,
    DirectedLocomotion,
    LightFollowing,
    Locomotion,
    TaskError,
    make_task,
    task_class,
    task_from_dict,
)
from revolve_env.world import WorldConfig

SHORT = {"seconds": 2.0, "insertion": 0.5}
ENGINES = ["pybullet", pytest.param("mujoco", marks=pytest.mark.skipif(
    not __import__("importlib").util.find_spec("mujoco"), reason="needs mujoco"))]


def _same(a: Any, b: Any) -> bool:
    return bool(a.fitness == b.fitness and a.v == b.v and a.s == b.s
                and np.array_equal(a.trajectory, b.trajectory))


@pytest.mark.parametrize("engine", ENGINES)
def test_the_default_task_is_the_papers_fitness_to_the_bit(engine: str) -> None:
    robot = example("spider")
    plain = evaluate(robot, engine=engine, **SHORT)
    for task in ("locomotion", Locomotion(), {"name": "locomotion", "s_weight": 5.0}):
        assert _same(evaluate(robot, engine=engine, task=task, **SHORT), plain)
    poses = plain.trajectory[::12]  # the default pose rate: 5 Hz, every 12th control period
    terms = fitness_terms(poses)
    assert (plain.fitness, plain.v, plain.s) == (terms.fitness, terms.v, terms.s)
    heavier = evaluate(robot, engine=engine, task=Locomotion(s_weight=10.0), **SHORT)
    assert heavier.fitness == fitness_terms(poses, 10.0).fitness


def test_directed_locomotion_is_the_displacement_along_its_heading() -> None:
    robot = example("gecko")
    base = evaluate(robot, **SHORT)
    path = base.trajectory
    for heading in (0.0, math.pi / 2, 2.5):
        got = evaluate(robot, task=DirectedLocomotion(heading=heading), **SHORT)
        d = path[-1, :2] - path[0, :2]
        assert got.fitness == pytest.approx(d[0] * math.cos(heading) + d[1] * math.sin(heading),
                                            abs=1e-12)
        assert (got.v, got.s) == (base.v, base.s)  # the kinematic terms, whatever the task
    ahead = evaluate(robot, task=DirectedLocomotion(0.0), **SHORT).fitness
    behind = evaluate(robot, task=DirectedLocomotion(math.pi), **SHORT).fitness
    assert ahead == pytest.approx(-behind, abs=1e-12)


def test_light_following_without_a_light_sensor_scores_the_light_at_the_core() -> None:
    robot = example("spider")  # no light sensor
    assert light_inputs(robot).size == 0
    result = evaluate(robot, task="light-following", **SHORT)
    config = WorldConfig()
    light = np.array(config.light_position)

    def at(p: np.ndarray) -> float:
        return 1.0 / (1.0 + (float(np.linalg.norm(light - p)) / config.light_range) ** 2)

    expected = at(result.trajectory[-1]) - at(result.trajectory[0])
    assert result.fitness == pytest.approx(expected, abs=1e-12)


def test_light_following_reads_the_robots_light_sensor() -> None:
    """The sensor crawler's fitness is the change of its light sensor's own reading, as the
    single-robot env observes it (noise-free), and the same in evaluate and the env."""
    robot = example("sensor_crawler")
    [k] = light_inputs(robot).tolist()
    env = revolve_env.LocomotionEnv(robot, controller="brain", insertion_time=0.5,
                                    evaluation_time=2.0, task="light-following",
                                    reset_noise_scale=0.0)  # evaluate's start, at rest
    obs, _ = env.reset(seed=0)
    zero = np.zeros(env.action_space.shape or (0,), np.float32)
    readings, total, done, step = [], 0.0, False, 0
    while not done:
        obs, reward, terminated, truncated, info = env.step(zero)
        step += 1
        if step >= env._insertion_steps:
            readings.append(float(obs[k]))
        total += float(reward)
        done = terminated or truncated
    env.close()
    assert info["fitness"] == pytest.approx(readings[-1] - readings[0], abs=1e-12)
    assert total == pytest.approx(info["fitness"], abs=1e-12)  # reward: the gain per step
    assert info["fitness"] == pytest.approx(
        evaluate(robot, task=LightFollowing(), seed=0, **SHORT).fitness, abs=1e-12)


@pytest.mark.parametrize("task", [Locomotion(), DirectedLocomotion(1.0), LightFollowing(),
                                  Sideways(2.0)], ids=lambda t: type(t).__name__)
def test_every_task_scores_alike_in_evaluate_and_the_gym_env(task: Any) -> None:
    robot = example("sensor_crawler")
    env = gym.make("revolve_env/Locomotion-v1", robot=robot, controller="brain",
                   insertion_time=0.5, evaluation_time=2.0, task=task,
                   reset_noise_scale=0.0)  # evaluate's start, at rest
    env.reset(seed=4)
    done, total = False, 0.0
    while not done:
        _, reward, terminated, truncated, info = env.step(np.zeros(env.action_space.shape))
        total += float(reward)
        done = terminated or truncated
    env.close()
    # The env's path length is a running sum, evaluate's a sum of the whole path: to rounding.
    assert info["fitness"] == pytest.approx(evaluate(robot, task=task, seed=4, **SHORT).fitness,
                                            rel=1e-12, abs=1e-12)
    assert total == pytest.approx(info["fitness"], abs=1e-12)


def test_a_users_task_is_stored_and_made_again_by_its_dotted_path() -> None:
    task = Sideways(scale=3.0)
    data = task.to_dict()
    assert data == {"name": "user_tasks:Sideways", "scale": 3.0, "pose_rate": 5.0}
    assert task_from_dict(data) == task
    assert make_task("user_tasks:Sideways") == Sideways()
    for name in TASKS:  # every shipped task by its name, its defaults, round trip
        shipped = make_task(name)
        assert shipped.name == name and task_from_dict(shipped.to_dict()) == shipped
    assert task_class("directed-locomotion") is DirectedLocomotion
    mine = Straighter()  # a subclass of a shipped task is the user's: its own dotted path
    assert mine.to_dict() == {"name": "user_tasks:Straighter", "s_weight": 10.0, "pose_rate": 5.0}
    assert task_from_dict(mine.to_dict()) == mine and Locomotion().name == "locomotion"


def test_a_users_task_in_the_population_env_scores_every_robot() -> None:
    """Fitness window longer than the episode: the window is every pose since insertion, so
    each robot's fitness is its sideways distance from then to its last pose (at 5 Hz, the
    default: every 12th control period)."""
    env = PopulationEnv(initial_robots=[example("spider"), example("gecko")],
                        insertion_time=0.25, fitness_window=10.0, task=Sideways(2.0))
    env.reset(seed=1)
    totals = dict.fromkeys(env.agents, 0.0)
    for _ in range(40):
        _, rewards, _, _, infos = env.step({})
        for agent, r in rewards.items():
            totals[agent] += r
    insertion = round(0.25 / env.config.control_period)
    for agent, info in infos.items():
        path = info["trajectory"]
        last = insertion + (len(path) - 1 - insertion) // 12 * 12
        expected = 2.0 * abs(path[last, 1] - path[insertion, 1])
        assert info["fitness"] == pytest.approx(expected, abs=1e-12)
        assert totals[agent] == pytest.approx(info["fitness"], abs=1e-12)
    env.close()


def test_a_tasks_own_reward_is_the_reward_of_both_envs() -> None:
    env = PopulationEnv(initial_robots=[example("snake")], insertion_time=0.25,
                        task=AliveBonus())
    env.reset(seed=0)
    for _ in range(30):  # two poses at 5 Hz after the 15 periods of insertion: ages 15 and 27
        _, rewards, _, _, infos = env.step({})
        assert list(rewards.values()) == [1.0]
    assert infos["robot_0"]["fitness"] > 0  # the fitness stays the task's
    env.close()
    single = gym.make("revolve_env/Locomotion-v1", robot=example("snake"), controller="brain",
                      insertion_time=0.25, evaluation_time=0.5, task=AliveBonus())
    single.reset(seed=0)
    assert single.step(np.zeros(single.action_space.shape))[1] == 1.0
    single.close()


@pytest.mark.parametrize("call", ["step", "advance"])
def test_a_tasks_reward_of_the_wrong_shape_is_refused_by_step_and_advance(call: str) -> None:
    class Scalar(AliveBonus):
        def reward(self, window: Any, fitness: Any, previous: Any) -> Any:
            return np.zeros(fitness.shape[0] + 1)

    env = PopulationEnv(initial_robots=[example("snake")], insertion_time=0.25, task=Scalar())
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"reward\(\.\.\.\) must give shape \(1,\), got \(2,\)"):
        getattr(env, call)({})  # advance() reads no reward, but a user's is checked all the same
    env.close()


def test_the_learners_score_candidates_on_their_task() -> None:
    robot = example("spider")
    task = DirectedLocomotion(heading=math.pi / 2)
    evaluation = CandidateEvaluation(insertion=0.25, seconds=0.5, task=task)
    result = RandomSearchLearner(batch_size=2, evaluation=evaluation).learn(
        robot, 3 * evaluation.cost, np.random.default_rng(7))
    seed = int(np.random.default_rng(7).integers(0, 2**63 - 1))  # the search's common seed
    inborn = evaluate(robot, seconds=0.5, insertion=0.25, seed=seed, task=task).fitness
    assert result.fitness[0] == inborn
    env = _make_env(robot, "modulate", 0.25, 0.5, 1 / 60, task=task)  # SB3's training env
    assert env.task == task
    env.close()


def test_evaluations_of_several_tasks_side_by_side_keep_each_its_own() -> None:
    robot = example("gecko")
    tasks = [EvalTask(i, robot, 0.25, 1.0, 3, task=t)
             for i, t in enumerate([Locomotion(), Sideways(), DirectedLocomotion(2.0)])]
    together = evaluate_robots(tasks)
    assert [o.fitness for o in together] == [evaluate_robot(t).fitness for t in tasks]
    assert len({o.fitness for o in together}) == 3


@pytest.mark.parametrize(("task", "message"), [
    ("walking", "unknown task 'walking': use one of locomotion"),
    ("no_such_module:Task", "task 'no_such_module:Task': cannot import module"),
    ("user_tasks:Nothing", "module 'user_tasks' has no 'Nothing'"),
    ("user_tasks:NoFitness", "task class 'user_tasks:NoFitness' does not follow the Task "
                             "protocol: it has no fitness, reward, to_dict, signal"),
    ({"name": "locomotion", "speed": 1.0}, "task 'locomotion': bad parameters ['speed']"),
    ({"name": "directed-locomotion", "heading": math.inf}, "heading (radians) must be a finite"),
    ({"name": "locomotion", "s_weight": "5"}, "s_weight must be a finite number, got '5'"),
    ({"heading": 1.0}, "a task table needs a 'name'"),
    (Sideways, "task=Sideways is a class: pass an instance, Sideways()"),
    ("user_tasks:Mutable", "must be hashable (a frozen dataclass)"),
    ("user_tasks:Smell", "asks for signal 'smell'; known signals: light"),
], ids=str)
def test_a_bad_task_is_refused_in_one_line_naming_it(task: Any, message: str) -> None:
    with pytest.raises(TaskError) as caught:
        make_task(task)
    assert message in str(caught.value) and "\n" not in str(caught.value)
    with pytest.raises(ValueError, match="task"):  # a TaskError is a ValueError: bad input
        evaluate(example("snake"), task=task, **SHORT)


def test_a_name_read_from_someone_elses_results_resolves_without_importing_their_code() -> None:
    stored = {"name": "user_tasks:Sideways", "scale": 2.0}
    with pytest.raises(TaskError, match="imports its module, which is not allowed here"):
        task_from_dict(stored, allow_import=False)
    assert task_from_dict({"name": "locomotion", "s_weight": 4}, allow_import=False) == \
        Locomotion(4.0)
    assert Locomotion(4).to_dict() == {"name": "locomotion", "s_weight": 4.0,  # plain floats
                                       "pose_rate": 5.0}


def test_a_fitness_of_the_wrong_shape_is_refused_naming_the_task() -> None:
    class Scalar(Sideways):
        def fitness(self, window: Any) -> Any:
            return 1.0

    with pytest.raises(TaskError, match="fitness\\(window\\) must give shape \\(1,\\)"):
        evaluate(example("snake"), task=Scalar(), **SHORT)


def test_the_package_exports_the_task_keywords() -> None:
    import inspect

    # evaluate and evaluate_many take it as a part of their setting (Setting.of's keywords)
    for fn in (Setting.of, revolve_env.LocomotionEnv.__init__):
        assert "task" in inspect.signature(fn).parameters
    # PopulationEnv takes it among its keywords (a part of its setting)
    for keywords in (SettingKeywords, PopulationKeywords):
        assert "task" in keywords.__annotations__
