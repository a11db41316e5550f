"""Experiment configuration and the Python API: ``run(config, out_dir)`` and ``resume(out_dir)``.

One engine runs every scenario; a scenario is an :class:`ExperimentConfig`:

============ ======= ==================== ================ ===================
preset        engine  population/offspring new robots       survivor selection
============ ======= ==================== ================ ===================
scenario1     offline 15 + 15              reproduction     fitness (15 fittest)
scenario2     offline 15 + 1               reproduction     fitness
scenario3     online  15 at start, 8..30   reproduction     online rule
baseline_a    offline 15 + 15              random robots    fitness
baseline_b    offline 15 + 15              reproduction     random
quick         offline 15 + 15, 150 births  reproduction     fitness
============ ======= ==================== ================ ===================

The baselines run on the offline (15+15) engine by default: it is the cheapest setup (isolated
evaluations parallelise over all cores) and directly comparable to scenario 1, which is what the
paper's sanity check needs. Set ``engine = "online"`` to run a baseline in the online world
instead (random survivor selection then kills as many robots as the online rule would, chosen
uniformly).
"""

from __future__ import annotations

import dataclasses
import math
import os
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from evolution.config import EvolutionConfig

__all__ = [
    "PRESETS",
    "ConfigError",
    "ExperimentConfig",
    "ExperimentSummary",
    "ProgressCallback",
    "preset",
    "resume",
    "run",
]


class ConfigError(ValueError):
    """An experiment configuration that cannot be run (unknown key, value out of range, ...)."""


_CHOICES: dict[str, tuple[str, ...]] = {
    "engine": ("offline", "online"),
    "new_robots": ("reproduction", "random"),
    "survivor_selection": ("fitness", "random"),
    "evaluator": ("local", "ray"),
}


@dataclass(frozen=True, slots=True)
class ExperimentConfig:
    """Everything an experiment needs; frozen, JSON/TOML round-trippable.

    Attributes:
        name: Free-form experiment name (goes into the results).
        engine: ``"offline"`` (isolated evaluations, generations) or ``"online"`` (one world).
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
        birth_clearance: Online: minimum distance from a newborn to another robot. Metres.
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
        learning: The ``[learning]`` table (:mod:`evolution.learning.config`): infancy learning
            in a Training Center that :func:`run` and :func:`resume` build from it; ``None``: no
            learning. Stored with the results, so a resumed run learns the same way.
    """

    name: str = "custom"
    engine: str = "offline"
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
    birth_clearance: float = 0.5
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
        floats = {
            "insertion": (0.0, False), "evaluation_time": (0.0, True), "fertile_age": (0.0, False),
            "conception_interval": (0.0, True), "birth_radius": (0.0, False),
            "birth_clearance": (0.0, False), "death_threshold": (0.0, False),
            "cull_fraction": (0.0, True),
        }
        for key, (bound, strict) in floats.items():
            value = getattr(self, key)
            if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
                raise ConfigError(f"{key} must be a finite number, got {value!r}")
            if value < bound or (strict and value == bound):
                raise ConfigError(f"{key} must be {'>' if strict else '>='} {bound}, got {value}")
        for key in ("death_threshold", "cull_fraction"):
            if getattr(self, key) > 1:
                raise ConfigError(f"{key} must be <= 1, got {getattr(self, key)}")
        if self.max_sim_time is not None and not (
            isinstance(self.max_sim_time, (int, float)) and self.max_sim_time > 0
            and math.isfinite(self.max_sim_time)
        ):
            raise ConfigError(f"max_sim_time must be a positive number of seconds, got {self.max_sim_time!r}")
        if self.fertile_age < self.insertion:
            raise ConfigError(
                f"fertile_age ({self.fertile_age} s) must be >= insertion ({self.insertion} s)"
            )
        if self.engine == "offline" and self.fertile_age > self.insertion + self.evaluation_time:
            raise ConfigError(
                "offline robots are mature once evaluated: fertile_age must be <= insertion + "
                f"evaluation_time ({self.insertion + self.evaluation_time} s), got {self.fertile_age}"
            )
        if self.min_alive > self.max_alive:
            raise ConfigError(f"min_alive ({self.min_alive}) must be <= max_alive ({self.max_alive})")
        if self.engine == "online" and not self.min_alive <= self.population_size <= self.max_alive:
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
        if not isinstance(self.evolution, EvolutionConfig):
            raise ConfigError(f"evolution must be an EvolutionConfig, got {type(self.evolution).__name__}")
        if not isinstance(self.name, str) or not self.name:
            raise ConfigError(f"name must be a non-empty string, got {self.name!r}")
        if self.learning is not None:
            if not isinstance(self.learning, Mapping):
                raise ConfigError(f"learning must be a table of parameters, got {self.learning!r}")
            # A JSON-plain copy: detached from the caller's mapping, equal to its stored form.
            object.__setattr__(self, "learning", _json_roundtrip(dict(self.learning)))
            self.training_center()  # validates the table

    # -- conversions -----------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """Plain data (JSON/TOML-compatible; ``max_sim_time``/``ray_address`` omitted when None)."""
        data: dict[str, Any] = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "evolution":
                value = {g.name: getattr(value, g.name) for g in fields(value)}
            elif f.name == "learning" and value is not None:
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
        data = dict(data)
        base: dict[str, Any] = {}
        if "preset" in data:
            name = data.pop("preset")
            base = preset(name).to_dict()
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ConfigError(
                f"unknown experiment config key(s): {', '.join(unknown)}; known keys: "
                f"{', '.join(sorted(known | {'preset'}))}"
            )
        evolution = dict(base.pop("evolution", {}))
        evolution_data = data.pop("evolution", {})
        if not isinstance(evolution_data, Mapping):
            raise ConfigError(f"evolution must be a table of parameters, got {evolution_data!r}")
        evolution.update(evolution_data)
        evolution_known = {f.name for f in fields(EvolutionConfig)}
        unknown = sorted(set(evolution) - evolution_known)
        if unknown:
            raise ConfigError(
                f"unknown evolution config key(s): {', '.join(unknown)}; known keys: "
                f"{', '.join(sorted(evolution_known))}"
            )
        try:
            evolution_config = EvolutionConfig(**evolution)
        except (TypeError, ValueError) as error:
            raise ConfigError(f"evolution: {error}") from error
        merged = {**base, **data}
        # TOML has no integers-as-floats distinction problem, but accept 12 for 12.0.
        try:
            return cls(**merged, evolution=evolution_config)
        except TypeError as error:
            raise ConfigError(str(error)) from error

    @classmethod
    def from_toml(cls, path: str | os.PathLike[str]) -> ExperimentConfig:
        """Read a TOML file (top-level keys as in :meth:`from_dict`, ``[evolution]`` table).

        Raises:
            ConfigError: unreadable or invalid TOML, or an invalid configuration (with the path).
        """
        path = Path(path)
        try:
            with open(path, "rb") as f:
                data = tomllib.load(f)
        except OSError as error:
            raise ConfigError(f"cannot read experiment config {path}: {error}") from error
        except tomllib.TOMLDecodeError as error:
            raise ConfigError(f"{path} is not valid TOML: {error}") from error
        try:
            return cls.from_dict(data)
        except ConfigError as error:
            raise ConfigError(f"{path}: {error}") from error

    def replace(self, **changes: Any) -> ExperimentConfig:
        """A copy with some fields changed (validated)."""
        return dataclasses.replace(self, **changes)

    def training_center(self) -> Any:
        """The :class:`~evolution.learning.TrainingCenter` of :attr:`learning` (``None`` without).

        Raises:
            ConfigError: the learning table is invalid (unknown learner or key, bad value).
        """
        if self.learning is None:
            return None
        from evolution.learning.config import training_center_from_dict

        try:
            return training_center_from_dict(self.learning)
        except (TypeError, ValueError) as error:
            raise ConfigError(f"learning: {error}") from error

    @property
    def seconds_per_evaluation(self) -> float:
        """Simulated seconds of one offline evaluation (insertion + window)."""
        return self.insertion + self.evaluation_time


def _scenario1() -> ExperimentConfig:
    return ExperimentConfig(name="scenario1")


PRESETS: dict[str, Callable[[], ExperimentConfig]] = {
    "scenario1": _scenario1,
    "scenario2": lambda: ExperimentConfig(name="scenario2", offspring_size=1),
    "scenario3": lambda: ExperimentConfig(name="scenario3", engine="online"),
    "baseline_a": lambda: ExperimentConfig(name="baseline_a", new_robots="random"),
    "baseline_b": lambda: ExperimentConfig(name="baseline_b", survivor_selection="random"),
    "quick": lambda: ExperimentConfig(name="quick", births=150),
}
"""Named configurations: the paper's five experiments and a quick one."""


def preset(name: str, **overrides: Any) -> ExperimentConfig:
    """A named preset, optionally with some fields changed.

    Raises:
        ConfigError: unknown preset name (the known ones are listed) or invalid overrides.
    """
    if name not in PRESETS:
        raise ConfigError(f"unknown scenario {name!r}; known: {', '.join(PRESETS)}")
    config = PRESETS[name]()
    if overrides:
        known = {f.name for f in fields(ExperimentConfig)}
        unknown = sorted(set(overrides) - known)
        if unknown:
            raise ConfigError(f"unknown experiment config key(s): {', '.join(unknown)}")
        config = config.replace(**overrides)
    return config


# --------------------------------------------------------------------------------------------
# Python API


@dataclass(frozen=True, slots=True)
class ExperimentSummary:
    """How an experiment's runs ended.

    Attributes:
        out_dir: The results directory.
        db_path: Its database.
        runs: One summary per run executed by this call, by run id.
    """

    out_dir: Path
    db_path: Path
    runs: tuple[Any, ...]


ProgressCallback = Callable[[Any], None]
"""Receives :class:`evolution.engine.ProgressEvent` after every commit point of every run."""


def run(
    config: ExperimentConfig | str | Mapping[str, Any],
    out_dir: str | os.PathLike[str],
    progress: ProgressCallback | None = None,
    *,
    evaluator: Any = None,
    world_factory: Callable[..., Any] | None = None,
    infancy: Callable[..., Any] | None = None,
) -> ExperimentSummary:
    """Run an experiment, writing its results to ``out_dir/results.sqlite``.

    Args:
        config: An :class:`ExperimentConfig`, a preset name (``"scenario1"``, ...), or a dict.
        out_dir: Results directory; created if missing. It must not already hold results.
        progress: Called with a :class:`~evolution.engine.ProgressEvent` after every commit
            point (raising from it stops the run after that commit point; ``resume`` continues).
        evaluator: An :mod:`evolution.evaluators` evaluator; default from ``config.evaluator``
            and ``config.workers`` (closed at the end only if made here).
        world_factory: Makes the online world of a run (default: the population environment).
        infancy: The Training Center: an infancy hook, usually a
            :class:`~evolution.learning.TrainingCenter` (both engines; see
            :mod:`evolution.engine` for when it runs, how learning is recorded and what
            Lamarckian inheritance changes). Default: the one ``config.learning`` describes
            (stored with the results; :func:`resume` rebuilds it). A hook given here without
            ``config.learning`` is not stored: pass the same one to :func:`resume`.

    Returns:
        The summary of every run.

    Raises:
        ConfigError: invalid configuration, or an ``infancy`` other than the Training Center
            of ``config.learning``.
        ValueError: an infancy hook the engine cannot honour
            (:func:`evolution.engine.check_infancy`).
        StoreError: ``out_dir`` already holds results (of this or another experiment).
        KeyboardInterrupt: Ctrl-C; what finished is committed, ``resume(out_dir)`` continues.
    """
    from evolution.engine import check_infancy
    from evolution.store import DB_NAME, Store, StoreError

    config = _as_config(config)
    infancy = _infancy_for(config, infancy)
    check_infancy(infancy)
    out = Path(out_dir)
    db_path = out / DB_NAME
    if db_path.exists():
        try:
            with Store.open(db_path) as existing:
                same = existing.config == _json_roundtrip(config.to_dict())
                name = existing.config.get("name", "?")
        except StoreError as error:
            raise StoreError(f"{out} already holds a results database that cannot be used: {error}") from error
        if same:
            raise StoreError(
                f"{out} already holds results of this experiment; use resume({str(out)!r}) to "
                "continue it, or choose another directory"
            )
        raise StoreError(
            f"{out} holds results of another experiment ({name!r}); refusing to overwrite them, "
            "choose another directory"
        )
    if out.exists() and not out.is_dir():
        raise StoreError(f"{out} exists and is not a directory")
    Store.create(db_path, config.to_dict(), config.seed).close()
    return _execute(config, db_path, progress, evaluator, world_factory, infancy)


def resume(
    out_dir: str | os.PathLike[str],
    progress: ProgressCallback | None = None,
    *,
    evaluator: Any = None,
    world_factory: Callable[..., Any] | None = None,
    infancy: Callable[..., Any] | None = None,
) -> ExperimentSummary:
    """Continue an interrupted experiment to the result an uninterrupted one would have given.

    Finished runs are left alone; the others continue from their last commit point. With a
    stored ``learning`` table the Training Center is rebuilt from it (``infancy`` may be given
    only if it is the same one).

    Raises:
        StoreError: no usable results database in ``out_dir`` (missing, corrupt, newer schema).
        ConfigError: the stored configuration is not valid for this package version, or
            ``infancy`` differs from the stored learning table's Training Center.
    """
    from evolution.engine import check_infancy
    from evolution.store import DB_NAME, Store

    check_infancy(infancy)
    db_path = Path(out_dir) / DB_NAME
    with Store.open(db_path) as store:
        config = ExperimentConfig.from_dict(store.config)
    infancy = _infancy_for(config, infancy)
    check_infancy(infancy)
    return _execute(config, db_path, progress, evaluator, world_factory, infancy)


def _execute(
    config: ExperimentConfig,
    db_path: Path,
    progress: ProgressCallback | None,
    evaluator: Any,
    world_factory: Callable[..., Any] | None,
    infancy: Callable[..., Any] | None,
) -> ExperimentSummary:
    from evolution.engine import RunJob, execute_run, run_seed
    from evolution.evaluators import make_evaluator
    from evolution.store import Store

    with Store.open(db_path) as store:
        # Registering is idempotent, so a run killed before all its runs were registered
        # resumes with every one of them.
        for run_id in range(config.runs):
            store.add_run(run_id, run_seed(config.seed, run_id))
        pending = [r.run_id for r in store.runs() if r.status != "finished"]
    jobs = [RunJob(str(db_path), run_id, config, world_factory, infancy) for run_id in pending]
    own = evaluator is None
    if own:
        evaluator = make_evaluator(config.evaluator, config.workers, config.ray_address)
    try:
        summaries = evaluator.run_jobs(execute_run, jobs, progress)
    finally:
        if own:
            evaluator.close()
    return ExperimentSummary(db_path.parent, db_path, tuple(summaries))


def _infancy_for(config: ExperimentConfig, infancy: Callable[..., Any] | None) -> Any:
    """The infancy hook of a run: ``config.learning``'s Training Center, or ``infancy``.

    Raises:
        ConfigError: both are given and differ (which one would the stored results describe?).
    """
    center = config.training_center()
    if center is None:
        return infancy
    if infancy is not None and infancy != center:
        raise ConfigError(
            "the config has a learning table and infancy= gives another Training Center; give "
            "one of them (the learning table is stored with the results, infancy= is not)"
        )
    return center


def _as_config(config: ExperimentConfig | str | Mapping[str, Any]) -> ExperimentConfig:
    if isinstance(config, ExperimentConfig):
        return config
    if isinstance(config, str):
        return preset(config)
    if isinstance(config, Mapping):
        return ExperimentConfig.from_dict(config)
    raise ConfigError(f"config must be an ExperimentConfig, a preset name or a dict, got {config!r}")


def _json_roundtrip(data: dict[str, Any]) -> dict[str, Any]:
    import json

    return json.loads(json.dumps(data, sort_keys=True))
