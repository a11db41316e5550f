"""Locomotion fitness ``f = v + 5 s`` over a sliding time window (pure NumPy).

The one implementation used by the single-robot env, :func:`revolve_env.evaluate`, the population
env and evolution (Revolve paper, section 4): over the last ``window`` seconds (12 s by default),

* ``v`` is the length of the path travelled by the core in the horizontal plane (metres),
* ``s`` is the straight horizontal distance between the core's positions at the start and the end
  of the window (metres),
* ``f = v + s_weight * s`` with ``s_weight = 5``,

both from the core's pose sampled at the task's pose rate (5 Hz by default, the paper's; or every
control period): :mod:`revolve_env.fitness.sampling` holds that rule and the shaking measure.

:func:`fitness_terms` works on a whole trajectory, :func:`window_fitness` on the last ``window``
seconds of a time-stamped one. Online, :class:`FitnessWindows` keeps the windows of many robots
in one ring buffer (times, core positions and path lengths, one column per robot) and gives
every robot's terms at once with array operations (the one ring buffer);
:class:`SlidingWindowFitness` is one robot's window in it, with float-valued methods. The
formula ``v + s_weight * s`` itself is :func:`~revolve_env.fitness.terms.speed_fitness`, which
every form calls.

What a task (:mod:`revolve_env.tasks`) scores is a :class:`Window`: every robot's window as
arrays (its ends, ``v``, ``s``, its samples and, for a task that asks for one, a signal at both
ends); :meth:`FitnessWindows.window`, :meth:`SlidingWindowFitness.window` and
:func:`trajectory_window` (a whole evaluation) make one. ``v`` and ``s`` are the kinematic terms
of every task; ``f = v + 5 s`` is the paper's task, :class:`revolve_env.tasks.Locomotion`.
"""

from revolve_env.fitness.terms import (
    DEFAULT_S_WEIGHT,
    DEFAULT_WINDOW,
    FitnessTerms,
    Window,
    fitness_terms,
    trajectory_window,
    window_fitness,
)
from revolve_env.fitness.windows import FitnessWindows, SlidingWindowFitness

__all__ = [
    "DEFAULT_S_WEIGHT",
    "DEFAULT_WINDOW",
    "FitnessTerms",
    "FitnessWindows",
    "SlidingWindowFitness",
    "Window",
    "fitness_terms",
    "trajectory_window",
    "window_fitness",
]
