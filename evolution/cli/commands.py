"""The ``revolve`` command line: run, resume and report experiments; show and export robots.

Results layout: ``revolve run CONFIG --out DIR`` writes the experiment to ``DIR/<name>/``
(``name`` from the config; ``--name`` changes it) with its database ``results.sqlite``. Several
experiments can therefore share one ``DIR``; ``revolve report DIR`` finds every results database
at or below ``DIR`` and compares them, writing into ``DIR/report/``. Existing results are never
overwritten: running into a directory that holds results is an error (use ``revolve resume``).

Errors in the input (unknown scenario or config key, out-of-range value, a directory holding
other results, a corrupt, damaged, newer or (for ``resume``) read-only database, a bad robot
file) print one line to stderr and exit with status 2; ``resume``, ``report`` and ``show --db``
check a database (:func:`evolution.experiments.store.integrity.verify`) before using it, so a
refused one is left exactly as it was. Any other error is a bug: its traceback is shown with a line
saying so (status 1).
Ctrl-C stops after the last commit point (status 130); ``revolve resume`` continues from there.

Each command imports what it uses when it runs (the experiments, the reporting stack, a physics
engine), and each subcommand's options are defined when it is used (:data:`COMMANDS`), so
``revolve --help`` and ``revolve --version`` load none of them (``benchmarks/bench_startup.py``).
"""

from __future__ import annotations

import argparse
import importlib
import sys
import traceback
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn, TypeAlias

from evolution.cli.logs import cli_logging, duration, metres
from evolution.cli.options import parse_set as _parse_set
from evolution.cli.options import tensorboard_argument
from evolution.cli.robots import (
    EXIT_INTERRUPTED,
    CliError,
    load_robot,
    non_negative_int,
    positive_int,
    robot_arguments,
    seconds,
    trust_argument,
    workers,
    writable_folder,
)

if TYPE_CHECKING:
    from evolution.experiments import ExperimentConfig, ExperimentSummary
    from evolution.experiments.app.callbacks import TensorBoardLogger

__all__ = ["CliError", "build_parser", "main"]

EXIT_BUG = 1
EXIT_USAGE = 2


FIGURE_FORMATS = ("png", "pdf", "svg")


# --------------------------------------------------------------------------------------------
# Configurations


def _describe_learning(config: ExperimentConfig) -> str:
    """One line on a config's infancy learning (empty without a ``[learning]`` table)."""
    if config.learning is None:
        return ""
    table = config.learning
    return (f"infancy learning: {table['learner']}, {float(table['budget']):g} s per infant, "
            f"{table.get('inheritance', 'darwinian')}")


# --------------------------------------------------------------------------------------------
# Subcommands


def _say(text: str) -> None:
    print(text, flush=True)


def _print_runs(summary: ExperimentSummary) -> None:
    for r in summary.runs:
        _say(f"run {r.run_id}: {r.status}, {r.births} births, {r.sim_time:.0f} s simulated, "
             f"best {metres(r.best)} m, mean {metres(r.mean)} m, population {r.population_size}, "
             f"{duration(r.wall_time)}")


def _cmd_run(args: argparse.Namespace) -> int:
    from evolution.cli.progress import ProgressDisplay
    from evolution.experiments import load_config, run
    from evolution.experiments.app.callbacks import combine

    overrides = _parse_set(args.set or [])
    for key in ("runs", "births", "seed", "workers", "name"):
        value = getattr(args, key)
        if value is not None:
            overrides[key] = value
    config = load_config(args.config, overrides)
    out = Path(args.out) / config.name
    targets = {i: config.births for i in range(config.runs)}
    bar = combine(ProgressDisplay(targets, label=config.name), *_tensorboard(args, config.name))
    _say(f"{config.name}: {config.runs} run(s) x {config.births} births ({config.mode}) -> {out}")
    if config.learning is not None:
        _say(_describe_learning(config))
    try:
        summary = run(config, out, bar)
    except KeyboardInterrupt:
        bar.close()
        if (out / "results.sqlite").exists():
            print(f"revolve: interrupted; finished work is saved in {out}; continue with: "
                  f"revolve resume {out}", file=sys.stderr)
        else:
            print("revolve: interrupted before anything was saved", file=sys.stderr)
        return EXIT_INTERRUPTED
    bar.close()
    _print_runs(summary)
    _say(f"results: {summary.db_path}\nnext: revolve report {args.out}")
    return 0


def _tensorboard(args: argparse.Namespace, name: str) -> list[TensorBoardLogger]:
    """The TensorBoard logger of ``--tensorboard DIR`` (in ``DIR/<name>``), if asked for.

    Raises:
        CliError: ``DIR/<name>`` cannot be a folder (a file is in the way), checked now rather
            than at the first commit point.
    """
    if not args.tensorboard:
        return []
    from evolution.experiments.app.callbacks import TensorBoardLogger

    folder = Path(args.tensorboard) / name
    writable_folder(folder, "--tensorboard")
    return [TensorBoardLogger(folder)]


def _experiment_dirs(root: Path) -> list[Path]:
    from evolution.experiments import DB_NAME, StoreError

    if not root.exists():
        raise StoreError(f"no such results directory: {root}")
    if (root / DB_NAME).is_file():
        return [root]
    found = sorted(p.parent for p in root.rglob(DB_NAME))
    if not found:
        raise StoreError(f"no results database ({DB_NAME}) at or below {root}")
    return found


def _cmd_resume(args: argparse.Namespace) -> int:
    from evolution.cli.progress import ProgressDisplay
    from evolution.experiments import DB_NAME, Store, resume
    from evolution.experiments.app.api import check_resumable, work_left
    from evolution.experiments.app.callbacks import combine

    if args.tensorboard:
        writable_folder(Path(args.tensorboard), "--tensorboard")
    todo = []
    # Every database is checked before any is continued: a damaged or read-only one stops the
    # command with nothing changed.
    for folder in _experiment_dirs(Path(args.dir)):
        config = check_resumable(folder / DB_NAME, args.trust_pickled_policies,
                                 args.trust_task_code)
        with Store.open(folder / DB_NAME) as store:
            runs = store.runs()
        if work_left(config, runs):
            todo.append((folder, config, runs))
    if not todo:
        _say(f"nothing to resume: every run below {args.dir} has finished")
        return 0
    if args.tensorboard:  # every folder checked before any run continues
        for _, config, _ in todo:
            writable_folder(Path(args.tensorboard) / config.name, "--tensorboard")
    for folder, config, runs in todo:
        births = {r.run_id: r.births for r in runs}
        left = [i for i in range(config.runs) if i not in births
                or next(r for r in runs if r.run_id == i).status != "finished"]
        bar = combine(ProgressDisplay({i: config.births for i in left},
                                      {i: births.get(i, 0) for i in left}, label=config.name),
                      *_tensorboard(args, config.name))
        _say(f"{config.name}: resuming {len(left)} run(s) in {folder}")
        if config.learning is not None:
            _say(_describe_learning(config) + " (rebuilt from the stored learning table)")
        try:
            summary = resume(folder, bar, trust_pickled_policies=args.trust_pickled_policies,
                             trust_task_code=args.trust_task_code)
        except KeyboardInterrupt:
            bar.close()
            print(f"revolve: interrupted; finished work is saved in {folder}; continue with: "
                  f"revolve resume {folder}", file=sys.stderr)
            return EXIT_INTERRUPTED
        bar.close()
        _print_runs(summary)
    return 0


def _cmd_report(args: argparse.Namespace) -> int:
    from evolution.experiments.store.folders import left_out_note
    from evolution.reporting import report
    from evolution.reporting.tables import shaking_line, shaking_rows

    formats = tuple(f.strip() for f in args.formats.split(",") if f.strip())
    if not formats or any(f not in FIGURE_FORMATS for f in formats):
        raise CliError(f"--formats takes a comma-separated list of {', '.join(FIGURE_FORMATS)}; "
                       f"got {args.formats!r}")
    result = report(args.dir, args.out, formats, brain_aware=args.brain_aware,
                    every_set=args.all)
    if not args.quiet:  # --quiet: what was left out and where the page is, no list of files
        _say(f"{len(result.experiments)} experiment(s): "
             + ", ".join(f"{e.label} ({len(e.runs)} runs)" for e in result.experiments))
        for path in (*result.figures, *result.tables):
            _say(str(path))
    note = left_out_note(args.dir, result.left_out, "revolve report")
    if note:
        _say(note)
    if not args.quiet:  # the shaking of each experiment's robots (docs/experiments.md)
        for row in shaking_rows(result.experiments):
            _say(shaking_line(row))
    _say(f"open in a browser: {result.page}")
    return 0


def _cmd_export(args: argparse.Namespace) -> int:
    from revolve_env.body.export import bill_of_materials, to_sdf, to_urdf

    robot, _ = load_robot(args)
    if args.format == "urdf":
        text = to_urdf(robot)
    elif args.format == "sdf":
        text = to_sdf(robot)
    elif args.format == "mjcf":
        from revolve_env.evaluation import evaluation_mjcf  # loads MuJoCo

        text = evaluation_mjcf(robot)
    elif args.format == "bom":
        text = bill_of_materials(robot).to_text()
    else:
        import json

        text = json.dumps(bill_of_materials(robot).to_dict(), indent=2)
    if not text.endswith("\n"):
        text += "\n"
    if args.out is None:
        sys.stdout.write(text)
    else:
        Path(args.out).write_text(text, encoding="utf-8")
        _say(f"wrote {args.out}")
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:
    import tempfile
    import time

    from evolution.cli.progress import ProgressDisplay
    from evolution.config import EvolutionConfig
    from evolution.evaluation import EvalTask, evaluate_robot
    from evolution.experiments import ExperimentConfig, run
    from revolve_env.body.examples import spider

    started = time.perf_counter()
    # The config first: every value is checked before anything is simulated.
    config = ExperimentConfig(
        name="demo", population_size=args.population, offspring_size=args.population,
        births=args.births, evaluation_time=args.seconds, fertile_age=3.0 + args.seconds,
        diversity_interval=args.population, workers=args.workers, seed=args.seed,
        evolution=EvolutionConfig(initial_parts_mean=8.0, initial_parts_sd=3.0, max_parts=15),
    )
    robot = spider()
    outcome = evaluate_robot(EvalTask(0, robot, 3.0, args.seconds, 0))
    if outcome.fitness is None:
        raise CliError(f"the example spider could not be evaluated: {outcome.failure}")
    _say(f"example spider: fitness {outcome.fitness:.3f} m over {args.seconds:g} s "
         f"(path {outcome.v or 0:.3f} m, displacement {outcome.s or 0:.3f} m)")
    _say(f"evolving: {config.population_size} random robots, then ({config.population_size}+"
         f"{config.offspring_size}) generations up to {config.births} births")
    with tempfile.TemporaryDirectory(prefix="revolve-demo-") as tmp:
        out = Path(args.out) / "demo" if args.out else Path(tmp) / "demo"
        bar = ProgressDisplay({0: config.births})
        try:
            summary = run(config, out, bar)
        finally:
            bar.close()
        best = summary.runs[0].best
        _say(f"best fitness after {summary.runs[0].births} births: {metres(best)} m "
             f"(population mean {metres(summary.runs[0].mean)} m); "
             f"{time.perf_counter() - started:.0f} s in all")
        if args.out:
            _say(f"results: {out}; try: revolve report {args.out}")
    return 0


# --------------------------------------------------------------------------------------------
# Parser


class _DefaultsFormatter(argparse.HelpFormatter):
    """Help that ends every option's text with its default (options without one say so)."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        if (action.default in (None, argparse.SUPPRESS) or not action.option_strings
                or "%(default)" in text or isinstance(action, argparse._HelpAction)):
            return text
        return f"{text} (default: %(default)s)"


class _Parser(argparse.ArgumentParser):
    """A parser whose errors are one line (exit status 2), as every other input error's."""

    def error(self, message: str) -> NoReturn:
        """Print ``message`` on one line (no usage block) and exit with status 2."""
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see: {self.prog} --help)\n")


class _DefaultsParser(_Parser):
    """A subcommand parser whose ``--help`` shows every option's default."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", _DefaultsFormatter)
        super().__init__(*args, **kwargs)


COMMANDS: dict[str, tuple[str, str]] = {
    "run": ("evolution.cli.commands:_add_run", "run an experiment"),
    "resume": ("evolution.cli.commands:_add_resume", "continue interrupted experiments"),
    "reevaluate": ("evolution.cli.reevaluate:add_reevaluate",
                   "evaluate stored robots again: the optimism of a single evaluation"),
    "report": ("evolution.cli.commands:_add_report",
               "figures, tables and a browser page comparing experiments"),
    "show": ("evolution.cli.viewer:add_show", "render a GIF of a robot walking"),
    "watch": ("evolution.cli.viewer:add_watch",
              "watch a robot or an online run live (or record it)"),
    "export": ("evolution.cli.commands:_add_export",
               "export a robot as URDF, SDF, MuJoCo MJCF or bill of materials"),
    "demo": ("evolution.cli.commands:_add_demo",
             "check the installation: evaluate a robot, evolve a few"),
    "study": ("evolution.cli.study:add_study",
              "run the paper's five experiments and draw their figures"),
}
"""Every subcommand: the ``module:function`` that adds its options, and its line in ``--help``."""


class _Command(_DefaultsParser):
    """A subcommand's parser whose options are added when it is first used.

    Its ``define`` function (``module:function``, given the subcommand's parser through
    :class:`_Into`) runs when the subcommand is parsed or its help or usage is shown, so
    ``revolve --help`` and ``revolve --version`` import none of the commands' modules (they load
    the experiments, the reporting stack and the physics engines: seconds of CPU).
    """

    def __init__(self, *args: Any, define: str = "", **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._define = define

    def define(self) -> None:
        """Add the subcommand's options (once)."""
        if self._define:
            module, _, function = self._define.partition(":")
            self._define = ""
            getattr(importlib.import_module(module), function)(_Into(self))
            _chatter(self, argparse.SUPPRESS)  # also after the command: revolve report -q

    def parse_known_args(  # type: ignore[override]  # typeshed's overloads, same behaviour
            self, args: Sequence[str] | None = None,
            namespace: argparse.Namespace | None = None) -> tuple[argparse.Namespace, list[str]]:
        """Define the options, then parse as argparse does."""
        self.define()
        return super().parse_known_args(args, namespace)

    def format_usage(self) -> str:
        """Define the options, then the usage line."""
        self.define()
        return super().format_usage()

    def format_help(self) -> str:
        """Define the options, then the help."""
        self.define()
        return super().format_help()


class _Into(argparse._SubParsersAction):  # type: ignore[type-arg]  # not generic at run time
    """What a command's ``add_*`` function is given when its deferred parser is defined.

    ``add_parser(name, description=..., epilog=...)`` hands back the parser registered under
    ``name`` (see :class:`_Command`) with that description and epilog, instead of a new one.
    """

    def __init__(self, parser: argparse.ArgumentParser) -> None:
        super().__init__(option_strings=[], prog=parser.prog, parser_class=type(parser))
        self._parser = parser

    def add_parser(self, name: str, **kwargs: Any) -> Any:
        """The parser of ``name``, with the ``description`` and ``epilog`` given."""
        for key in ("description", "epilog"):
            if key in kwargs:
                setattr(self._parser, key, kwargs[key])
        return self._parser


class _Version(argparse.Action):
    """``--version``: the installed version, looked up only when asked for."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS,
                 default: str = argparse.SUPPRESS, help: str | None = None) -> None:
        super().__init__(option_strings, dest, nargs=0, default=default, help=help)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: Any, option_string: str | None = None) -> NoReturn:
        # As evolution.experiments.store.database.package_version, without importing the
        # experiments.
        from importlib.metadata import PackageNotFoundError, version

        try:
            number = version("revolve-env")
        except PackageNotFoundError:  # run from a checkout (PYTHONPATH)
            import revolve_env

            number = revolve_env.__version__
        print(f"{parser.prog} {number}")  # on stdout, as argparse's own version action
        parser.exit()


def _chatter(parser: argparse.ArgumentParser, default: Any) -> None:
    """``-v``/``--verbose`` and ``-q``/``--quiet`` (a subcommand's default leaves revolve's)."""
    chatter = parser.add_mutually_exclusive_group()
    chatter.add_argument("-v", "--verbose", action="store_true", default=default,
                         help="also log every commit point and every failure (DEBUG)")
    chatter.add_argument("-q", "--quiet", action="store_true", default=default,
                         help="no progress display, only warnings and errors (on stderr); "
                              "report and study list no files")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``revolve`` (one subparser per subcommand, defined on first use)."""
    parser = _Parser(
        prog="revolve",
        description="Online and offline evolution of modular robots (the Revolve experiments).",
        epilog="Start with `revolve demo`; then `revolve run quick` and `revolve report results`.",
    )
    parser.add_argument("--version", action=_Version, help="show the version and exit")
    _chatter(parser, False)
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND",
                                parser_class=_Command)
    for name, (define, summary) in COMMANDS.items():
        sub.add_parser(name, help=summary, define=define)
    return parser


_Subparsers: TypeAlias = "argparse._SubParsersAction[_DefaultsParser]"


def _add_run(sub: _Subparsers) -> None:
    from evolution.experiments import learning_names, shipped_configs

    learning = learning_names()
    names = ", ".join(sorted(set(shipped_configs()) - set(learning)))
    learning_list = ", ".join(learning)
    p = sub.add_parser(
        "run",
        description="Run an experiment and store it in OUT/<name>/results.sqlite (name from the "
                    "config or --name). Several experiments may share OUT; existing results are "
                    "never overwritten. Ctrl-C stops after the last commit point; continue with "
                    "`revolve resume OUT/<name>`.",
        epilog=f"shipped configs: {names}; with infancy learning (a [learning] table: "
               f"learner, budget, inheritance, ...): {learning_list}. A TOML file may add a "
               "[learning] table to any experiment; it is stored with the results and `revolve "
               "resume` learns the same way. Example: revolve run quick --runs 3 --out results; "
               "revolve run scenario1_learning --set learning.budget=35 --out results",
    )
    p.add_argument("config", metavar="CONFIG_OR_SCENARIO",
                   help=f"a shipped config ({names}; {learning_list}) or the path of a TOML "
                        "config file")
    p.add_argument("--runs", type=positive_int, help="independent repeats (default: the config's)")
    p.add_argument("--births", type=positive_int,
                   help="stop each run after this many births (default: the config's)")
    p.add_argument("--seed", type=non_negative_int, help="experiment seed (default: the config's)")
    p.add_argument("--workers", type=workers,
                   help="worker processes, 0: all cores (default: the config's)")
    p.add_argument("--name", help="experiment name, the folder inside OUT (default: the config's)")
    p.add_argument("--out", default="results", metavar="DIR",
                   help="results folder")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="change any config key, e.g. --set evaluation_time=6, "
                        "--set evolution.max_parts=20 or --set learning.budget=35 (repeatable)")
    tensorboard_argument(p)
    p.set_defaults(handler=_cmd_run)


def _add_resume(sub: _Subparsers) -> None:
    p = sub.add_parser(
        "resume",
        description="Continue every unfinished run of the experiment in DIR (a folder holding "
                    "results.sqlite), or of every experiment below DIR, to the result an "
                    "uninterrupted run would have given.",
    )
    p.add_argument("dir", metavar="DIR", help="an experiment's results folder, or a folder of them")
    tensorboard_argument(p)
    trust_argument(p)
    p.set_defaults(handler=_cmd_resume)


def _add_report(sub: _Subparsers) -> None:
    p = sub.add_parser(
        "report",
        description="Compare the experiments at or below DIR: one study, or the experiments "
                    "outside any study (what is left out is named; --all compares every set). "
                    "Each pair is compared at the most births both reached, and robots lost to "
                    "blow-ups are counted apart. Writes index.html (the whole report on one "
                    "page), fitness_over_births, final_fitness, diversity_over_births, "
                    "final_diversity, lost_robots and curve_tests (PNG and PDF), summary.csv, "
                    "tests_per_run.csv (Mann-Whitney U, A12 with its exact interval and Holm "
                    "on one value per run), tests_pooled_descriptive.csv, curve_tests.csv and "
                    "summary.md into DIR/report (or --out). When an experiment learns (a "
                    "[learning] table), summary.csv/summary.md also give the mean inborn and "
                    "learned fitness and the learner failures, and learning_gain (PNG/PDF) "
                    "compares inborn and learned fitness. --brain-aware adds the brain-aware "
                    "diversity. What each table and figure means: docs/reports.md.",
    )
    p.add_argument("dir", metavar="DIR", help="results folder (as given to `revolve run --out`)")
    p.add_argument("--out", metavar="DIR", help="output folder")
    p.add_argument("--formats", default="png,pdf",
                   help="figure formats, comma-separated: png, pdf, svg")
    p.add_argument("--brain-aware", action="store_true",
                   help="also the brain-aware diversity (body + neural distance; slower)")
    p.add_argument("--all", action="store_true",
                   help="compare every set of experiments below DIR (studies and lone "
                        "experiments together, each pair at the births both reached)")
    p.set_defaults(handler=_cmd_report)


def _add_export(sub: _Subparsers) -> None:
    p = sub.add_parser(
        "export",
        description="Write a robot as URDF or SDF, as MuJoCo MJCF (mjcf: the very model "
                    "revolve-env steps on MuJoCo, ground and settings included, placed where "
                    "an evaluation starts it; needs the mujoco package), or its bill of "
                    "materials (bom: a table; bom-json: JSON). The robot is given as for "
                    "`revolve show`.",
    )
    robot_arguments(p)
    p.add_argument("--format", required=True, choices=("urdf", "sdf", "mjcf", "bom", "bom-json"))
    p.add_argument("--out", metavar="FILE", help="file to write")
    p.set_defaults(handler=_cmd_export)


def _add_demo(sub: _Subparsers) -> None:
    p = sub.add_parser(
        "demo",
        description="Evaluate the example spider and print its fitness, then evolve a small "
                    "population for a few births and print the best fitness (3 to 8 s on two "
                    "cores, measured).",
    )
    p.add_argument("--births", type=positive_int, default=30, help="births")
    p.add_argument("--population", type=positive_int, default=6,
                   help="population size and children per generation")
    p.add_argument("--seconds", type=seconds, default=12.0,
                   help="evaluation time per robot after 3 s insertion, seconds")
    p.add_argument("--seed", type=non_negative_int, default=0, help="seed")
    p.add_argument("--workers", type=workers, default=0,
                   help="worker processes")
    p.add_argument("--out", metavar="DIR", help="keep the demo's results in DIR/demo")
    p.set_defaults(handler=_cmd_demo)


INPUT_ERRORS: tuple[tuple[str, str], ...] = (
    ("evolution.experiments.loop.errors", "ConfigError"),
    ("evolution.experiments.loop.errors", "StoreError"),
    ("revolve_env.body.errors", "RobotError"),
    ("evolution.random_robot", "RandomRobotError"),
    # an optional extra, named with its pip command
    ("evolution.experiments.app.callbacks", "TensorBoardUnavailableError"),
)
"""Bad input besides :class:`CliError` and :class:`OSError`, as (defining module, class):
reported on one line (exit status 2). :class:`~evolution.experiments.loop.run.ReplayError` is a
``StoreError`` but means a bug (a non-deterministic simulation), so it is not among them."""


def _loaded(module: str, name: str) -> type[BaseException] | None:
    """The class ``module.name`` if that module has been imported, else ``None``.

    An exception of a class whose module was never imported cannot have been raised, so the
    error handling of :func:`main` needs no import (a command that never loaded the experiments
    does not load them to report its error).
    """
    found = sys.modules.get(module)
    return None if found is None else getattr(found, name, None)


def input_errors() -> tuple[type[BaseException], ...]:
    """The classes of bad input that can have been raised so far (see :data:`INPUT_ERRORS`)."""
    found = (_loaded(module, name) for module, name in INPUT_ERRORS)
    return (CliError, OSError, *(kind for kind in found if kind is not None))


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``revolve``; returns the exit status.

    Errors in the input (configuration, results database, robot file, command line) print one
    line and return 2; an internal error (a bug, e.g. a replay that does not reproduce the
    stored run) shows its traceback, says that it is a bug, and returns 1.
    """
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        with cli_logging(int(args.verbose) - int(args.quiet)):
            return int(args.handler(args))
    except KeyboardInterrupt:
        print("revolve: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as error:  # noqa: BLE001 - sorted below; a bug shows its traceback
        replay = _loaded("evolution.experiments.loop.run", "ReplayError")
        if replay is not None and isinstance(error, replay):
            return _bug(args.command)
        if isinstance(error, input_errors()):
            message = str(error).splitlines()[0] if str(error) else type(error).__name__
            print(f"revolve {args.command}: error: {message}", file=sys.stderr)
            return EXIT_USAGE
        if isinstance(error, ImportError):
            print(f"revolve {args.command}: error: {error} (a dependency of revolve-env is "
                  "missing: reinstall it with pip)", file=sys.stderr)
            return EXIT_USAGE
        return _bug(args.command)


def _bug(command: str) -> int:
    traceback.print_exc()
    print(f"revolve {command}: internal error: this is a bug in revolve-env, not a problem with "
          "your input; please report it with the traceback above (finished work is saved)",
          file=sys.stderr)
    return EXIT_BUG


if __name__ == "__main__":
    sys.exit(main())
