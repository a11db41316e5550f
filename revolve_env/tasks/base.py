"""The Task protocol: what every robot is rewarded for, decided for all robots at once.

A task (dm_control's ``Task``, over arrays of robots) scores every robot's fitness window
(:class:`~revolve_env.fitness.Window`: its ends, path length ``v``, displacement ``s``, samples
and, when the task asks for one, a signal at both ends) with one call of :meth:`Task.fitness`,
and turns every robot's fitness before and after a control step into that step's reward with
one call of :meth:`Task.reward` (the gain, unless the task says otherwise). No per-robot Python:
both calls get arrays with one entry per robot. The envs and :func:`revolve_env.evaluate` own the
rest, the same for every task: nothing is sampled during insertion, a window with fewer than two
samples scores 0 (:func:`score`), a robot whose simulation blows up scores 0 from then on.

A task is plain data: a frozen dataclass whose fields are its parameters, with a name, so that
it is stored with results (:meth:`Task.to_dict`) and made again
(:func:`~revolve_env.tasks.registry.task_from_dict`).
:class:`BaseTask` gives a user's class everything but :meth:`~Task.fitness`. Names resolve
through ONE function, :func:`~revolve_env.tasks.registry.task_class` (in the registry, above the
tasks it names): a shipped task's name (:data:`~revolve_env.tasks.registry.TASKS`) or the dotted
path ``"package.module:ClassName"`` of a user's class.
:func:`~revolve_env.tasks.registry.make_task` turns whatever a ``task=`` keyword was given into a
checked task; a class that does not follow the protocol is refused in one line naming it.

Signals: a task that needs more than the core's path names one of :data:`SIGNALS` in its
``signal`` attribute; the world samples it for every robot with each fitness sample
(:mod:`revolve_env.world.signals`):

* ``"light"``: the brightest reading among the robot's light sensors (noise-free, the light
  sensor's model: ``max(0, cos a) / (1 + (d / light_range)^2)``, in [0, 1]); a robot without a
  light sensor reads the light at its core centre as a sensor facing it would
  (``1 / (1 + (d / light_range)^2)``), so it is scored on coming closer.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from revolve_env.fitness import Window
from revolve_env.fitness.sampling import DEFAULT_POSE_RATE, check_pose_rate

__all__ = ["SIGNALS", "BaseTask", "Task", "TaskError", "check", "check_class", "own_reward",
           "pose_rate", "score", "task_name"]

SIGNALS: tuple[str, ...] = ("light",)
"""Signals a task may ask the world to sample with every fitness sample (see the module doc)."""

class TaskError(ValueError):
    """An unknown task name, a class that fails the protocol, or bad task parameters."""


@runtime_checkable
class Task(Protocol):
    """What a task must have (see the module doc); :class:`BaseTask` gives all but ``fitness``."""

    @property
    def name(self) -> str:
        """Its registry name, or the dotted path of its class (``"package.module:Class"``)."""

    @property
    def signal(self) -> str | None:
        """The signal it needs sampled (one of :data:`SIGNALS`), or None."""

    def fitness(self, window: Window) -> NDArray[np.float64]:
        """Every robot's fitness over its window, shape (n,), from arrays only."""

    def reward(self, window: Window, fitness: NDArray[np.float64],
               previous: NDArray[np.float64]) -> NDArray[np.float64]:
        """Every robot's reward for a control step, from its fitness after and before it."""

    def to_dict(self) -> dict[str, Any]:
        """``{"name": name, **parameters}``: what :func:`revolve_env.tasks.task_from_dict` reads."""


@dataclass(frozen=True)
class BaseTask:
    """A task's common part: its name, no signal, reward = fitness gain, plain-data form.

    Subclass it as a frozen dataclass whose fields are the task's parameters and define
    :meth:`fitness`; set ``signal`` (a class variable) to one of :data:`SIGNALS` to get that
    signal at both ends of every window.

    Attributes:
        pose_rate: How often the core's pose (and the signal) is sampled for the window:
            samples per second (Hz; the paper's system: 5), or ``"every-period"``, a sample
            every control period (:mod:`revolve_env.fitness.sampling`). Keyword only, so that a
            subclass's own fields keep their order. Stored with the task (:meth:`to_dict`).
    """

    signal: ClassVar[str | None] = None
    #: The short name a shipped task is stored under (:data:`~revolve_env.tasks.TASKS`), set by
    #: the class that owns it; any other class, a subclass of a shipped one included, is stored
    #: under its dotted path.
    registered: ClassVar[str | None] = None
    pose_rate: float | str = field(default=DEFAULT_POSE_RATE, kw_only=True)

    def __post_init__(self) -> None:
        try:
            object.__setattr__(self, "pose_rate", check_pose_rate(self.pose_rate))
        except ValueError as error:
            raise TaskError(str(error)) from None

    @property
    def name(self) -> str:
        """The registry name of this class, else its dotted path."""
        return task_name(type(self))

    def fitness(self, window: Window) -> NDArray[np.float64]:
        """Every robot's fitness over its window (subclasses define it)."""
        raise NotImplementedError(f"{type(self).__name__} defines no fitness(window)")

    def reward(self, window: Window, fitness: NDArray[np.float64],
               previous: NDArray[np.float64]) -> NDArray[np.float64]:
        """The fitness gain over the step: the return of a whole window is its fitness."""
        gain: NDArray[np.float64] = fitness - previous
        return gain

    def to_dict(self) -> dict[str, Any]:
        """``{"name": ..., **fields}`` (plain numbers and strings for the shipped tasks)."""
        fields = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        return {"name": self.name, **fields}


def task_name(cls: type) -> str:
    """The name a task class is stored under: its registry name, else ``module:QualName``."""
    own = vars(cls).get("registered")  # the class's own, not one inherited
    return own if isinstance(own, str) else f"{cls.__module__}:{cls.__qualname__}"


def check_class(cls: type, name: str) -> None:
    """Refuse a class that lacks a member of the protocol (one line naming it)."""
    missing = [m for m in ("fitness", "reward", "to_dict") if not callable(getattr(cls, m, None))]
    missing += [m for m in ("name", "signal") if not hasattr(cls, m)]
    if missing:
        raise TaskError(f"task class {name!r} does not follow the Task protocol: it has no "
                        f"{', '.join(missing)} (subclass revolve_env.tasks.BaseTask)")


def check(task: object) -> Task:
    """``task`` if it follows the protocol, with a known signal and a plain-data form."""
    cls = type(task)
    label = f"{cls.__module__}:{cls.__qualname__}"
    check_class(cls, label)
    assert isinstance(task, Task)
    if task.signal is not None and task.signal not in SIGNALS:
        raise TaskError(f"task {label!r} asks for signal {task.signal!r}; known signals: "
                        f"{', '.join(SIGNALS)}")
    data = task.to_dict()
    if not isinstance(data, dict) or not isinstance(data.get("name"), str):
        raise TaskError(f"task {label!r}: to_dict() must give a dict with a 'name' string")
    pose_rate(task)
    try:
        hash(task)
    except TypeError:
        raise TaskError(f"task {label!r} must be hashable (a frozen dataclass)") from None
    return task


def own_reward(task: Task) -> bool:
    """Whether ``task`` rewards by its own rule, not :class:`BaseTask`'s fitness gain.

    Its rewards must then be computed and checked every step (a user's rule may give a wrong
    shape); the fitness gain has the fitness's shape by construction, and compiled steps may
    score it themselves.
    """
    return getattr(type(task), "reward", None) is not BaseTask.reward


def pose_rate(task: Task) -> float | str:
    """The pose rate ``task`` is scored at (:attr:`BaseTask.pose_rate`), checked.

    A task of the protocol's without one: the default,
    :data:`~revolve_env.fitness.sampling.DEFAULT_POSE_RATE`.

    Raises:
        TaskError: the task's pose rate is not one (one line).
    """
    try:
        return check_pose_rate(getattr(task, "pose_rate", DEFAULT_POSE_RATE))
    except ValueError as error:
        raise TaskError(f"task {task.name!r}: {error}") from None


def score(task: Task, window: Window) -> NDArray[np.float64]:
    """Every robot's fitness: the task's, 0 for a window of fewer than two samples (n,).

    Raises:
        TaskError: the task gave something else than one number per robot.
    """
    f = task.fitness(window)
    samples = window.samples
    n = samples.shape[0]
    if not (type(f) is np.ndarray and f.dtype == np.float64 and f.shape == (n,)):
        f = np.asarray(f, dtype=np.float64)
        if f.shape != (n,):
            raise TaskError(f"task {task.name!r}: fitness(window) must give shape ({n},), got "
                            f"{f.shape}")
    # One reduction first: the mask is made only when some window is that short.
    if n and np.minimum.reduce(samples) < 2:
        f = np.where(samples < 2, 0.0, f)
    return f
