"""Evaluation conditions: how a robot starts (heading, position) and the noise it lives with.

One :class:`EvaluationConditions` describes the conditions of every evaluation of an experiment,
offline (:func:`revolve_env.evaluate`, the single-robot env) and online (newborns of the
population env), so both draw from the same distribution:

* ``heading``: a fixed heading (radians) or ``"random"``, uniform in ``[0, 2 pi)``;
* ``position_jitter``: the start is drawn uniformly from a disc of this radius (metres) around
  the nominal start (the origin offline, a requested position online);
* ``sensor_noise`` / ``actuator_noise``: standard deviations of Gaussian noise added to every
  sensor value (in each sensor's units) and every normalised hinge target (in ``[-1, 1]``), as
  RoboGen's simulator does with its sensor and motor noise levels;
* ``reset_noise_scale``: Gymnasium's MuJoCo envs' convention: every active hinge starts at an
  angle drawn uniformly from ``[-scale, scale]`` radians and a speed drawn uniformly from
  ``[-scale, scale]`` radians per second (after the start, from the same generator), instead of
  at rest at 0. The envs default to :data:`DEFAULT_RESET_NOISE_SCALE` (so each reset seed gives
  another episode); evaluations and experiments keep 0, the paper's start.

Every draw comes from a generator the caller seeds from its run's seed tree, so the conditions
are random across evaluations but every evaluation is reproducible to the bit. With the default
(:data:`IDEAL`: heading 0, no jitter, no noise) an evaluation draws nothing at all.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from typing import Any, Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

__all__ = ["DEFAULT_RESET_NOISE_SCALE", "IDEAL", "MAX_RADIUS", "MAX_RESET_NOISE_SCALE",
           "RANDOM_HEADING", "EvaluationConditions", "Start", "add_actuator_noise",
           "add_sensor_noise", "with_noise_shortcuts", "with_reset_noise"]

MAX_RADIUS = 100.0
"""Largest distance a robot is placed from its nominal start: the start jitter, an experiment's
birth radius and clearance (the paper's birth disc is 2 m; MuJoCo aborts on a robot 1e30 m
away). Metres."""

DEFAULT_RESET_NOISE_SCALE = 0.1
"""The envs' default ``reset_noise_scale`` (``Locomotion-v*``, the population env): start angles
within +-0.1 rad (5.7 degrees) and speeds within +-0.1 rad/s of rest, as Gymnasium's Ant-v5.
Radians, radians per second."""

MAX_RESET_NOISE_SCALE = math.pi / 4
"""Largest ``reset_noise_scale``: a hinge target's full range (45 degrees). Radians."""

RANDOM_HEADING: Literal["random"] = "random"
"""The ``heading`` value that draws a heading uniformly in ``[0, 2 pi)``."""


def _finite(value: object) -> bool:
    """A finite int or float (a bool is not a number here)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


class Start(NamedTuple):
    """Where and how a robot starts: core ``position`` ``(x, y)`` in metres, ``yaw`` in radians."""

    position: tuple[float, float]
    yaw: float


@dataclass(frozen=True, slots=True)
class EvaluationConditions:
    """The conditions of an evaluation (module docstring); frozen, plain-data round-trippable.

    Attributes:
        heading: Start heading. Radians; or ``"random"`` (uniform in ``[0, 2 pi)``).
        position_jitter: Radius of the disc the start is drawn from, around the nominal start.
            Metres; 0: exactly the nominal start.
        sensor_noise: Standard deviation of Gaussian noise on every sensor value (its units).
        actuator_noise: Standard deviation of Gaussian noise on every normalised hinge target.
        reset_noise_scale: Half-width of the uniform noise on every active hinge's start angle
            (radians) and speed (radians per second); 0: at rest at 0.

    Raises:
        ValueError: a heading that is neither a finite number nor ``"random"``, a negative or
            non-finite jitter or noise, a jitter beyond :data:`MAX_RADIUS` or a reset noise
            beyond :data:`MAX_RESET_NOISE_SCALE` (the message names the field).
    """

    heading: float | Literal["random"] = 0.0
    position_jitter: float = 0.0
    sensor_noise: float = 0.0
    actuator_noise: float = 0.0
    reset_noise_scale: float = 0.0

    def __post_init__(self) -> None:
        heading = self.heading
        if heading != RANDOM_HEADING and not _finite(heading):
            raise ValueError(
                f"heading must be a number of radians or {RANDOM_HEADING!r}, got {heading!r}")
        if heading != RANDOM_HEADING:
            object.__setattr__(self, "heading", float(heading))
        for name in ("position_jitter", "sensor_noise", "actuator_noise", "reset_noise_scale"):
            value = getattr(self, name)
            if not (_finite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
            object.__setattr__(self, name, float(value))
        if self.position_jitter > MAX_RADIUS:
            raise ValueError(f"position_jitter must be <= {MAX_RADIUS:g} m, got "
                             f"{self.position_jitter!r}")
        if self.reset_noise_scale > MAX_RESET_NOISE_SCALE:
            raise ValueError(f"reset_noise_scale must be <= pi/4 rad (a hinge's range), got "
                             f"{self.reset_noise_scale!r}")

    @property
    def random_heading(self) -> bool:
        """Whether the heading is drawn."""
        return self.heading == RANDOM_HEADING

    @property
    def noisy(self) -> bool:
        """Whether sensor or actuator noise is on."""
        return self.sensor_noise > 0 or self.actuator_noise > 0

    def start(self, rng: np.random.Generator,
              nominal: tuple[float, float] = (0.0, 0.0)) -> Start:
        """Draw a start around ``nominal`` (metres): the jitter first, then the heading.

        Nothing is drawn from ``rng`` for a fixed heading and no jitter.
        """
        x, y = float(nominal[0]), float(nominal[1])
        if self.position_jitter > 0:
            radius = self.position_jitter * math.sqrt(float(rng.uniform(0.0, 1.0)))
            angle = float(rng.uniform(0.0, 2.0 * math.pi))
            x, y = x + radius * math.cos(angle), y + radius * math.sin(angle)
        if self.heading == RANDOM_HEADING:
            yaw = float(rng.uniform(0.0, 2.0 * math.pi))
        else:
            yaw = float(self.heading)
        return Start((x, y), yaw)

    def start_joints(self, rng: np.random.Generator, n: int
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
        """Draw the start angles (radians) and speeds (rad/s) of ``n`` active hinges.

        Uniform in ``[-reset_noise_scale, reset_noise_scale]``, the angles first; None (at rest
        at 0), and nothing drawn from ``rng``, when ``reset_noise_scale`` is 0. Drawn after
        :meth:`start`, from the same generator.
        """
        scale = self.reset_noise_scale
        if scale <= 0:
            return None
        return rng.uniform(-scale, scale, n), rng.uniform(-scale, scale, n)

    def to_dict(self) -> dict[str, Any]:
        """Plain data (JSON/TOML-compatible).

        ``reset_noise_scale`` appears only when it is not 0, so the conditions stored before it
        existed (every experiment's) are written as they were.
        """
        data = {f.name: getattr(self, f.name) for f in fields(self)}
        if not self.reset_noise_scale:
            del data["reset_noise_scale"]
        return data

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> EvaluationConditions:
        """Build from plain data; missing keys take the defaults.

        Raises:
            ValueError: an unknown key (the known ones are listed) or a bad value.
        """
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"unknown evaluation condition(s): {', '.join(unknown)}; known: "
                             f"{', '.join(sorted(known))}")
        return cls(**dict(data))


IDEAL = EvaluationConditions()
"""Heading 0 at the nominal start, no noise: the conditions of every offline evaluation before
conditions existed (and the default of :func:`revolve_env.evaluate`)."""


def add_sensor_noise(values: NDArray[np.float64], noise: float, rng: np.random.Generator,
                     low: NDArray[np.float64], high: NDArray[np.float64]
                     ) -> NDArray[np.float64]:
    """Sensor ``values`` with Gaussian noise of std ``noise``, clipped to ``[low, high]``.

    The one noise rule of evaluations and both worlds of robots: touch and light readings stay in
    [0, 1] (:func:`revolve_env.body.parts.sensor_bounds`). With ``noise == 0`` the values are
    returned as they are and nothing is drawn from ``rng``.
    """
    if noise <= 0:
        return values
    noisy = values + rng.normal(0.0, noise, values.shape)
    return np.minimum(np.maximum(noisy, low), high)


def add_actuator_noise(targets: NDArray[np.float64], noise: float, rng: np.random.Generator
                       ) -> NDArray[np.float64]:
    """Normalized hinge ``targets`` with Gaussian noise of std ``noise`` (a new array).

    The other half of the noise rule (:func:`add_sensor_noise`): the world clips the noisy
    targets to [-1, 1]. With ``noise == 0`` the targets are returned as they are and nothing is
    drawn from ``rng``.
    """
    if noise <= 0:
        return targets
    return targets + rng.normal(0.0, noise, targets.shape)


def with_noise_shortcuts(conditions: EvaluationConditions | None, sensor_noise: float,
                         actuator_noise: float) -> EvaluationConditions:
    """``conditions``, or the ``sensor_noise``/``actuator_noise`` shortcuts as conditions.

    The rule of ``evaluate`` and ``LocomotionEnv``, which take both: :data:`IDEAL` when neither
    is given.

    Raises:
        TypeError: ``conditions`` is not an :class:`EvaluationConditions`.
        ValueError: the noise is given both ways.
    """
    if conditions is None:
        if sensor_noise == 0 and actuator_noise == 0:
            return IDEAL
        return EvaluationConditions(sensor_noise=sensor_noise, actuator_noise=actuator_noise)
    if not isinstance(conditions, EvaluationConditions):
        raise TypeError(f"conditions must be an EvaluationConditions, got "
                        f"{type(conditions).__name__}")
    if sensor_noise or actuator_noise:
        raise ValueError("give the noise either in conditions or as sensor_noise/actuator_noise, "
                         "not both")
    return conditions


def with_reset_noise(conditions: EvaluationConditions, reset_noise_scale: float | None,
                     conditions_given: bool) -> EvaluationConditions:
    """The envs' start noise rule: ``conditions`` with the ``reset_noise_scale`` an env uses.

    The keyword ``reset_noise_scale`` when given; else the conditions' own when the caller gave
    conditions (an experiment's: 0, the paper's start); else :data:`DEFAULT_RESET_NOISE_SCALE`.

    Raises:
        ValueError: a bad ``reset_noise_scale`` (negative, not finite, beyond pi/4).
    """
    if reset_noise_scale is None:
        if conditions_given:
            return conditions
        reset_noise_scale = DEFAULT_RESET_NOISE_SCALE
    return replace(conditions, reset_noise_scale=reset_noise_scale)
