"""Experiment configuration: :class:`ExperimentConfig`, and shipped configs by name.

One evolution loop runs every scenario; a scenario is an :class:`ExperimentConfig`. The shipped ones
(:mod:`~evolution.experiments.loop.registry`; 30 runs each unless named otherwise):

============ ======= ==================== ================ ===================
name          mode    population/offspring new robots       survivor selection
============ ======= ==================== ================ ===================
scenario1     offline 15 + 15              reproduction     fitness (15 fittest)
scenario2     offline 15 + 1               reproduction     fitness
scenario3     online  15 at start, 8..30   reproduction     online rule
baseline_a    offline 15 + 15              random robots    fitness
baseline_b    offline 15 + 15              reproduction     random
quick         offline 15 + 15, 150 births  reproduction     fitness (1 run)
============ ======= ==================== ================ ===================

The baselines run offline (15+15) by default: it is the cheapest setup (isolated
evaluations parallelise over all cores) and directly comparable to scenario 1, which is what the
paper's sanity check needs. Set ``mode = "online"`` to run a baseline in the online world
instead (random survivor selection then kills as many robots as the online rule would, chosen
uniformly).

``mode`` is the switch between offline and online evolution; ``engine`` names only the physics
engine (``[world] engine = "pybullet" | "mujoco"``). Before, the top-level switch was called
``engine`` too: a config (TOML file, dict, ``--set engine=online``) that still uses that name is
read as ``mode`` with a one-line warning saying to rename it (:func:`renamed_keys`); results
databases store the new name (their stored configs are upgraded in place when opened, schema
version 5).

The ``[evaluation]`` table (:class:`~revolve_env.conditions.EvaluationConditions`) gives the
conditions of every evaluation of a run, offline (each robot's isolated evaluation, seeded by
:func:`~evolution.evaluation.evaluation_seed`) and online (every newborn in the population env,
seeded from the run's world seed)::

    [evaluation]
    heading = "random"       # radians, or "random" (uniform in [0, 2 pi))
    position_jitter = 0.0    # start drawn from a disc of this radius, metres
    sensor_noise = 0.0       # std of Gaussian noise on every sensor value
    actuator_noise = 0.0     # std of Gaussian noise on every normalised hinge target

The default is a random heading and no noise: online newborns face random headings, so offline
robots do too, and the two modes' fitness are comparable (the fitness ``v + 5 s`` itself does
not depend on the heading, but a robot's gait meets the world in another direction). Override
on the command line with ``--set evaluation.heading=0``.

The ``[task]`` table (:mod:`revolve_env.tasks`) says what robots are scored on, offline and
online, and what infants learn (the paper's ``f = v + 5 s``, ``locomotion``, without one)::

    [task]
    name = "directed-locomotion"   # a shipped task, or "package.module:ClassName" of your own
    heading = 1.57                 # its parameters, radians here

Every task takes ``pose_rate``, how often the core's pose is sampled for the fitness (samples
per second, or ``"every-period"``: :mod:`revolve_env.fitness.sampling`), and ``locomotion`` the
paper's instability guard ``limit`` (metres per second over the window: 1.0 zeroes ``f >= 12
m`` over 12 s)::

    [task]
    name = "locomotion"
    pose_rate = 5                  # Hz, the paper's; "every-period" samples each control period
    limit = 1.0                    # the paper's --fitness-limit; off without it

(on the command line ``--set task.name=locomotion --set task.pose_rate=60``).
It is stored with the results, so ``resume`` and ``reevaluate`` score with the same task. A
class of your own is imported (from your Python path: a results folder carries no code) when a
run starts; resuming or re-evaluating a stored one imports it only when the user trusts the folder
(``trust_task_code``, :func:`~evolution.experiments.app.api.check_task_code`); opening a stored
configuration to read or report it never imports a module.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import revolve_env
from evolution.config import EvolutionConfig
from evolution.experiments.loop.errors import ConfigError
from evolution.experiments.loop.registry import read_toml, shipped_config, shipped_configs
from evolution.learning import TrainingCenter, training_center_from_dict
from revolve_env.conditions import MAX_RADIUS, EvaluationConditions
from revolve_env.fitness.sampling import pose_stride
from revolve_env.setting import DEFAULT_ENGINE, Setting
from revolve_env.tasks import (
    TASKS,
    Locomotion,
    Task,
    TaskError,
    check_task_name,
    pose_rate,
    task_from_dict,
)
from revolve_env.terrain import (
    Flat,
    Heightfield,
    Terrain,
    TerrainError,
    make_terrain,
    terrain_table,
)

__all__ = ["DEFAULT_EVALUATION", "MAX_BIRTHS", "MAX_RADIUS", "MAX_SECONDS", "MAX_WORKERS",
           "ConfigError", "ExperimentConfig", "WorldSettings", "as_config", "check_name",
           "load_config", "preset", "renamed_keys"]

_log = logging.getLogger(__name__)

# Upper bounds: a value beyond them cannot be what a researcher meant, and would hang the
# machine (a billion births, a million worker processes) or break the physics (MuJoCo aborts on
# a robot placed 1e30 m away) long after the command started.
MAX_SECONDS = 3600.0
"""Longest insertion, evaluation, fertile age or conception interval: a simulated hour (the
paper's are 3, 12, 15 and 15 s). Seconds."""
MAX_BIRTHS = 10_000_000
"""Most births of a run (the paper's: 3000)."""
MAX_WORKERS = 1024
"""Most worker processes (0 means all cores)."""
_MAX_INTS = {"population_size": 10_000, "offspring_size": 10_000, "tournament_size": 10_000,
             "births": MAX_BIRTHS, "min_alive": 1000, "max_alive": 1000,
             "max_conception_attempts": 10_000, "diversity_interval": MAX_BIRTHS,
             "checkpoint_interval": MAX_BIRTHS, "runs": 10_000, "seed": 2**63 - 1,
             "workers": MAX_WORKERS}
"""Upper bound of each integer key (``seed``: what SQLite's integers hold)."""


def check_name(name: object, what: str = "name") -> str:
    """``name`` if it can name a results folder: printable text, no path.

    Raises:
        ConfigError: not text, empty, longer than 100 characters, a control character, a
            slash or backslash, or ``.`` / ``..``.
    """
    if not isinstance(name, str) or not name:
        raise ConfigError(f"{what} must be a non-empty string, got {name!r}")
    if (len(name) > 100 or not name.isprintable() or "/" in name or "\\" in name
            or name in (".", "..")):
        raise ConfigError(f"{what} {name!r} cannot name a folder: give at most 100 printable "
                          "characters without / or \\ (not . or ..)")
    return name

_NESTED = ("evaluation", "evolution", "learning", "task", "world")
"""Config keys that are tables, merged key by key by presets and overrides."""


@dataclass(frozen=True, slots=True)
class WorldSettings:
    """The ``[world]`` table: the physics every evaluation and online world of a run uses.

    Attributes:
        engine: The physics engine: ``"mujoco"`` (the default,
            :data:`revolve_env.setting.DEFAULT_ENGINE`) or ``"pybullet"``
            (:data:`revolve_env.ENGINES`). Stored with the results, so ``resume``
            and ``report`` know it; the engine's package must import when the run starts.
        terrain: The ground (:mod:`revolve_env.terrain`): ``"flat"`` (the default), or a
            terrain's name or table, ``terrain = "rugged"`` or ``[world.terrain]`` with
            ``name = "rugged"`` and its parameters (``height = 0.03``, ``seed = 2``, ...). A
            non-flat terrain is kept as its full table (every parameter, defaults included), so
            the stored run names its ground exactly; a flat one is not stored at all (configs of
            runs on the plane are as before).
    """

    engine: str = DEFAULT_ENGINE
    terrain: str | Mapping[str, Any] = "flat"

    def __post_init__(self) -> None:
        engines: tuple[str, ...] = revolve_env.ENGINES
        if self.engine not in engines:
            raise ConfigError(f"world.engine must be one of {', '.join(map(repr, engines))}, "
                              f"got {self.engine!r}")
        try:
            spec = make_terrain(self.terrain)
        except TerrainError as error:
            raise ConfigError(f"world.terrain: {error}") from None
        object.__setattr__(self, "terrain", "flat" if isinstance(spec, Flat)
                           else terrain_table(spec))

    @property
    def terrain_spec(self) -> Terrain:
        """The terrain as a spec (:func:`revolve_env.terrain.make_terrain`)."""
        return make_terrain(self.terrain)


DEFAULT_EVALUATION = EvaluationConditions(heading="random")
"""The conditions of an experiment without an ``[evaluation]`` table: random heading, no noise
(offline as online; the module docstring says why)."""

_CHOICES: dict[str, tuple[str, ...]] = {
    "mode": ("offline", "online"),
    "new_robots": ("reproduction", "random"),
    "survivor_selection": ("fitness", "random"),
    "evaluator": ("local", "ray"),
}


@dataclass(frozen=True, slots=True)
class ExperimentConfig:
    """Everything an experiment needs; frozen, JSON/TOML round-trippable.

    Attributes:
        name: Free-form experiment name (goes into the results).
        mode: ``"offline"`` (isolated evaluations, generations) or ``"online"`` (one world).
            Formerly ``engine`` (still read, with a warning: :func:`renamed_keys`).
        population_size: Offline: the constant population (mu). Online: robots at the start.
        offspring_size: Offline: children per generation (lambda); ignored online.
        new_robots: ``"reproduction"`` (two tournament parents) or ``"random"`` (Baseline A).
        survivor_selection: ``"fitness"`` or ``"random"`` (Baseline B).
        tournament_size: Parent selection tournament size.
        births: Stop after this many births (the initial population counts).
        max_sim_time: Also stop at this simulated time; ``None``: no limit. Seconds.
        insertion: Delivery stage: the robot settles before it is evaluated. Seconds.
        evaluation_time: Fitness window (offline evaluation length after insertion). Seconds.
        fertile_age: Age at which a robot is mature. Seconds.
        conception_interval: Online: a robot is conceived every this many seconds.
        birth_radius: Online: newborns appear within this distance of the origin. Metres.
        birth_clearance: Online: gap kept between a newborn's footprint and every living
            robot's (:mod:`revolve_env.envs.placement`, the population env's rule). Metres.
        min_alive: Online: survivor selection never goes below this many robots.
        max_alive: Online: at this many robots the least fit are culled.
        death_threshold: Online: robots below this fraction of the mean fitness die.
        cull_fraction: Online: fraction killed when ``max_alive`` is reached.
        max_conception_attempts: Parent pairs tried when crossover gives no child; after that a
            random robot is conceived and the failure recorded.
        diversity_interval: Diversity is computed every this many births (0: never).
        checkpoint_interval: Online: commit (and allow resume) every this many births.
        runs: Independent repeats.
        seed: Experiment seed; run ``i`` uses ``SeedSequence([seed, i])``.
        workers: Worker processes; 0 means all cores.
        evaluator: ``"local"`` processes or ``"ray"``.
        ray_address: Ray cluster address (``None``: start or join a local one).
        evolution: Random robot and reproduction parameters.
        world: The ``[world]`` table (:class:`WorldSettings`): the physics engine.
        evaluation: The ``[evaluation]`` table: start heading and jitter, sensor and actuator
            noise of every evaluation, offline and online (module docstring;
            :data:`DEFAULT_EVALUATION` by default).
        learning: The ``[learning]`` table (:mod:`evolution.learning.config`): infancy learning
            in a Training Center that :func:`run` and :func:`resume` build from it; ``None``: no
            learning. Stored with the results, so a resumed run learns the same way.
        task: The ``[task]`` table (``{"name": ..., **parameters}``, :mod:`revolve_env.tasks`):
            what every robot is scored on and infants learn (:meth:`fitness_task`); ``None``:
            the paper's :class:`~revolve_env.tasks.Locomotion`. Stored with the results.
    """

    name: str = "custom"
    mode: str = "offline"
    population_size: int = 15
    offspring_size: int = 15
    new_robots: str = "reproduction"
    survivor_selection: str = "fitness"
    tournament_size: int = 4
    births: int = 3000
    max_sim_time: float | None = None
    insertion: float = 3.0
    evaluation_time: float = 12.0
    fertile_age: float = 15.0
    conception_interval: float = 15.0
    birth_radius: float = 2.0
    birth_clearance: float = 0.02
    min_alive: int = 8
    max_alive: int = 30
    death_threshold: float = 0.7
    cull_fraction: float = 0.7
    max_conception_attempts: int = 10
    diversity_interval: int = 15
    checkpoint_interval: int = 1
    runs: int = 1
    seed: int = 0
    workers: int = 0
    evaluator: str = "local"
    ray_address: str | None = None
    evolution: EvolutionConfig = field(default_factory=EvolutionConfig)
    learning: Mapping[str, Any] | None = field(default=None, hash=False)
    world: WorldSettings = field(default_factory=WorldSettings)
    evaluation: EvaluationConditions = DEFAULT_EVALUATION
    task: Mapping[str, Any] | None = field(default=None, hash=False)

    def __post_init__(self) -> None:
        for key, choices in _CHOICES.items():
            if getattr(self, key) not in choices:
                raise ConfigError(
                    f"{key} must be one of {', '.join(map(repr, choices))}, "
                    f"got {getattr(self, key)!r}"
                )
        ints = {
            "population_size": 1, "offspring_size": 1, "tournament_size": 1, "births": 1,
            "min_alive": 1, "max_alive": 2, "max_conception_attempts": 1,
            "diversity_interval": 0, "checkpoint_interval": 1, "runs": 1, "seed": 0, "workers": 0,
        }
        for key, low in ints.items():
            value = getattr(self, key)
            if not isinstance(value, int) or isinstance(value, bool):
                raise ConfigError(f"{key} must be an integer, got {value!r}")
            if value < low:
                raise ConfigError(f"{key} must be >= {low}, got {value}")
            if value > _MAX_INTS[key]:
                raise ConfigError(f"{key} must be <= {_MAX_INTS[key]}, got {value}")
        floats = {
            "insertion": (0.0, False), "evaluation_time": (0.0, True), "fertile_age": (0.0, False),
            "conception_interval": (0.0, True), "birth_radius": (0.0, False),
            "birth_clearance": (0.0, False), "death_threshold": (0.0, False),
            "cull_fraction": (0.0, True),
        }
        for key, (bound, strict) in floats.items():
            value = getattr(self, key)
            if not _finite_number(value):
                raise ConfigError(f"{key} must be a finite number, got {value!r}")
            if value < bound or (strict and value == bound):
                raise ConfigError(f"{key} must be {'>' if strict else '>='} {bound}, got {value}")
        for key in ("death_threshold", "cull_fraction"):
            if getattr(self, key) > 1:
                raise ConfigError(f"{key} must be <= 1, got {getattr(self, key)}")
        for key, high, unit in (("insertion", MAX_SECONDS, "s"),
                                ("evaluation_time", MAX_SECONDS, "s"),
                                ("fertile_age", MAX_SECONDS, "s"),
                                ("conception_interval", MAX_SECONDS, "s"),
                                ("birth_radius", MAX_RADIUS, "m"),
                                ("birth_clearance", MAX_RADIUS, "m")):
            if getattr(self, key) > high:
                raise ConfigError(f"{key} must be <= {high:g} {unit}, got {getattr(self, key)}")
        if self.max_sim_time is not None and not (
            _finite_number(self.max_sim_time) and self.max_sim_time > 0
        ):
            raise ConfigError("max_sim_time must be a positive number of seconds, got "
                              f"{self.max_sim_time!r}")
        if self.fertile_age < self.insertion:
            raise ConfigError(
                f"fertile_age ({self.fertile_age} s) must be >= insertion ({self.insertion} s)"
            )
        if self.mode == "offline" and self.fertile_age > self.insertion + self.evaluation_time:
            raise ConfigError(
                "offline robots are mature once evaluated: fertile_age must be <= insertion + "
                f"evaluation_time ({self.insertion + self.evaluation_time} s), "
                f"got {self.fertile_age}"
            )
        if self.min_alive > self.max_alive:
            raise ConfigError(
                f"min_alive ({self.min_alive}) must be <= max_alive ({self.max_alive})")
        if self.mode == "online" and not self.min_alive <= self.population_size <= self.max_alive:
            raise ConfigError(
                f"online population_size ({self.population_size}) must lie within "
                f"[min_alive, max_alive] = [{self.min_alive}, {self.max_alive}]"
            )
        if self.new_robots == "reproduction" and self.population_size < 2:
            raise ConfigError("reproduction needs population_size >= 2")
        if self.births < self.population_size:
            raise ConfigError(
                f"births ({self.births}) must be >= population_size ({self.population_size}): "
                "the initial robots count as births"
            )
        if self.ray_address is not None and not isinstance(self.ray_address, str):
            raise ConfigError(f"ray_address must be a string, got {self.ray_address!r}")
        _check_tables(self)
        check_name(self.name)
        terrain = self.world.terrain_spec
        if isinstance(terrain, Heightfield):  # every robot must start on it
            try:
                terrain.check_disc(self.birth_radius if self.mode == "online"
                                   else self.evaluation.position_jitter,
                                   "the birth disc: birth_radius" if self.mode == "online"
                                   else "the start disc: evaluation.position_jitter")
            except TerrainError as error:
                raise ConfigError(f"world.terrain: {error}") from None
        if self.mode == "online" and not revolve_env.engine(self.world.engine).shared_world:
            shared = [e for e in revolve_env.ENGINES if revolve_env.engine(e).shared_world]
            raise ConfigError(
                f"world.engine {self.world.engine!r} steps isolated worlds only (its capability "
                f"shared_world is False): an online run needs one world of every robot "
                f"({', '.join(shared)}); offline runs evaluate on it")
        physics = revolve_env.with_engine(revolve_env.WorldConfig(), self.world.engine)
        period = physics.control_period
        if self.evaluation_time < period:
            raise ConfigError(f"evaluation_time must cover one control period ({period:.6g} s "
                              f"on {self.world.engine}), got {self.evaluation_time}")
        if self.learning is not None:
            if not isinstance(self.learning, Mapping):
                raise ConfigError(f"learning must be a table of parameters, got {self.learning!r}")
            # A JSON-plain copy: detached from the caller's mapping, equal to its stored form.
            object.__setattr__(self, "learning", _json_roundtrip(dict(self.learning)))
            self._training_center(None)  # validates the table
        if self.task is not None:
            if not isinstance(self.task, Mapping):
                raise ConfigError(f"task must be a table with a name, got {self.task!r}")
            object.__setattr__(self, "task", _json_roundtrip(dict(self.task)))
            # A shipped task is built (its parameters checked) now; a class of the user's own
            # only when a run uses it (fitness_task): reading a stored config imports nothing.
            if self.task.get("name") in TASKS or not isinstance(self.task.get("name"), str):
                task = self.fitness_task(allow_import=False)
                try:
                    pose_stride(pose_rate(task), period)
                except (TaskError, ValueError) as error:
                    raise ConfigError(f"task: {error}") from None
            else:
                try:
                    check_task_name(self.task["name"])
                except TaskError as error:
                    raise ConfigError(f"task: {error}") from None

    # -- conversions -----------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """Plain data (JSON/TOML-compatible; ``max_sim_time``/``ray_address`` omitted when None)."""
        data: dict[str, Any] = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "evaluation":  # reset_noise_scale only when set: as stored before it
                value = value.to_dict()
            elif f.name in ("evolution", "world"):
                value = {g.name: getattr(value, g.name) for g in fields(value)}
                if f.name == "world" and value["terrain"] == "flat":
                    del value["terrain"]  # the plane: the stored config as before terrains
            elif f.name in ("learning", "task") and value is not None:
                value = _json_roundtrip(dict(value))
            if value is not None:
                data[f.name] = value
        return data

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ExperimentConfig:
        """Build from plain data; a ``preset`` key starts from that preset.

        Raises:
            ConfigError: unknown key (named), unknown preset, or a value out of range.
        """
        data = renamed_keys(data)
        base: dict[str, Any] = {}
        if "preset" in data:
            name = data.pop("preset")
            if not isinstance(name, str):
                raise ConfigError(f"preset must be the name of a shipped config, got {name!r}")
            base = cls.from_toml(shipped_config(name)).to_dict()
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ConfigError(
                f"unknown experiment config key(s): {', '.join(unknown)}; known keys: "
                f"{', '.join(sorted(known | {'preset'}))}"
            )
        evolution = _table("evolution", base, data, EvolutionConfig)
        try:
            evolution_config = EvolutionConfig(**evolution)
        except (TypeError, ValueError, ArithmeticError) as error:  # 10**400 -> float: Overflow
            raise ConfigError(f"evolution: {error}") from error
        world_settings = WorldSettings(**_table("world", base, data, WorldSettings))
        # Missing keys take DEFAULT_EVALUATION's values (not the class defaults: IDEAL).
        evaluation = {**DEFAULT_EVALUATION.to_dict(),
                      **_table("evaluation", base, data, EvaluationConditions)}
        try:
            conditions = EvaluationConditions(**evaluation)
        except ValueError as error:  # its messages start with the field's name
            raise ConfigError(f"evaluation.{error}") from error
        merged = {**base, **data}
        try:
            return cls(**merged, evolution=evolution_config, world=world_settings,
                       evaluation=conditions)
        except TypeError as error:
            raise ConfigError(str(error)) from error

    @classmethod
    def from_toml(cls, path: str | os.PathLike[str]) -> ExperimentConfig:
        """Read a TOML file (top-level keys as in :meth:`from_dict`, ``[evolution]`` table).

        Raises:
            ConfigError: unreadable or invalid TOML, or an invalid configuration (with the path).
        """
        path = Path(path)
        data = read_toml(path)
        try:
            return cls.from_dict(data)
        except ConfigError as error:
            raise ConfigError(f"{path}: {error}") from error

    def replace(self, **changes: Any) -> ExperimentConfig:
        """A copy with some fields changed (validated)."""
        return dataclasses.replace(self, **changes)

    def training_center(self) -> TrainingCenter | None:
        """The :class:`~evolution.learning.TrainingCenter` of :attr:`learning` (``None`` without).

        Raises:
            ConfigError: the learning table is invalid (unknown learner or key, bad value).
        """
        return self._training_center(self.fitness_task())

    def _training_center(self, task: Task | None) -> TrainingCenter | None:
        if self.learning is None:
            return None
        try:
            return training_center_from_dict(self.learning, engine=self.world.engine,
                                             conditions=self.evaluation, task=task,
                                             terrain=self.world.terrain_spec)
        except (TypeError, ValueError, ArithmeticError) as error:  # int(inf): OverflowError
            raise ConfigError(f"learning: {error}") from error

    def fitness_task(self, allow_import: bool = True) -> Task:
        """The task of :attr:`task` (:class:`~revolve_env.tasks.Locomotion` without one).

        ``allow_import=False`` resolves the shipped tasks only (a class of the user's own would
        import its module, i.e. run code).

        Raises:
            ConfigError: an unknown task, a module that does not import, a class that does not
                follow the protocol, or parameters it refuses (one line naming it).
        """
        if self.task is None:
            return Locomotion()
        try:
            return task_from_dict(self.task, allow_import=allow_import)
        except TaskError as error:
            raise ConfigError(f"task: {error}") from None

    def setting(self, allow_import: bool = True) -> Setting:
        """Where and how this experiment's robots are simulated, as one record.

        Its ``[world]`` engine and terrain, its task (:meth:`fitness_task`), its
        ``[evaluation]`` conditions, ``insertion`` and ``evaluation_time``
        (:class:`revolve_env.setting.Setting`: what ``evaluate`` and the envs take).

        Raises:
            ConfigError: see :meth:`fitness_task`.
        """
        world = revolve_env.WorldConfig(engine=self.world.engine, terrain=self.world.terrain_spec)
        return Setting(world=world, task=self.fitness_task(allow_import),
                       conditions=self.evaluation, insertion=self.insertion,
                       seconds=self.evaluation_time)

    @property
    def seconds_per_evaluation(self) -> float:
        """Simulated seconds of one offline evaluation (insertion + window)."""
        return self.insertion + self.evaluation_time


def _check_tables(config: ExperimentConfig) -> None:
    """Refuse a nested table of the wrong type (ConfigError naming it)."""
    tables: tuple[tuple[str, type], ...] = (
        ("world", WorldSettings), ("evaluation", EvaluationConditions),
        ("evolution", EvolutionConfig))
    for key, kind in tables:
        value = getattr(config, key)
        if not isinstance(value, kind):
            article = "an" if kind.__name__[0] in "AEIOU" else "a"
            raise ConfigError(f"{key} must be {article} {kind.__name__}, got "
                              f"{type(value).__name__}")


def _table(name: str, base: dict[str, Any], data: dict[str, Any],
           kind: type[EvolutionConfig] | type[WorldSettings] | type[EvaluationConditions],
           ) -> dict[str, Any]:
    """A nested config table: the preset's keys (``base``) updated with ``data``'s, both popped.

    Raises:
        ConfigError: the table is not a table, or holds a key ``kind`` does not have.
    """
    table = dict(base.pop(name, {}))
    given = data.pop(name, {})
    if not isinstance(given, Mapping):
        raise ConfigError(f"{name} must be a table of parameters, got {given!r}")
    table.update(given)
    known = {f.name for f in fields(kind)}
    unknown = sorted(set(table) - known)
    if unknown:
        raise ConfigError(f"unknown {name} config key(s): {', '.join(unknown)}; known keys: "
                          f"{', '.join(sorted(known))}")
    return table


def load_config(name_or_path: str | os.PathLike[str],
                overrides: Mapping[str, Any] | None = None) -> ExperimentConfig:
    """An experiment config from a shipped name or a TOML path, with some keys changed.

    Args:
        name_or_path: A shipped config name (``scenario1``, ..., ``quick``,
            ``scenario1_learning``, ...; :mod:`~evolution.experiments.loop.registry`) or a TOML file
            (with an optional ``[learning]`` table).
        overrides: Config keys to change (``evaluation``, ``evolution``, ``learning`` and
            ``world`` as nested tables, merged key by key into the config's).

    Raises:
        ConfigError: unknown name, unreadable file, unknown key or value out of range.
    """
    path = Path(name_or_path)
    if path.suffix == ".toml" or path.is_file():
        if not path.is_file():
            raise ConfigError(f"no such config file: {path}")
        config = ExperimentConfig.from_toml(path)
    elif str(name_or_path) in shipped_configs():
        config = ExperimentConfig.from_toml(shipped_config(str(name_or_path)))
    else:
        raise ConfigError(
            f"unknown scenario {str(name_or_path)!r}; known: "
            f"{', '.join(sorted(shipped_configs()))} (or give the path of a TOML config file)")
    if not overrides:
        return config
    overrides = renamed_keys(overrides)  # before merging: the override's mode wins the file's
    data = config.to_dict()
    nested = _NESTED
    for table in nested:
        value = overrides.get(table)
        if value is None:
            continue
        if not isinstance(value, Mapping):
            raise ConfigError(f"{table} is a table: set its keys as {table}.KEY=VALUE")
        if table == "learning" and "learning" not in data and "learner" not in value:
            raise ConfigError(
                f"{name_or_path} has no [learning] table: give learning.learner and "
                "learning.budget, or start from a config with one")
        data[table] = {**data.get(table, {}), **value}
    data.update({k: v for k, v in overrides.items() if k not in nested})
    return ExperimentConfig.from_dict(data)


def preset(name: str, **overrides: Any) -> ExperimentConfig:
    """A shipped config (the same file ``revolve run NAME`` reads), some fields changed.

    Raises:
        ConfigError: unknown name (the known ones are listed) or invalid overrides.
    """
    config = ExperimentConfig.from_toml(shipped_config(name))
    if overrides:
        overrides = renamed_keys(overrides)
        known = {f.name for f in fields(ExperimentConfig)}
        unknown = sorted(set(overrides) - known)
        if unknown:
            raise ConfigError(f"unknown experiment config key(s): {', '.join(unknown)}")
        config = config.replace(**overrides)
    return config


def renamed_keys(data: Mapping[str, Any]) -> dict[str, Any]:
    """``data`` (top-level config keys) with the old name of ``mode`` renamed.

    ``engine = "offline" | "online"`` at the top level is what ``mode`` was called before
    ``engine`` came to mean the physics engine only (``[world] engine``). It is still read, as
    ``mode``, with a one-line warning (logged: ``revolve`` prints it) saying to rename it.

    Raises:
        ConfigError: a top-level ``engine`` names a physics engine (it belongs in ``[world]``),
            or it disagrees with a ``mode`` given beside it.
    """
    out = dict(data)
    if "engine" not in out:
        return out
    old = out.pop("engine")
    if isinstance(old, str) and old in revolve_env.ENGINES:
        raise ConfigError(
            f"engine = {old!r} at the top level: the physics engine is set in the [world] table "
            f"(world.engine = {old!r}; on the command line --set world.engine={old}); the "
            "top-level switch between offline and online evolution is mode")
    if "mode" in out and out["mode"] != old:
        raise ConfigError(f"engine = {old!r} (the old name of mode) disagrees with mode = "
                          f"{out['mode']!r}: give mode only")
    out["mode"] = old  # validated with the other keys
    _log.warning("config key engine = %r is the old name of mode: write mode = %r (engine now "
                 "names only the physics engine, world.engine)", old, old)
    return out


def as_config(config: ExperimentConfig | str | os.PathLike[str] | Mapping[str, Any]
              ) -> ExperimentConfig:
    """An :class:`ExperimentConfig` from itself, a shipped name, a TOML path or a dict.

    Raises:
        ConfigError: unknown name, unreadable file, invalid configuration, or another type.
    """
    if isinstance(config, ExperimentConfig):
        return config
    if isinstance(config, (str, os.PathLike)):
        return load_config(config)
    if isinstance(config, Mapping):
        return ExperimentConfig.from_dict(config)
    raise ConfigError(f"config must be an ExperimentConfig, a shipped config name, a TOML "
                      f"path or a dict, got {config!r}")


def _finite_number(value: object) -> bool:
    """Whether ``value`` is a finite int or float.

    A bool is not a number here: ``true`` for a number of seconds is a mistake, not 1 s.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:  # an int beyond any float
        return False


def _json_roundtrip(data: dict[str, Any]) -> dict[str, Any]:
    return dict(json.loads(json.dumps(data, sort_keys=True)))
