"""The single-robot env's Gymnasium ids, their registration, and the episode-length rule.

``import revolve_env`` registers (with string entry points, so no physics engine is imported):

* ``revolve_env/Locomotion-v1``: :class:`~revolve_env.envs.LocomotionEnv` with
  ``proprioception=True`` (RoboGen's sensors, then hinge angles and velocities): the one to use;
* ``revolve_env/Locomotion-v0``: RoboGen's sensors only, kept for code written against it
  (Gymnasium warns that it is out of date when it is made).

Both default to the spider (``gym.make("revolve_env/Locomotion-v1")``); ``robot=`` takes a
:class:`~revolve_env.body.robot.Robot`, an example name or a robot JSON file
(:func:`revolve_env.body.examples.resolve_robot`).

Episode length (the rule and the defaults are in :mod:`revolve_env.episode_length`, which the
env imports too): the env truncates itself after ``insertion_time + evaluation_time`` seconds,
:func:`episode_steps` control periods. The registered ``max_episode_steps`` is that of the
default times, :data:`DEFAULT_MAX_EPISODE_STEPS` (3 s + 12 s at 60 Hz = 900 steps), so that
``env.spec.max_episode_steps`` is the episode's length, and Gymnasium's ``TimeLimit`` (which
``gym.make`` wraps around every env with a ``max_episode_steps``) never ends an episode the env
would go on with:

* shorter times (e.g. ``evaluation_time=2.5``): the env truncates itself first; the limit is not
  reached (``spec.max_episode_steps`` is then an upper bound; pass
  ``max_episode_steps=episode_steps(...)[1]`` to ``gym.make`` to make it exact);
* longer times, or a smaller ``max_episode_steps`` given to ``gym.make``: the ``TimeLimit`` would
  cut the episode (a fitness over a shorter span, or 0 when it ends within the insertion phase,
  which is never scored). ``gym.make`` refuses that with a one-line ``ValueError`` naming the
  ``max_episode_steps`` to pass instead (the check is :class:`TimeLimitFits`, a wrapper the
  registration adds after the ``TimeLimit``); ``max_episode_steps=-1`` removes the limit.

``gym.make``'s layers stay what Gymnasium makes them (``TimeLimitFits``, ``TimeLimit``,
``OrderEnforcing``, ``PassiveEnvChecker``, the env), but once the lower three have nothing left
to check (the env reset, the env checker's first step seen) :class:`TimeLimitFits` steps the env
directly and applies the ``TimeLimit``'s count and truncation itself, as it would: the same
results and wrapper state, three Python calls fewer per step (a tenth of a step's overhead).
Gymnasium offers no public way to do that: the ``TimeLimit``'s count is private
(``_elapsed_steps``, ``_max_episode_steps``; the order enforcer's ``has_reset`` and the checker's
``checked_step``/``checked_data_reuse`` are public). So the shortcut is taken only where it is
shown to hold: once per process (and again if those wrappers' methods change) gym.make's three
layers around a small stand-in env are stepped both ways through two episodes, and any
difference in the results or in the layers' plain state (or an error) sends every step through
the layers as Gymnasium has them (:func:`shortcut_holds`).
"""

from __future__ import annotations

import dataclasses
import functools
import warnings
from collections.abc import Callable
from typing import Any, SupportsFloat

import gymnasium
import numpy as np
from gymnasium.envs.registration import EnvSpec, WrapperSpec
from gymnasium.wrappers import OrderEnforcing, PassiveEnvChecker, TimeLimit

from revolve_env.episode_length import (
    DEFAULT_CONTROL_PERIOD,
    DEFAULT_EVALUATION_TIME,
    DEFAULT_INSERTION_TIME,
    DEFAULT_MAX_EPISODE_STEPS,
    DEFAULT_ROBOT,
    check_time_limit,
    episode_steps,
)

__all__ = [
    "DEFAULT_CONTROL_PERIOD",
    "DEFAULT_EVALUATION_TIME",
    "DEFAULT_INSERTION_TIME",
    "DEFAULT_MAX_EPISODE_STEPS",
    "DEFAULT_ROBOT",
    "LOCOMOTION_ID",
    "LOCOMOTION_V1_ID",
    "VECTOR_ENTRY_POINT",
    "TimeLimitFits",
    "episode_steps",
    "register_envs",
    "shortcut_holds",
    "vector_spec",
]

LOCOMOTION_ID = "revolve_env/Locomotion-v0"
"""Gymnasium id of :class:`~revolve_env.envs.LocomotionEnv` observing RoboGen's sensors only."""
LOCOMOTION_V1_ID = "revolve_env/Locomotion-v1"
"""Gymnasium id of :class:`~revolve_env.envs.LocomotionEnv` with ``proprioception=True``."""

class TimeLimitFits(gymnasium.Wrapper[Any, Any, Any, Any],
                    gymnasium.utils.RecordConstructorArgs):
    """Refuses a ``TimeLimit`` that would end the single-robot env's episodes early.

    Added by the registration after ``gym.make``'s ``TimeLimit``; at construction it compares the
    limit (``env.spec.max_episode_steps``) with the env's own episode (:func:`episode_steps`) and
    raises ``ValueError`` when the limit is shorter; otherwise it passes everything through.
    """

    def __init__(self, env: gymnasium.Env[Any, Any]) -> None:
        gymnasium.utils.RecordConstructorArgs.__init__(self)
        gymnasium.Wrapper.__init__(self, env)
        check_time_limit(env.spec.max_episode_steps if env.spec is not None else None,
                         env.unwrapped)
        self._layers = _plain_layers(env)

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """The env's step through ``gym.make``'s layers, as they would take it.

        Once the layers below have nothing left to check (the env was reset, the env checker
        has seen a step), the step goes to the env directly and the ``TimeLimit``'s count and
        truncation are applied here, as that wrapper applies them: the same results, the same
        wrapper state, without three Python calls per step (where :func:`shortcut_holds`).
        """
        layers = self._layers
        if layers is None or self.env is not layers[0] or not _checked(layers):
            return self.env.step(action)
        return _direct_step(layers, action)


Layers = tuple[TimeLimit[Any, Any], OrderEnforcing[Any, Any], PassiveEnvChecker[Any, Any],
               gymnasium.Env[Any, Any]]
"""``gym.make``'s TimeLimit, OrderEnforcing, PassiveEnvChecker and the env, outer first."""


def _checked(layers: Layers) -> bool:
    """Whether the layers below the limit have nothing left to check (reset; a step seen)."""
    checker = layers[2]
    return layers[1].has_reset and checker.checked_step and checker.checked_data_reuse


def _direct_step(layers: Layers, action: Any
                 ) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
    """The env's step with the ``TimeLimit``'s count and truncation, once :func:`_checked`.

    (Gymnasium 1's private state of the limit, as its ``step`` keeps it.)
    """
    limit: Any = layers[0]
    obs, reward, terminated, truncated, info = layers[3].step(action)
    limit._elapsed_steps += 1
    if limit._elapsed_steps >= limit._max_episode_steps:
        truncated = True
    return obs, reward, terminated, truncated, info


def _plain_layers(env: gymnasium.Env[Any, Any]) -> Layers | None:
    """``gym.make``'s TimeLimit, OrderEnforcing and PassiveEnvChecker over the env, or None.

    Exactly those types, with the state their steps keep in Gymnasium 1, where the shortcut
    holds (:func:`shortcut_holds`).
    """
    limit = env
    order = getattr(limit, "env", None)
    checker = getattr(order, "env", None)
    inner = getattr(checker, "env", None)
    if (type(limit) is TimeLimit and type(order) is OrderEnforcing
            and type(checker) is PassiveEnvChecker and inner is not None
            and inner is env.unwrapped and _has_state(limit, order, checker)
            and shortcut_holds()):
        return limit, order, checker, inner
    return None


def _has_state(limit: object, order: object, checker: object) -> bool:
    """Whether the wrappers keep the state that the shortcut reads and writes."""
    return all(hasattr(w, a) for w, a in (
        (limit, "_elapsed_steps"), (limit, "_max_episode_steps"), (order, "has_reset"),
        (checker, "checked_step"), (checker, "checked_data_reuse")))


def shortcut_holds() -> bool:
    """Whether :class:`TimeLimitFits`' shortcut gives what gym.make's layers give.

    Checked (see the module doc) once per version of their ``step`` and ``reset`` methods.
    """
    return _shortcut_checked(tuple(getattr(cls, name)
                                   for cls in (TimeLimit, OrderEnforcing, PassiveEnvChecker)
                                   for name in ("step", "reset")))


class _StandIn(gymnasium.Env[Any, Any]):
    """A tiny env for the check: every step's results differ; it truncates itself at step 5."""

    observation_space = gymnasium.spaces.Box(-10.0, 10.0, (2,), np.float32)
    action_space = gymnasium.spaces.Box(-1.0, 1.0, (2,), np.float32)

    def __init__(self) -> None:
        self._t = 0

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[Any, dict[str, Any]]:
        super().reset(seed=seed)
        self._t = 0
        return np.zeros(2, dtype=np.float32), {"t": 0}

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        self._t += 1
        obs = np.asarray(action, dtype=np.float32) * np.float32(self._t)
        return obs, float(self._t), False, self._t >= 5, {"t": self._t}


@functools.cache
def _shortcut_checked(methods: tuple[Callable[..., Any], ...]) -> bool:
    """:func:`shortcut_holds` for one version of the wrappers' methods (``methods``: the key)."""
    def layers() -> Layers:
        inner = _StandIn()
        order = OrderEnforcing(PassiveEnvChecker(inner))
        return TimeLimit(order, max_episode_steps=3), order, order.env, inner  # type: ignore[return-value]

    def state(ls: Layers) -> list[dict[str, Any]]:  # the layers' plain-data state
        return [{k: v for k, v in vars(w).items() if isinstance(v, bool | int | float | str)}
                for w in ls[:3]]

    def result(out: tuple[Any, ...]) -> tuple[Any, ...]:
        return (np.asarray(out[0]).tobytes(), *out[1:])

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the checker's, on the stand-in: not the user's
            plain, short = layers(), layers()
            if not _has_state(*plain[:3]):
                return False
            for seed in (0, 1):  # two episodes: the second starts from a reset limit
                if plain[0].reset(seed=seed)[1] != short[0].reset(seed=seed)[1]:
                    return False
                for k in range(5):  # past the limit (3) and the stand-in's own end (5)
                    action = np.full(2, 0.25 * (k + 1), dtype=np.float32)
                    a = plain[0].step(action)
                    b = _direct_step(short, action) if _checked(short) else short[0].step(action)
                    if result(a) != result(b) or state(plain) != state(short):
                        return False
            return _checked(short)
    except Exception:  # noqa: BLE001 (internals that differ: the plain path, whatever the error)
        return False


def register_envs() -> None:
    """Register ``Locomotion-v0`` and ``-v1`` with Gymnasium (once; no physics is imported)."""
    check = WrapperSpec("TimeLimitFits", "revolve_env.registration:TimeLimitFits", {})
    for env_id, kwargs in ((LOCOMOTION_ID, {}), (LOCOMOTION_V1_ID, {"proprioception": True})):
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point="revolve_env.envs.locomotion:LocomotionEnv",
                               kwargs=kwargs, max_episode_steps=DEFAULT_MAX_EPISODE_STEPS,
                               additional_wrappers=(check,))


VECTOR_ENTRY_POINT = "revolve_env.envs.vector:LocomotionVectorEnv"
"""The native vector env of both ids (:class:`~revolve_env.envs.vector.LocomotionVectorEnv`)."""


def vector_spec(env_id: str = LOCOMOTION_V1_ID) -> EnvSpec:
    """``env_id``'s spec for ``gym.make_vec(..., vectorization_mode="vector_entry_point")``.

    ``gym.make_vec(vector_spec(), num_envs=64, vectorization_mode="vector_entry_point")`` makes
    the native vector env (64 robots stepped in one batch). The registered ids cannot carry the
    vector entry point themselves: Gymnasium refuses that mode for a spec with additional
    wrappers, and theirs (:class:`TimeLimitFits`) is what refuses a ``max_episode_steps`` that
    cuts ``gym.make``'s episodes short; the vector env makes that check itself.
    """
    spec = gymnasium.spec(env_id)
    return dataclasses.replace(spec, additional_wrappers=(), vector_entry_point=VECTOR_ENTRY_POINT)
