"""The single-robot env's default robot and times, and its episode-length rule.

Shared by the env (:class:`~revolve_env.envs.LocomotionEnv`) and its Gymnasium registration
(:mod:`revolve_env.registration`, which names the env by its dotted path): below both, so that
neither imports the other. Imports nothing.
"""

from __future__ import annotations

__all__ = ["DEFAULT_CONTROL_PERIOD", "DEFAULT_EVALUATION_TIME", "DEFAULT_INSERTION_TIME",
           "DEFAULT_MAX_EPISODE_STEPS", "DEFAULT_ROBOT", "episode_steps"]

DEFAULT_ROBOT = "spider"
"""The robot of ``gym.make`` without ``robot=``: an example name."""
DEFAULT_INSERTION_TIME = 3.0
"""The paper's settling phase before the evaluation, not scored. Seconds."""
DEFAULT_EVALUATION_TIME = 12.0
"""The paper's evaluation time (and fitness window). Seconds."""
DEFAULT_CONTROL_PERIOD = 1.0 / 60.0
"""Time per env step of the default :class:`~revolve_env.world.WorldConfig`. Seconds. A copy,
because importing ``revolve_env`` (which registers the envs) must not import the world package;
``tests/test_registration.py`` holds the two equal."""


def episode_steps(insertion_time: float, evaluation_time: float,
                  control_period: float) -> tuple[int, int]:
    """``(insertion steps, steps of the whole episode)`` of the single-robot env.

    Args:
        insertion_time: Settling phase. Seconds.
        evaluation_time: Scored phase. Seconds.
        control_period: Time per env step. Seconds.
    """
    insertion = round(insertion_time / control_period)
    return insertion, insertion + round(evaluation_time / control_period)


DEFAULT_MAX_EPISODE_STEPS = episode_steps(DEFAULT_INSERTION_TIME, DEFAULT_EVALUATION_TIME,
                                          DEFAULT_CONTROL_PERIOD)[1]
"""Steps of an episode with the default times (900): the registered ``max_episode_steps``."""
