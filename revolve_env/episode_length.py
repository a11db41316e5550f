"""The single-robot env's default robot and times, and its episode-length rule.

Shared by the env (:class:`~revolve_env.envs.LocomotionEnv`) and its Gymnasium registration
(:mod:`revolve_env.registration`, which names the env by its dotted path): below both, so that
neither imports the other. Imports nothing of this package.
"""

from __future__ import annotations

from typing import Any

__all__ = ["DEFAULT_CONTROL_PERIOD", "DEFAULT_EVALUATION_TIME", "DEFAULT_INSERTION_TIME",
           "DEFAULT_MAX_EPISODE_STEPS", "DEFAULT_ROBOT", "check_time_limit", "episode_steps"]

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


def check_time_limit(limit: int | None, env: Any) -> None:
    """Refuse a ``max_episode_steps`` that would end ``env``'s episodes early (None, -1: none).

    ``env``: a :class:`~revolve_env.envs.LocomotionEnv` (its times and control period).

    Raises:
        ValueError: the limit is shorter than the env's episode (one line: what to pass).
    """
    dt = float(env.config.control_period)
    insertion, total = episode_steps(env.insertion_time, env.evaluation_time, dt)
    if limit is None or limit < 0 or limit >= total:
        return
    what = (f"ends every episode within the {insertion}-step insertion phase, which is not "
            "scored (every return would be 0)" if limit <= insertion else
            f"cuts the {total}-step episode short")
    raise ValueError(
        f"max_episode_steps={limit} {what}: an episode is {env.insertion_time:g} s + "
        f"{env.evaluation_time:g} s at {dt:.4g} s per step; pass max_episode_steps={total} "
        "(or -1), or choose shorter insertion_time/evaluation_time")
