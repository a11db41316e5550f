"""What the robot commands (``show``, ``watch``, ``export``) share: their arguments and loading.

A robot is named on the command line as a JSON file, an example name, or a robot of a results
database (``--db DIR --robot ID`` or ``--best``, in ``--run R``); :func:`stored_robot` also
returns what the database says about it (experiment, run seed, record, learning), which is what
``revolve show`` compares its re-simulation with. Bad input raises :class:`CliError` (one line).

The experiments and the robot description are imported by the functions that read a database,
a robot or a bound they set, not with this module: ``revolve --help`` builds its parser without
them (or numpy).
"""

from __future__ import annotations

import argparse
import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from evolution.experiments import ExperimentConfig
    from evolution.experiments.loop.records import LearningRecord, RobotRecord
    from revolve_env.body.robot import Robot

__all__ = [
    "EXIT_INTERRUPTED",
    "CliError",
    "StoredRobot",
    "load_robot",
    "no_db",
    "non_negative_float",
    "non_negative_int",
    "non_negative_seconds",
    "number",
    "positive_float",
    "positive_int",
    "robot_arguments",
    "seconds",
    "stored_robot",
    "trust_argument",
    "workers",
    "writable_folder",
]


EXIT_INTERRUPTED = 130
"""Exit status of a command stopped by Ctrl-C (what it committed is kept)."""


class CliError(ValueError):
    """Bad command-line input (reported on one line, exit status 2)."""


def number(kind: type[int | float], low: float, strict: bool,
           high: float = math.inf) -> Callable[[str], Any]:
    """An argparse type: ``kind`` parsed from text, finite, above ``low``, at most ``high``.

    With ``strict`` false, ``low`` itself is allowed. ``high`` bounds what could hang the
    machine (frames, repeats, workers, seconds).
    """
    noun = "an integer" if kind is int else "a number"

    def parse(text: str) -> int | float:
        try:
            value = kind(text)
        except (ValueError, OverflowError):
            raise argparse.ArgumentTypeError(f"not {noun}: {text!r}") from None
        if not math.isfinite(value) or (value <= low if strict else value < low):
            bound = f"> {low:g}" if strict else f">= {low:g}"
            raise argparse.ArgumentTypeError(f"must be {bound}, got {text}")
        if value > high:
            raise argparse.ArgumentTypeError(f"must be <= {high:g}, got {text}")
        return value

    return parse


positive_int = number(int, 1, strict=False)
non_negative_int = number(int, 0, strict=False)
positive_float = number(float, 0.0, strict=True)
non_negative_float = number(float, 0.0, strict=False)


def workers(text: str) -> int:
    """Worker processes (0: all cores), at most the experiments' ``MAX_WORKERS``."""
    from evolution.experiments.loop.config import MAX_WORKERS

    return int(number(int, 0, strict=False, high=MAX_WORKERS)(text))


def seconds(text: str) -> float:
    """A simulated duration, at most :data:`~evolution.experiments.loop.config.MAX_SECONDS`."""
    from evolution.experiments.loop.config import MAX_SECONDS

    return float(number(float, 0.0, strict=True, high=MAX_SECONDS)(text))


def non_negative_seconds(text: str) -> float:
    """A simulated duration that may be 0, at most ``MAX_SECONDS``."""
    from evolution.experiments.loop.config import MAX_SECONDS

    return float(number(float, 0.0, strict=False, high=MAX_SECONDS)(text))


def trust_argument(parser: argparse.ArgumentParser, pickled: bool = True) -> None:
    """The flags that let a results folder's contents run code, each off by default.

    ``--trust-pickled-policies`` (unless ``pickled`` is false: a command that loads no policy)
    loads SB3 policies that older versions saved as pickles; ``--trust-task-code`` imports the
    module of a task class of the user's own that the stored config names.
    """
    if pickled:
        parser.add_argument("--trust-pickled-policies", action="store_true",
                            help="also load SB3 policies saved as pickles by older versions of "
                                 "revolve-env; unpickling can run any code the file holds, so "
                                 "use it only for a results folder whose author you trust")
    parser.add_argument("--trust-task-code", action="store_true",
                        help="import the module of a task class of your own that the stored "
                             "[task] names (package.module:Class, from your Python path); its "
                             "code runs, so use it only for a results folder whose author you "
                             "trust")


def writable_folder(path: Path, option: str) -> None:
    """Refuse a folder that cannot be made or written, before anything runs.

    Raises:
        CliError: a file is in the way (``path`` or one of its parents), or the nearest
            existing parent cannot be written.
    """
    for place in (path, *path.parents):
        if place.exists():
            if not place.is_dir():
                raise CliError(f"{option} {path}: {place} is a file, not a folder")
            if not os.access(place, os.W_OK | os.X_OK):
                raise CliError(f"{option} {path}: cannot write in {place}")
            return


def robot_arguments(parser: argparse.ArgumentParser) -> None:
    """The arguments naming one robot: ROBOT, or ``--db DIR`` with ``--robot ID``/``--best``."""
    parser.add_argument("robot", nargs="?", metavar="ROBOT",
                        help="robot JSON file, or an example name (spider, gecko, snake, "
                             "sensor_crawler, bar_walker)")
    parser.add_argument("--db", metavar="DIR",
                        help="take the robot from this experiment's results directory instead")
    parser.add_argument("--run", type=non_negative_int,
                        help="run of --db (default: 0)")
    parser.add_argument("--robot", dest="robot_id", type=non_negative_int, metavar="ID",
                        help="robot id (birth index) within the run of --db")
    parser.add_argument("--best", action="store_true",
                        help="with --db: the fittest robot of the run's final population")


@dataclass(frozen=True, slots=True)
class StoredRobot:
    """A robot of a results database and what the database says about it.

    Attributes:
        db: The database file.
        config: The experiment's stored configuration.
        run_seed: Seed of the robot's run.
        record: The robot's row (genome as conceived, birth, death, last fitness).
        learning: Its infancy learning record, ``None`` without one.
        robot: The genome decoded.
        fitness_time: Simulated time of its last fitness sample; ``None`` without one. Seconds.
    """

    db: Path
    config: ExperimentConfig
    run_seed: int
    record: RobotRecord
    learning: LearningRecord | None
    robot: Robot
    fitness_time: float | None = None

    @property
    def name(self) -> str:
        """A short name for files: ``run<r>_robot<id>``."""
        return f"run{self.record.run_id}_robot{self.record.robot_id}"


def stored_robot(args: argparse.Namespace) -> StoredRobot:
    """The robot that ``--db``, ``--run`` and ``--robot``/``--best`` name.

    Raises:
        CliError: a bad combination of arguments, or no such run or robot.
        StoreError: the database is missing or damaged (the robot does not decode).
    """
    if args.robot is not None:
        raise CliError("give either a robot file/example or --db, not both")
    if (args.robot_id is None) == (not args.best):
        raise CliError("with --db, give --robot ID or --best")
    from evolution.experiments import DB_NAME, Store, StoreError
    from evolution.experiments.store.integrity import verify

    run = 0 if args.run is None else args.run
    db = Path(args.db)
    db = db if db.name == DB_NAME else db / DB_NAME
    with Store.open(db) as store:
        config = verify(store)
        seeds = {r.run_id: r.seed for r in store.runs()}
        if run not in seeds:
            raise CliError(f"{db} has no run {run}")
        if args.best:
            final = [(f, rid) for rid, f in store.final_population(run)
                     if f is not None and math.isfinite(f)]
            if not final:
                raise CliError(f"run {run} of {db} has no evaluated population yet")
            robot_id = max(final)[1]
        else:
            robot_id = args.robot_id
        try:
            record = store.robot(run, robot_id)
        except KeyError as error:
            raise CliError(str(error.args[0])) from None
        learning = store.learning(run, [robot_id])
        samples = store.fitness_samples(run, robot_id)
    try:
        robot = record.robot()
    except ValueError as error:  # RobotError, or a genome that is not JSON
        raise StoreError(f"{db} is damaged: robot {robot_id} of run {run} does not "
                         f"decode ({error})") from None
    return StoredRobot(db, config, seeds[run], record,
                       learning[0] if learning else None, robot,
                       samples[-1].time if samples else None)


def load_robot(args: argparse.Namespace) -> tuple[Robot, str]:
    """The robot named on the command line and a short name for it."""
    if args.db is not None:
        stored = stored_robot(args)
        return stored.robot, stored.name
    from revolve_env.body.examples import EXAMPLES

    no_db(args)
    if args.robot is None:
        raise CliError("give a robot JSON file, an example name "
                       f"({', '.join(EXAMPLES)}) or --db DIR --robot ID")
    return robot_file(args.robot)


def no_db(args: argparse.Namespace) -> None:
    """Refuse ``--best``, ``--robot`` or ``--run`` without ``--db`` (they would be ignored).

    Raises:
        CliError: one of them is given.
    """
    given = [flag for flag, value in (("--best", args.best), ("--robot", args.robot_id),
                                      ("--run", args.run)) if value not in (None, False)]
    if given:
        raise CliError(f"{' and '.join(given)} {'names' if len(given) == 1 else 'name'} a "
                       "robot of a results database: give --db DIR too")


def robot_file(name: str) -> tuple[Robot, str]:
    """A robot JSON file or an example name (:func:`resolve_robot`'s rule), and a short name.

    A file is read by :func:`~revolve_env.body.serialize.load`: without waiting (a FIFO opens at
    once and is then refused) and at most :data:`~revolve_env.body.serialize.MAX_JSON_BYTES` + 1
    bytes of it, so a FIFO, a device or a folder given as the robot is one line, not a hang.
    """
    from revolve_env.body.errors import RobotError
    from revolve_env.body.examples import resolve_robot
    from revolve_env.body.serialize import NotARegularFileError, load

    path = Path(name)
    try:
        try:
            return load(path), path.stem
        except FileNotFoundError:  # an example's name, or resolve_robot's one line for no file
            return resolve_robot(name)
    except NotARegularFileError as error:
        raise CliError(f"the robot file {name} is {error.kind}, not a regular file") from None
    except RobotError as error:
        raise CliError(f"{name}: {error}") from None
    except ValueError as error:
        raise CliError(str(error)) from None
    except OSError as error:
        raise CliError(f"cannot read the robot file {name}: {error.strerror or error}") from None
