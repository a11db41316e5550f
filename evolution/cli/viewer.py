"""``revolve show`` and ``revolve watch``: what a robot or an online run looks like.

``revolve show ROBOT | --db DIR (--robot ID | --best) [--run R] [--size WxH] [--camera C]``
re-simulates one robot alone at the origin, driven by its own brain, and writes a GIF (or MP4)
of it, filmed by a camera (:data:`revolve_env.cameras.CAMERAS`) at a size. For a robot of a
results database it first says which robot it draws (experiment, run, id, birth and its time)
and compares the fitness stored with the results to the re-simulated one; when they differ (by
more than :data:`TOLERANCE`) it says why, from the stored configuration and records: the
stored fitness was the sliding window of the shared online world, the robot lived with a
learned policy, another engine or timing was asked for, or the evaluation had noisy
conditions. An offline robot evaluated under ideal conditions is re-simulated with its
evaluation's engine, timing and seed, so its fitness is reproduced exactly; a robot whose
Training Center learned a new controller is drawn with that controller (the one evaluated).

``revolve watch ROBOT | RESULTS [--run R] [--engine E] [--record OUT] [--seconds S]
[--size WxH] [--camera C]``:

* a robot (JSON file or example name): the engine's window (pybullet's, or MuJoCo's viewer)
  with the robot walking in real time; with ``--record OUT`` the same as ``show`` without the
  window.
* an online experiment's results folder: the run is replayed from its stored configuration and
  seed into a temporary database (the same births, deaths and fitness as stored: the replay is
  checked robot by robot against the stored genomes), and the whole world is shown in a window
  (matplotlib) or, with ``--record``, written as a video (MP4 with ``imageio-ffmpeg``, else GIF)
  with the time and births on top and a legend of the living robots (colour, id, current
  sliding-window fitness), fittest first. ``--seconds`` stops the replay at that simulated time.

The windows need a display: without one the command stops with a one-line error that names
``--record``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

import revolve_env
from evolution.cli.robots import (
    CliError,
    StoredRobot,
    no_db,
    non_negative_int,
    non_negative_seconds,
    number,
    positive_float,
    robot_arguments,
    robot_file,
    seconds,
    stored_robot,
    trust_argument,
)
from evolution.evaluation import evaluation_seed
from evolution.experiments import DB_NAME, Evolution, ExperimentConfig, Store
from evolution.experiments.loop.online_world import PopulationWorld
from evolution.experiments.loop.records import FitnessSample, RobotRecord
from evolution.experiments.loop.run import ReplayError, run_seed, world_seed
from evolution.experiments.store.integrity import verify
from evolution.experiments.store.results_folder import check_task_code
from revolve_env.body.robot import PartType, Robot
from revolve_env.body.serialize import from_json
from revolve_env.cameras import CAMERAS, MAX_SIZE, check_size
from revolve_env.conditions import IDEAL, EvaluationConditions
from revolve_env.terrain import Flat, Terrain

if TYPE_CHECKING:
    from revolve_env.envs.recording import Video

__all__ = ["MAX_FPS", "MAX_FRAMES", "TOLERANCE", "add_show", "add_watch", "fitness_reasons",
           "render_setup"]

TOLERANCE = 1e-6
"""Stored and re-simulated fitness within this many metres are the same."""
MAX_FPS = 60.0
"""Most frames per simulated second: one per control period (1/60 s)."""
MAX_FRAMES = 2000
"""Most frames of one video: they are held in memory (480 x 360 RGB, 0.5 MB each)."""


def _say(text: str) -> None:
    print(text, flush=True)


# --------------------------------------------------------------------------------------------
# show


@dataclass(frozen=True, slots=True)
class _Plan:
    """What to simulate: the robot, its timing, engine and seed, and what it says about it."""

    robot: Robot
    name: str
    seconds: float
    insertion: float
    engine: str
    seed: int
    stored: StoredRobot | None = None
    learned: bool = False
    conditions: EvaluationConditions = IDEAL
    terrain: Terrain = Flat()


def _plan(args: argparse.Namespace) -> _Plan:
    """The robot and simulation ``show`` (or ``watch ROBOT``) asks for."""
    if getattr(args, "db", None) is None:
        if hasattr(args, "best"):  # show's robot arguments
            no_db(args)
        robot, name = robot_file(args.robot) if args.robot is not None else _no_robot()
        return _Plan(robot, name, args.seconds or 12.0,
                     3.0 if args.insertion is None else args.insertion,
                     args.engine or revolve_env.DEFAULT_ENGINE, 0)
    stored = stored_robot(args)
    config = stored.config
    robot, learned = stored.robot, False
    lesson = stored.learning
    if lesson is not None and lesson.learned_genome is not None and lesson.policy is None:
        robot, learned = from_json(lesson.learned_genome), True  # the controller it lived with
    return _Plan(robot, stored.name, args.seconds or config.evaluation_time,
                 config.insertion if args.insertion is None else args.insertion,
                 args.engine or config.world.engine,
                 evaluation_seed(stored.run_seed, stored.record.robot_id), stored, learned,
                 config.evaluation, config.world.terrain_spec)


def _check_drivable(plan: _Plan) -> None:
    """Refuse, in one line, a robot the single-robot env cannot drive (no active hinge)."""
    if not any(node.type == PartType.ACTIVE_HINGE for _, node in plan.robot.walk()):
        raise CliError(f"cannot show {plan.name}: it has no active hinge, so nothing moves it "
                       "(the single-robot env needs one)")


def _no_robot() -> tuple[Robot, str]:
    raise CliError("give a robot JSON file, an example name or --db DIR --robot ID")


def _stored_kind(stored: StoredRobot) -> str:
    config = stored.config
    if config.mode == "online":
        when = "" if stored.fitness_time is None else f" at t = {stored.fitness_time:.1f} s"
        return (f"its last {config.evaluation_time:g} s sliding-window sample in the shared "
                f"online world{when}")
    return (f"isolated {config.evaluation_time:g} s evaluation after {config.insertion:g} s "
            f"settling, {config.world.engine}")


def fitness_reasons(plan: _Plan) -> list[str]:
    """Why a stored robot's re-simulation may not give its stored fitness (empty: it must)."""
    stored = plan.stored
    if stored is None:
        return []
    config, reasons = stored.config, []
    if config.mode == "online":
        reasons.append("its stored fitness was measured in the shared online world (other "
                       "robots, collisions, its birth place and heading, a sliding window), "
                       "the re-simulation is alone at the origin")
    lesson = stored.learning
    if lesson is not None and lesson.policy is not None:
        ref = json.loads(lesson.policy).get("file", "?")
        reasons.append(f"it lived driven by a learned policy ({ref}); the re-simulation drives "
                       "it with its inborn network")
    if plan.engine != config.world.engine:
        reasons.append(f"re-simulated on {plan.engine}, stored from {config.world.engine}")
    if (plan.seconds, plan.insertion) != (config.evaluation_time, config.insertion):
        reasons.append(f"re-simulated over {plan.insertion:g} + {plan.seconds:g} s, stored over "
                       f"{config.insertion:g} + {config.evaluation_time:g} s")
    if plan.conditions != config.evaluation:
        reasons.append(f"re-simulated under other conditions ({plan.conditions}) than stored "
                       f"({config.evaluation})")
    return reasons


def _describe(plan: _Plan, video: Video) -> list[str]:
    """The lines ``show`` prints about the robot it drew."""
    lines = [f"{video.path}: {video.frames} frames, {video.seconds:.1f} s simulated "
             f"({plan.engine}), {video.distance:.3f} m from the start"]
    stored = plan.stored
    if stored is None:
        lines.insert(0, f"{plan.name}: fitness re-simulated alone: {video.fitness:.3f} m")
        return lines
    rec = stored.record
    born = "never born" if rec.birth_time is None else f"t = {rec.birth_time:.1f} s"
    learned = ", with the controller its Training Center learned" if plan.learned else ""
    head = (f"robot {rec.robot_id} of run {rec.run_id} of {stored.config.name} (born at birth "
            f"{rec.robot_id}, {born}{learned}), ")
    if rec.fitness is None or not math.isfinite(rec.fitness):
        died = f" (died: {rec.death_cause})" if rec.death_cause else ""
        lines.insert(0, head + f"no stored fitness{died}, re-simulated alone: "
                           f"{video.fitness:.3f} m")
        return lines
    head += (f"stored fitness {rec.fitness:.3f} m ({_stored_kind(stored)}), re-simulated "
             f"alone: {video.fitness:.3f} m")
    if abs(video.fitness - rec.fitness) <= TOLERANCE:
        lines.insert(0, head + " (the same)")
        return lines
    reasons = fitness_reasons(plan) or [
        "no known reason: the simulation did not reproduce the evaluation (a bug; please "
        "report it)"]
    lines[:0] = [head, f"  they differ by {video.fitness - rec.fitness:+.3f} m because "
                       + "; ".join(reasons)]
    return lines


def _frames(seconds: float, fps: float, size: tuple[int, int] = (480, 360)) -> None:
    """Refuse a video of more than :data:`MAX_FRAMES` 480 x 360 frames' memory (all are held).

    Raises:
        CliError: ``seconds * fps`` frames of ``size`` (pixels) would be too many.
    """
    most = max(1, MAX_FRAMES * 480 * 360 // (size[0] * size[1]))
    if seconds * fps > most:
        raise CliError(f"{seconds:g} s at {fps:g} frames per second would be "
                       f"{seconds * fps:.0f} frames, more than {most} of {size[0]} x {size[1]} "
                       f"pixels (about {MAX_FRAMES * 518_400 / 1e9:.0f} GB of memory): give "
                       "fewer --seconds, a lower --fps or a smaller --size")


def render_setup(engine: str) -> None:
    """Refuse, before anything is simulated, to render on ``engine`` where it cannot draw.

    MuJoCo: its OpenGL backend (:func:`revolve_env.envs.watch.render_problem`; chosen, where
    there is no display, when MuJoCo is first imported).

    Raises:
        CliError: it cannot render here (one line: what to install or set).
    """
    from revolve_env.envs.watch import render_problem

    problem = render_problem(engine)
    if problem is not None:
        raise CliError(f"{problem}, or use --engine pybullet")


def _cmd_show(args: argparse.Namespace) -> int:
    # Imported here: it loads the physics engine, which the other commands never need.
    from revolve_env.envs.video import VideoError, check_video

    plan = _plan(args)
    _check_drivable(plan)
    out = Path(args.out) if args.out else Path(f"{plan.name}.gif")
    _frames(plan.insertion + plan.seconds, args.fps, args.size)
    try:
        check_video(out, args.fps)
    except VideoError as error:
        raise CliError(f"cannot show {plan.name}: {error}") from None
    render_setup(plan.engine)
    from revolve_env.envs.recording import BlowUpError, record_robot
    from revolve_env.envs.watch import RenderUnavailableError

    try:
        with warnings.catch_warnings(record=True) as notes:
            warnings.simplefilter("always", UserWarning)
            video = record_robot(plan.robot, out, seconds=plan.seconds, insertion=plan.insertion,
                                 fps=args.fps, engine=plan.engine, seed=plan.seed,
                                 conditions=plan.conditions, terrain=plan.terrain,
                                 width=args.size[0], height=args.size[1], camera=args.camera)
    except (BlowUpError, VideoError) as error:  # the robot's or the video's fault, not ours
        raise CliError(f"cannot show {plan.name}: {error}") from None
    except RenderUnavailableError as error:  # no OpenGL context after all
        raise CliError(str(error)) from None
    for note in notes:
        _say(f"note: {note.message}")
    for line in _describe(plan, video):
        _say(line)
    return 0


def _timing_arguments(p: argparse.ArgumentParser, help_seconds: str,
                      kind: Callable[[str], Any] = seconds) -> None:
    p.add_argument("--seconds", type=kind, help=help_seconds)
    p.add_argument("--insertion", type=non_negative_seconds,
                   help="settling time shown first, seconds (default: the stored insertion, "
                        "else 3)")
    p.add_argument("--fps", type=number(float, 0.0, strict=True, high=MAX_FPS), default=15.0,
                   help=f"frames per simulated second, at most {MAX_FPS:g} (one per control "
                        "period; a GIF plays at most 50)")
    # the engines whose world holds a robot as an env does (not MuJoCo Warp's isolated worlds)
    p.add_argument("--engine", choices=[e for e in revolve_env.ENGINES
                                        if revolve_env.engine(e).shared_world],
                   help="physics engine (default: the stored one, else mujoco)")
    p.add_argument("--size", type=frame_size, default="480x360", metavar="WxH",
                   help="frame width and height, pixels")


def _camera_argument(p: argparse.ArgumentParser) -> None:
    p.add_argument("--camera", choices=tuple(CAMERAS), default="track",
                   help="where a robot is filmed from: track (1 m from its core, following it), "
                        "far (2.5 m, following), top (straight down, following), fixed (3 m "
                        "from its start: it walks across the picture)")


def frame_size(text: str) -> tuple[int, int]:
    """An argparse type: ``WxH`` (e.g. ``640x480``), each a whole number of pixels."""
    try:
        width, height = (int(part) for part in text.lower().split("x"))
        return check_size(width, height)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT in pixels, each 1 to "
                                         f"{MAX_SIZE} (e.g. 640x480), got {text!r}") from None


def add_show(sub: Any) -> None:
    """Register ``revolve show`` on the subcommand parsers ``sub``."""
    p = sub.add_parser(
        "show",
        description="Simulate a robot alone, driven by its own brain, and write an animated GIF "
                    "(with time, fitness and a map of its path). The robot is a JSON file, an "
                    "example name, or a robot of a results database (--db DIR --robot ID / "
                    "--best); for a stored robot it says which one it drew and compares its "
                    "stored and re-simulated fitness, saying why they differ.",
    )
    robot_arguments(p)
    p.add_argument("--out", metavar="FILE", help="GIF (or MP4) to write")
    _timing_arguments(p, "evaluation time after insertion, seconds (default: the stored "
                         "evaluation_time, else 12)")
    _camera_argument(p)
    p.set_defaults(handler=_cmd_show)


# --------------------------------------------------------------------------------------------
# watch

FrameSink = Callable[[NDArray[np.uint8], float], None]
"""Receives each labelled frame of a replay and its simulated time (seconds)."""


class RecordingWorld(PopulationWorld):
    """The online world of a run that also renders a labelled frame every ``every`` steps.

    It advances in frame-sized pieces (whole control periods, so the physics is stepped exactly
    as by :class:`PopulationWorld`: rendering reads the state, never changes it) and tells the
    loop what one call would have told it.

    Args:
        config: The experiment.
        seed: The world's seed (:func:`evolution.experiments.loop.run.world_seed`).
        every: Control periods between frames.
        sink: Called with each frame.
        size: Frame width and height. Pixels.
    """

    def __init__(self, config: ExperimentConfig, seed: int, every: int, sink: FrameSink,
                 size: tuple[int, int] = (480, 360)) -> None:
        super().__init__(config, seed)
        self._env.render_size = size
        self._period = every * float(self._env.config.control_period)
        self._next = 0.0
        self._sink = sink
        self._added = 0  # births asked for (robots born dead included)
        self._colors: dict[int, int] = {}  # robot id: its PALETTE index, for life

    def add(self, robot: Robot, robot_id: int, policy: Any = None) -> Any:
        """Add the robot and give it a colour of its own for its tag and the legend."""
        from revolve_env.envs.watch import pick_color

        self._added += 1
        alive = [self._colors[r] for r in self._env.robot_ids if r in self._colors]
        birth = super().add(robot, robot_id, policy)
        self._colors[robot_id] = pick_color(alive)
        return birth

    def advance_to(self, t: float) -> Any:
        """Advance to ``t`` frame by frame; the statuses one call would have given."""
        merged: dict[int, Any] = {}
        half = 0.5 * float(self._env.config.control_period)
        while self._next < t - half:
            self._merge(merged, super().advance_to(self._next))
            self._frame()
            self._next += self._period
        self._merge(merged, super().advance_to(t))
        return merged

    @staticmethod
    def _merge(merged: dict[int, Any], statuses: dict[int, Any]) -> None:
        for robot_id, status in statuses.items():
            if robot_id not in merged or merged[robot_id].death is None:
                merged[robot_id] = status

    def _frame(self) -> None:
        from revolve_env.envs.watch import PALETTE, Label, label_frame

        labels = []
        pixels = self._env.render_pixels("top")
        for robot_id in self._env.robot_ids:
            color = PALETTE[self._colors.get(robot_id, 0)]
            fitness = float(self._env.status(robot_id).fitness)
            labels.append(Label(f"#{robot_id}  {fitness:.3f} m", color, fitness,
                                tag=f"#{robot_id}", at=pixels.get(robot_id)))
        header = (f"t = {self.time:6.1f} s   births {self._added}   alive {len(labels)}   "
                  "(id, fitness)")
        self._sink(label_frame(self._env.render_frame("top"), header, labels), self.time)


def replay_online(config: ExperimentConfig, run_id: int, stored: Store | None, every: int,
                  sink: FrameSink, size: tuple[int, int] = (480, 360)) -> int:
    """Replay run ``run_id`` of an online experiment, sending a frame every ``every`` steps.

    The run is stepped again from its seed (the loop, :class:`~evolution.experiments.loop.evolve.
    Evolution`, in a recording world; nothing is written), exactly as ``resume`` replays it;
    with ``stored`` the replayed robots and fitness samples are checked against the stored ones.

    Returns:
        The births of the replay.

    Raises:
        ReplayError: a replayed robot differs from the stored one (a bug).
    """
    robots: list[RobotRecord] = []
    samples: list[FitnessSample] = []
    world = RecordingWorld(config, world_seed(run_seed(config.seed, run_id)), every, sink, size)
    try:
        with Evolution(config, run_id=run_id, world=world) as evolution:
            while not evolution.done:
                records = evolution.step().records
                robots += records.robots
                samples += records.fitness
    finally:
        world.close()
    if stored is not None:
        # In the store's order (Store.fitness_samples): by time, then robot.
        _check_replay(stored, run_id, robots, sorted(samples, key=lambda s: (s.time, s.robot_id)))
    return len(robots)


def _check_replay(stored: Store, run_id: int, robots: list[RobotRecord],
                  samples: list[FitnessSample]) -> None:
    """Refuse a replay whose robots or fitness samples differ from the stored run's.

    Raises:
        ReplayError: they differ (the simulation did not repeat itself: a bug).
    """
    kept = {r.robot_id: (r.genome, r.birth_time) for r in stored.robots(run_id)}
    for record in robots:
        if kept.get(record.robot_id) != (record.genome, record.birth_time):
            raise ReplayError(f"the replay of run {run_id} made a different robot "
                              f"{record.robot_id} than the stored one")
    end = max((s.time for s in samples), default=-math.inf)
    if [s for s in stored.fitness_samples(run_id) if s.time <= end] != samples:
        raise ReplayError(f"the replay of run {run_id} measured other fitness than the stored "
                          "run")


class _Window:
    """A matplotlib window showing frames at the pace of the simulation."""

    def __init__(self) -> None:
        import matplotlib.pyplot as plt

        self._plt = plt
        self._image: Any = None
        self._started = time.perf_counter()

    def __call__(self, frame: NDArray[np.uint8], t: float) -> None:
        plt = self._plt
        if self._image is None:
            plt.ion()
            self._image = plt.imshow(frame)
            plt.axis("off")
        else:
            self._image.set_data(frame)
        plt.pause(max(0.001, self._started + t - time.perf_counter()))


def _no_display(what: str) -> CliError:
    return CliError(f"no display for a live window of {what} ($DISPLAY is unset); write a "
                    "video instead with --record OUT.mp4 (or OUT.gif)")


def _write(frames: list[NDArray[np.uint8]], out: Path, fps: float) -> Path:
    from revolve_env.envs.video import write_video

    if not frames:
        raise CliError("the replay ended before its first frame: give more --seconds")
    with warnings.catch_warnings(record=True) as notes:
        warnings.simplefilter("always", UserWarning)
        try:
            written = write_video(frames, out, fps=fps)
        except ValueError as error:
            raise CliError(str(error)) from None
    for note in notes:
        _say(f"note: {note.message}")
    return written


def _watch_results(args: argparse.Namespace, folder: Path) -> int:
    from revolve_env.envs.video import VideoError, check_video
    from revolve_env.envs.watch import RenderUnavailableError, control_period, has_display

    db = folder if folder.name == DB_NAME else folder / DB_NAME
    with Store.open(db) as store:
        config = verify(store)
        if args.run not in {r.run_id for r in store.runs()}:
            raise CliError(f"{db} has no run {args.run}")
        if config.mode != "online":
            raise CliError(f"{config.name} is an offline experiment (robots evaluated alone): "
                           "watch one of its robots with `revolve show --db DIR --robot ID`")
        # The replay scores with the stored task: a class it names is imported only if trusted.
        check_task_code(db, config, args.trust_task_code)
        if args.record is None and not has_display():
            raise _no_display("an online run")
        stored_time = next(r.sim_time for r in store.runs() if r.run_id == args.run)
        if args.engine is not None and args.engine != config.world.engine:
            _say(f"note: replaying on {args.engine}; the run was stored from "
                 f"{config.world.engine}, so this world differs from the stored one")
            config = config.replace(world=dataclasses.replace(config.world, engine=args.engine))
        if args.seconds is not None:
            limit = config.max_sim_time
            config = config.replace(max_sim_time=min(limit or math.inf, args.seconds))
        dt = control_period(config.world.engine)
        every = max(1, round(1.0 / (args.fps * dt)))
        if args.record:
            _frames(min(stored_time, math.inf if args.seconds is None else args.seconds),
                    1.0 / (every * dt), args.size)
            try:
                check_video(args.record, 1.0 / (every * dt))
            except VideoError as error:
                raise CliError(str(error)) from None
        render_setup(config.world.engine)
        frames: list[NDArray[np.uint8]] = []
        show: FrameSink = (lambda frame, t: frames.append(frame)) if args.record else _Window()
        end = math.inf if args.seconds is None else args.seconds - 0.5 * dt

        def sink(frame: NDArray[np.uint8], t: float) -> None:
            # A frame shows [t, t + period). The engine stops at its first commit point after
            # --seconds: no frame beyond.
            if t < end:
                show(frame, t)

        _say(f"replaying run {args.run} of {config.name} ({config.world.engine}) from its seed"
             + ("" if args.seconds is None else f" for {args.seconds:g} s"))
        same = args.engine in (None, config.world.engine)
        try:
            births = replay_online(config, args.run, store if same else None, every, sink,
                                   args.size)
        except RenderUnavailableError as error:  # no OpenGL context after all
            raise CliError(str(error)) from None
    _say(f"{births} births replayed" + (" (the stored robots)" if same else ""))
    if args.record:
        written = _write(frames, Path(args.record), 1.0 / (every * dt))
        _say(f"{written}: {len(frames)} frames, {len(frames) * every * dt:.1f} s simulated")
    return 0


def _watch_robot(args: argparse.Namespace) -> int:
    from revolve_env.envs.watch import NoDisplayError, watch_robot

    plan = _plan(args)
    if args.record:
        args.out = args.record
        return _cmd_show(args)
    _check_drivable(plan)
    if not revolve_env.engine(plan.engine).gui:
        windows = [name for name in revolve_env.ENGINES if revolve_env.engine(name).gui]
        raise CliError(f"cannot watch {plan.name} live on {plan.engine}: a live window needs "
                       f"{' or '.join(windows)} (--engine {windows[0]}), or write a video with "
                       "--record")
    try:
        fitness = watch_robot(plan.robot, plan.seconds, plan.insertion, engine=plan.engine,
                              seed=plan.seed, conditions=plan.conditions, terrain=plan.terrain)
    except NoDisplayError:
        raise _no_display(plan.name) from None
    _say(f"{plan.name}: fitness {fitness:.3f} m")
    return 0


def _cmd_watch(args: argparse.Namespace) -> int:
    target = Path(args.target)
    if target.is_dir() or target.name == DB_NAME:
        return _watch_results(args, target)
    from revolve_env.body.examples import EXAMPLES

    if not target.exists() and target.suffix.lower() != ".json" and args.target not in EXAMPLES:
        raise CliError(f"no such folder: {target} (nor a robot JSON file or an example name: "
                       f"{', '.join(EXAMPLES)})")
    args.robot, args.db = args.target, None
    return _watch_robot(args)


def add_watch(sub: Any) -> None:
    """Register ``revolve watch`` on the subcommand parsers ``sub``."""
    p = sub.add_parser(
        "watch",
        description="Open a live window on a robot (the engine's window, in real time) or on an "
                    "online experiment's run (replayed from its stored config and seed: births, "
                    "deaths and fitness as stored). --record OUT writes a video instead, without "
                    "a window; an online world's frames carry each living robot's id and "
                    "current fitness.",
        epilog="Example: revolve watch results/scenario3 --seconds 60 --record world.mp4",
    )
    p.add_argument("target", metavar="ROBOT_OR_RESULTS",
                   help="a robot JSON file or example name, or an online experiment's results "
                        "folder")
    p.add_argument("--run", type=non_negative_int, default=0, help="run of the results")
    p.add_argument("--record", metavar="OUT", help="write a video (.mp4 or .gif), no window")
    trust_argument(p, pickled=False)
    _timing_arguments(p, "a robot: evaluation time after insertion (default 12); results: stop "
                         "the replay at this simulated time (default: the run's end), seconds",
                      positive_float)
    _camera_argument(p)
    p.set_defaults(handler=_cmd_watch)
