"""One episode of the single-robot env, the one loop every env-driven rollout uses.

The learners' candidate evaluation through the Gym env, the SB3 learner's inborn-vs-trained
comparison and the video recorder all step :class:`~revolve_env.envs.LocomotionEnv` from reset
to the end of its episode; :func:`run_episode` is that loop. (:func:`revolve_env.evaluate` steps
the world directly, without the env's overhead, and gives the same numbers.)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from revolve_env.envs.locomotion import LocomotionEnv

__all__ = ["Policy", "StepHook", "run_episode"]

Policy = Callable[[NDArray[np.float64]], NDArray[np.floating[Any]]]
"""Maps an observation to an action of the env's action space."""

StepHook = Callable[[int, dict[str, Any]], None]
"""Called after every step with the step's number (1, 2, ...) and its info."""


def run_episode(env: LocomotionEnv, seed: int | None, act: Policy | None = None,
                on_step: StepHook | None = None) -> dict[str, Any]:
    """Reset ``env`` with ``seed`` and step it until the episode ends.

    Args:
        env: The env (not closed here).
        seed: The reset's seed (``None``: the env's generator goes on unseeded).
        act: The action for each observation; ``None`` sends zeros (with ``controller="brain"``
            the robot's own network drives it, and ``action="modulate"`` zeros leave it as is).
        on_step: Called after every step (e.g. to record a video frame).

    Returns:
        The info of the last step (fitness, its terms, ``blow_up``, ...).
    """
    obs, info = env.reset(seed=seed)
    shape = env.action_space.shape or (0,)
    zero = np.zeros(shape, dtype=np.float32)
    step = 0
    while True:
        obs, _, terminated, truncated, info = env.step(zero if act is None else act(obs))
        step += 1
        if on_step is not None:
            on_step(step, info)
        if terminated or truncated:
            return info
