"""The Triangle of Life as an explicit state machine per robot.

A robot goes through five stages (paper, section 5.1 and Fig. 1)::

    conception -> delivery -> infancy -> maturity -> death

* **Conception**: a genome is made, from two parents or at random.
* **Delivery**: the robot is built and dropped into the world; it lasts ``insertion`` seconds
  (3 s by default) while the robot settles.
* **Infancy**: the Training Center. An optional *infancy hook* (a learner) may change the
  robot's brain; without one the stage only lasts until the robot is fertile.
* **Maturity**: fertile, the robot may be a parent. Reached ``fertile_age`` seconds after birth
  (15 s by default: 3 s insertion + 12 s evaluation).
* **Death**: removed from the population (survivor selection, a blow-up, ...).

Death may come at any stage after conception (a robot that blows up during delivery dies as an
infant would). Every transition carries the simulated time at which it happened, so the store can
record the whole life of every robot. An illegal transition raises :class:`LifecycleError`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum
from typing import Protocol, runtime_checkable

import numpy as np

from revolve_env.body.robot import Robot

__all__ = [
    "LEGAL_TRANSITIONS",
    "InfancyHook",
    "LearningSummary",
    "SummarizingInfancyHook",
    "Lifecycle",
    "LifecycleError",
    "LifecycleTiming",
    "Stage",
    "Transition",
    "stage_of",
]


# Not StrEnum: str() and f-strings of a member must stay "Stage.DEATH" (StrEnum gives "death").
class Stage(str, Enum):  # noqa: UP042
    """The stages of the Triangle of Life."""

    CONCEPTION = "conception"
    DELIVERY = "delivery"
    INFANCY = "infancy"
    MATURITY = "maturity"
    DEATH = "death"


LEGAL_TRANSITIONS: dict[Stage | None, frozenset[Stage]] = {
    None: frozenset({Stage.CONCEPTION}),
    Stage.CONCEPTION: frozenset({Stage.DELIVERY, Stage.DEATH}),
    Stage.DELIVERY: frozenset({Stage.INFANCY, Stage.DEATH}),
    Stage.INFANCY: frozenset({Stage.MATURITY, Stage.DEATH}),
    Stage.MATURITY: frozenset({Stage.DEATH}),
    Stage.DEATH: frozenset(),
}
"""For each stage (``None``: not yet conceived), the stages it may move to."""

InfancyHook = Callable[[Robot, np.random.Generator], Robot]
"""A Training Center learner: takes the delivered robot and a generator, returns the robot with
its learned brain (same body). Called once when infancy begins. Without a hook infancy only waits
until the robot is fertile."""


@dataclass(frozen=True, slots=True)
class LearningSummary:
    """What the Training Center's learner reported for one infant.

    Attributes:
        inborn_fitness: Fitness of the inborn controller as the learner measured it (its own
            candidate evaluation, not the experiment's); ``None`` when unknown (a plain hook).
            Metres.
        learned_fitness: Fitness of the learned controller as the learner measured it; ``None``
            when unknown. Metres.
        evaluations: Evaluations (or training episodes) the learner ran; ``None`` when unknown.
        sim_seconds: Simulated seconds the learner used in its own Training Center simulations;
            ``None`` when unknown. Seconds.
        failures: Learner evaluations that failed (blow-ups).
        policy: The trained policy when the learner's controller is not the robot's network
            (an SB3 :class:`~evolution.learning.PolicyAgent`): it drives the robot's evaluation
            (offline) or its life in the shared world (online); ``None`` otherwise.
    """

    inborn_fitness: float | None = None
    learned_fitness: float | None = None
    evaluations: int | None = None
    sim_seconds: float | None = None
    failures: int = 0
    policy: object | None = field(default=None, compare=False)


@runtime_checkable
class SummarizingInfancyHook(Protocol):
    """An infancy hook that also reports its learner's numbers.

    The :class:`~evolution.learning.TrainingCenter` is one.
    """

    def __call__(self, robot: Robot, rng: np.random.Generator) -> Robot:
        """The robot with its learned controller."""

    def learn_with_summary(self, robot: Robot,
                           rng: np.random.Generator) -> tuple[Robot, LearningSummary]:
        """The robot with its learned controller, and what the learner measured."""


class LifecycleError(ValueError):
    """An illegal lifecycle transition (wrong order, time going backwards, ...)."""


@dataclass(frozen=True, slots=True)
class LifecycleTiming:
    """When the stages of a robot begin, relative to its birth.

    Attributes:
        insertion: Length of the delivery stage (the robot settles after being dropped). Seconds.
        fertile_age: Age at which the robot becomes mature (fertile). Seconds.
    """

    insertion: float = 3.0
    fertile_age: float = 15.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.insertion) and self.insertion >= 0):
            raise ValueError(
                f"insertion must be a finite number of seconds >= 0, got {self.insertion}"
            )
        if not (math.isfinite(self.fertile_age) and self.fertile_age >= self.insertion):
            raise ValueError(
                f"fertile_age ({self.fertile_age} s) must be finite and >= insertion "
                f"({self.insertion} s)"
            )

    def stage_at(self, age: float) -> Stage:
        """The stage of a living robot ``age`` seconds after its birth (delivery)."""
        if age < 0:
            raise LifecycleError(f"age must be >= 0 s, got {age}")
        if age < self.insertion:
            return Stage.DELIVERY
        if age < self.fertile_age:
            return Stage.INFANCY
        return Stage.MATURITY


@dataclass(frozen=True, slots=True)
class Transition:
    """One recorded lifecycle transition.

    Attributes:
        robot_id: The robot (its birth index within the run).
        source: Stage left; ``None`` for conception.
        target: Stage entered.
        time: Simulated time of the transition. Seconds.
        note: Why (e.g. the cause of death); empty when there is nothing to say.
    """

    robot_id: int
    source: Stage | None
    target: Stage
    time: float
    note: str = ""


@dataclass(slots=True)
class Lifecycle:
    """The state machine of one robot; :attr:`transitions` is its recorded history.

    Use :meth:`conceive`, :meth:`deliver`, :meth:`begin_infancy`, :meth:`mature` and :meth:`die`,
    or :meth:`advance_to_age` which performs whatever transitions the robot's age calls for.
    """

    robot_id: int
    timing: LifecycleTiming = field(default_factory=LifecycleTiming)
    stage: Stage | None = None
    birth_time: float | None = None
    transitions: list[Transition] = field(default_factory=list)

    def _move(self, target: Stage, time: float, note: str = "") -> Transition:
        if not math.isfinite(time):
            raise LifecycleError(
                f"robot {self.robot_id}: transition time must be finite, got {time}"
            )
        if target not in LEGAL_TRANSITIONS[self.stage]:
            source = "unconceived" if self.stage is None else self.stage.value
            raise LifecycleError(
                f"robot {self.robot_id}: illegal transition {source} -> {target.value}"
            )
        if self.transitions and time < self.transitions[-1].time:
            raise LifecycleError(
                f"robot {self.robot_id}: transition to {target.value} at {time} s is earlier than "
                f"the previous one at {self.transitions[-1].time} s"
            )
        transition = Transition(self.robot_id, self.stage, target, float(time), note)
        self.transitions.append(transition)
        self.stage = target
        return transition

    @property
    def alive(self) -> bool:
        """Delivered and not dead."""
        return self.stage in (Stage.DELIVERY, Stage.INFANCY, Stage.MATURITY)

    @property
    def fertile(self) -> bool:
        """May be a parent."""
        return self.stage is Stage.MATURITY

    def conceive(self, time: float, note: str = "") -> Transition:
        """The genome exists (``note``: e.g. ``"parents 3,7"`` or ``"random"``)."""
        return self._move(Stage.CONCEPTION, time, note)

    def deliver(self, time: float) -> Transition:
        """The robot is built and dropped into the world: its birth."""
        transition = self._move(Stage.DELIVERY, time)
        self.birth_time = float(time)
        return transition

    def begin_infancy(self, time: float) -> Transition:
        """Insertion is over; the Training Center starts."""
        return self._move(Stage.INFANCY, time)

    def mature(self, time: float) -> Transition:
        """The robot becomes fertile."""
        return self._move(Stage.MATURITY, time)

    def die(self, time: float, cause: str = "") -> Transition:
        """The robot is removed (``cause``: e.g. ``"survivor selection"``, ``"blow-up"``)."""
        return self._move(Stage.DEATH, time, cause)

    def advance_to_age(self, age: float) -> list[Transition]:
        """Perform the transitions a living robot of ``age`` seconds is due (offline robots).

        A robot living in a world follows the world's clock instead (:meth:`advance_to`).

        Returns:
            The transitions made (possibly none).
        """
        return self.advance_to(self.timing.stage_at(age))

    def advance_to(self, due: Stage) -> list[Transition]:
        """Perform the transitions that bring a living robot to stage ``due``.

        ``due`` comes from the clock of the world the robot lives in (the population env counts
        every robot's age in control periods and reports whether it is still inserting and
        whether it is mature: :func:`stage_of`), so insertion and maturity have one clock. Each
        transition is stamped with the exact time it became due (birth + insertion, birth +
        fertile age), not the time of the call, so the record does not depend on how often the
        engine checks.

        Returns:
            The transitions made (possibly none).
        """
        if self.birth_time is None or not self.alive:
            raise LifecycleError(f"robot {self.robot_id}: only a living robot ages")
        made: list[Transition] = []
        if self.stage is Stage.DELIVERY and due in (Stage.INFANCY, Stage.MATURITY):
            made.append(self.begin_infancy(self.birth_time + self.timing.insertion))
        if self.stage is Stage.INFANCY and due is Stage.MATURITY:
            made.append(self.mature(self.birth_time + self.timing.fertile_age))
        return made


def stage_of(inserting: bool, mature: bool) -> Stage:
    """The stage of a living robot as its world's clock reports it (insertion, maturity)."""
    if mature:
        return Stage.MATURITY
    return Stage.DELIVERY if inserting else Stage.INFANCY
