"""Fast stand-ins for the physics, for testing the engine's rules (not the physics).

``fake_evaluate`` and :class:`FakeWorld` give every robot a deterministic speed derived from its
genome, so fitness differs between robots, depends on the genome (selection has something to
work on), and is reproducible. Module-level so worker processes can import them.
"""

from __future__ import annotations

import hashlib
import math
import sqlite3
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from evolution.config import EvolutionConfig
from evolution.evaluation import EvalOutcome, EvalTask, evaluate_after_infancy
from evolution.experiments import Birth, ExperimentConfig, ProgressEvent, RobotStatus, load_config
from revolve_env.body.robot import Robot
from revolve_env.body.serialize import to_json
from revolve_env.brain import get_params, param_bounds


def genome_of(task: EvalTask) -> str:
    """The task's robot as the store keeps it (compact JSON): what the fakes hash."""
    return to_json(task.robot, indent=None)


def speed_of(genome: str) -> float:
    """A deterministic speed in [0, 0.1) m/s: more parts and more connections walk faster."""
    digest = int(hashlib.sha256(genome.encode()).hexdigest()[:8], 16)
    return 0.1 * ((genome.count('"type"') + digest % 97) % 100) / 100.0


def fake_evaluate(task: EvalTask) -> EvalOutcome:
    """Fitness of a straight walk at the genome's speed over the window, plus seeded noise."""
    u = speed_of(genome_of(task))
    noise = np.random.default_rng(task.seed).normal(0.0, 1e-3)
    v = u * task.seconds + abs(noise)
    return EvalOutcome(v + 5 * u * task.seconds, v, u * task.seconds)


def fake_evaluate_with_losses(task: EvalTask) -> EvalOutcome:
    """As :func:`fake_evaluate`, but one robot in five blows up."""
    if int(hashlib.sha256(genome_of(task).encode()).hexdigest()[:4], 16) % 5 == 0:
        return EvalOutcome(None, failure="blow-up: core speed 12.0 m/s > 10.0")
    return fake_evaluate(task)


def fake_evaluate_with_nan(task: EvalTask) -> EvalOutcome:
    """As :func:`fake_evaluate`, but one robot in five gets a NaN fitness (a diverged
    evaluation that did not report itself as a blow-up)."""
    if int(hashlib.sha256(genome_of(task).encode()).hexdigest()[:4], 16) % 5 == 0:
        return EvalOutcome(math.nan, math.nan, math.nan)
    return fake_evaluate(task)


class FakeWorld:
    """An online world where each robot walks straight at its genome's speed.

    Sliding-window fitness after insertion: ``6 u w`` where ``w`` is the part of the last
    ``evaluation_time`` seconds the robot has walked. When ``blow_ups`` is set, robots faster
    than ``blow_up_speed`` (by default the top 2 %) blow up ``blow_up_age`` seconds after birth
    or later; the world then reports ``blow_up_fitness`` for them (the population env reports 0).
    """

    def __init__(self, config: ExperimentConfig, seed: int, blow_ups: bool = False,
                 blow_up_fitness: float = 0.0, blow_up_speed: float = 0.098,
                 blow_up_age: float = 5.0) -> None:
        self.config = config
        self._time = 0.0
        self._next = 0
        self.robots: dict[int, tuple[float, float, tuple[float, float], float]] = {}
        self.max_population = 0
        self.blow_ups = blow_ups
        self.blow_up_fitness = blow_up_fitness
        self.blow_up_speed = blow_up_speed
        self.blow_up_age = blow_up_age
        self.closed = False
        self.policies: dict[int, Any] = {}

    @property
    def time(self) -> float:
        return self._time

    def add(self, robot: Robot, robot_id: int, policy: Any = None) -> Birth:
        self.policies[robot_id] = policy
        position = (0.0, float(self._next))  # a row of lanes: never crowded
        self._next += 1
        self.robots[robot_id] = (speed_of(to_json(robot, indent=None)), self._time, position,
                                 0.0)
        self.max_population = max(self.max_population, len(self.robots))
        return Birth(robot_id, position, True)

    def remove(self, robot_id: int) -> None:
        del self.robots[robot_id]

    def advance_to(self, t: float) -> dict[int, RobotStatus]:
        assert t >= self._time
        self._time = t
        out: dict[int, RobotStatus] = {}
        for robot_id, (u, born, pos, _) in list(self.robots.items()):
            age = t - born
            walked = max(0.0, min(age - self.config.insertion, self.config.evaluation_time))
            removed = None
            fitness = 6 * u * walked
            if self.blow_ups and u > self.blow_up_speed and age >= self.blow_up_age:
                removed = "core speed 12.0 m/s > 10.0"
                fitness = self.blow_up_fitness
                del self.robots[robot_id]
            out[robot_id] = RobotStatus(
                robot_id, fitness, u * walked, u * walked,
                np.array([pos[0] + u * age, pos[1], 0.0]), age=age,
                inserting=age < self.config.insertion, mature=age >= self.config.fertile_age,
                death=None if removed is None else "blow_up", blow_up=removed)
        return out

    def close(self) -> None:
        self.closed = True


def fake_world(config: ExperimentConfig, seed: int) -> FakeWorld:
    return FakeWorld(config, seed)


def fake_world_with_blow_ups(config: ExperimentConfig, seed: int) -> FakeWorld:
    return FakeWorld(config, seed, blow_ups=True)


def fake_world_with_late_blow_ups(config: ExperimentConfig, seed: int) -> FakeWorld:
    """Robots faster than 0.085 m/s (about one in six) blow up from 40 s of age: after their
    first fitness samples, some before selection kills them."""
    return FakeWorld(config, seed, blow_ups=True, blow_up_speed=0.085, blow_up_age=40.0)


def fake_world_with_blow_ups_at_huge_fitness(config: ExperimentConfig, seed: int) -> FakeWorld:
    """As :func:`fake_world_with_blow_ups`, but a robot that blows up is reported at 1e9 m."""
    return FakeWorld(config, seed, blow_ups=True, blow_up_fitness=1e9)


def finite_mean(values: list[float | None]) -> float:
    xs = [v for v in values if v is not None and math.isfinite(v)]
    return sum(xs) / len(xs)


SMALL_ROBOTS = EvolutionConfig(initial_parts_mean=5.0, initial_parts_sd=2.0, max_parts=12)
"""Smaller robots: the operators' geometry checks dominate the engine's own cost in tests."""


def small(config: ExperimentConfig) -> ExperimentConfig:
    """The same experiment with smaller robots (faster tests, same rules)."""
    return config.replace(evolution=SMALL_ROBOTS)


# -- infancy learning without physics --------------------------------------------------------------

def param_distance_fitness(task: EvalTask) -> EvalOutcome:
    """Candidate fitness for learners: 10 minus the normalised distance of the controller
    parameters to the middle of their ranges (a smooth optimum every robot can approach)."""
    robot = task.robot
    bounds = param_bounds(robot)
    span = np.where(bounds[:, 1] > bounds[:, 0], bounds[:, 1] - bounds[:, 0], 1.0)
    d = (get_params(robot) - bounds.mean(axis=1)) / span
    return EvalOutcome(10.0 - float(np.linalg.norm(d)))


def fake_evaluate_after_infancy(task: EvalTask) -> EvalOutcome:
    """The engine's Training Center call (``task.infancy``), then :func:`fake_evaluate` of the
    robot that lives on."""
    return evaluate_after_infancy(task, fake_evaluate)


class CtrlCEvaluator:
    """An in-process evaluator that raises KeyboardInterrupt (Ctrl-C) at its n-th evaluation.

    ``function`` evaluates each task (the fake physics by default; pass
    ``evolution.evaluation.pool.evaluate_task`` for the real one, Training Center included).
    """

    workers = 1

    def __init__(self, n: int, function: Callable[[EvalTask], EvalOutcome] = fake_evaluate) -> None:
        self.left = n
        self.function = function

    def evaluate(self, tasks: list[EvalTask]) -> list[EvalOutcome]:
        out = []
        for task in tasks:
            self.left -= 1
            if self.left == 0:
                raise KeyboardInterrupt
            out.append(self.function(task))
        return out

    def run_jobs(self, fn: Any, jobs: list[Any], on_event: Any = None) -> list[Any]:
        return [fn(job, self, on_event or (lambda e: None)) for job in jobs]

    def close(self) -> None:
        pass


class PickyWorld(FakeWorld):
    """A fake world whose engine cannot build every third robot it is given."""

    def add(self, robot: Robot, robot_id: int, policy: Any = None) -> Birth:
        self.offered = getattr(self, "offered", 0) + 1
        if self.offered % 3 == 0:
            raise ValueError("MuJoCo cannot build this robot: fake refusal")
        return super().add(robot, robot_id, policy)


def picky_world(config: ExperimentConfig, seed: int) -> FakeWorld:
    return PickyWorld(config, seed)


# -- comparing and interrupting runs -----------------------------------------------------------

RESULT_TABLES = ("runs", "checkpoints", "robots", "fitness", "transitions", "population",
                 "diversity", "failures", "learning")
"""The tables of a results database that a resumed run must reproduce."""


def dump_results(db: Path, tables: tuple[str, ...] = RESULT_TABLES
                 ) -> dict[str, list[tuple[Any, ...]]]:
    """Every row of ``tables`` (default: every results table), in a canonical order."""
    con = sqlite3.connect(db)
    try:
        return {t: sorted(con.execute(f"SELECT * FROM {t}").fetchall(), key=repr)
                for t in tables}
    finally:
        con.close()


class Kill(Exception):
    """Stands for a kill of the process: raised from a progress callback."""


def kill_after(births: int) -> Callable[[ProgressEvent], None]:
    """A progress callback that stops a run at its first commit point with ``births`` births
    (replayed commit points do not count)."""
    def progress(event: ProgressEvent) -> None:
        if event.births >= births and not event.replaying:
            raise Kill(f"killed at {event.births} births")
    return progress


def tiny_run(name: str, **changes: Any) -> ExperimentConfig:
    """Shipped config ``name`` shrunk to seconds of real physics: 6 births, 1 s windows.

    Robots of the shipped size (small ones barely move in 1 s, so neither heading, noise, task
    nor terrain would show); ``scenario3`` also gets a small online world. ``changes`` override
    any key, tables (``world``, ``evaluation``, ``task``) merged as ``--set`` would.
    """
    values: dict[str, Any] = dict(
        runs=1, births=6, population_size=3, offspring_size=3, insertion=0.5,
        evaluation_time=1.0, fertile_age=1.5, diversity_interval=0, workers=1)
    if name == "scenario3":
        values.update(min_alive=2, max_alive=5, conception_interval=1.0, checkpoint_interval=2)
    values.update(changes)
    return load_config(name, values)

