"""Reinforcement learning on one robot that walks out of the box (stable-baselines3).

PPO on ``revolve_env/Locomotion-v1`` learns to walk when its env is set up as
``benchmarks/bench_rl.py`` found: observations and rewards normalised (``VecNormalize``: the
observation mixes accelerations up to 157 m/s^2 with radians, and a step's reward is about
0.01 m), short episodes (0.5 s insertion + 2.5 s evaluation, five times the episodes per step of
the paper's 3 s + 12 s) and several envs. A plain ``PPO("MlpPolicy", gym.make(...))`` learns
next to nothing in 100 k steps. Three calls::

    from revolve_env import rl

    venv = rl.make_vec_env("spider", seed=0)           # the normalised, short-episode VecEnv
    model = rl.make_ppo(venv, seed=0).learn(100_000)   # PPO with the benchmark's settings
    fitness = rl.policy_fitness(model, venv)           # the paper's 3 s + 12 s, metres

:func:`policy_fitness` evaluates on episodes of any length with the normalisation statistics
frozen: it copies them (:class:`ObservationNormalization`) before the first step, so neither the
evaluation nor further training changes what the policy sees; the same frozen statistics go with
a policy that drives a robot elsewhere (:class:`evolution.learning.PolicyAgent`).

Episodes shorter than the insertion phase cannot happen here: :class:`VecEnvConfig` refuses an
evaluation time of 0, and ``gym.make`` refuses a ``max_episode_steps`` that ends episodes early
(:mod:`revolve_env.registration`).

stable-baselines3 is in the ``learn`` extra (``pip install 'revolve-env[learn]'``); it is imported
when a function here needs it, never by ``import revolve_env``.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from revolve_env.body.examples import resolve_robot
from revolve_env.body.robot import Robot
from revolve_env.registration import (
    DEFAULT_EVALUATION_TIME,
    DEFAULT_INSERTION_TIME,
    LOCOMOTION_ID,
    LOCOMOTION_V1_ID,
)
from revolve_env.tasks import Locomotion

if TYPE_CHECKING:
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecEnv, VecNormalize

__all__ = [
    "INSTALL_HINT",
    "TRAINING_TASK",
    "ObservationNormalization",
    "VecEnvConfig",
    "make_ppo",
    "make_vec_env",
    "policy_fitness",
    "ppo_settings",
]

INSTALL_HINT = "stable-baselines3 is needed: pip install 'revolve-env[learn]'"
"""What to install for this module (the message of its ImportError)."""

_EPISODE_KEYS = ("insertion_time", "evaluation_time", "fitness_window")

TRAINING_TASK = Locomotion(pose_rate="every-period")
"""The task :func:`make_vec_env` trains on unless given one: the paper's ``f = v + 5 s`` with
the core's pose sampled every control period, so that PPO's reward (the fitness gain of each
step) is dense; the README's PPO figures were measured so. :func:`policy_fitness` scores with
the training env's task."""


def _sb3() -> Any:
    """The ``stable_baselines3`` module, or an ImportError saying what to install."""
    try:
        import stable_baselines3
    except ImportError as error:
        raise ImportError(INSTALL_HINT) from error
    return stable_baselines3


@dataclass(frozen=True, slots=True)
class VecEnvConfig:
    """The training env of :func:`make_vec_env`: episodes, envs and normalisation.

    Attributes:
        n_envs: Envs stepped together (one PPO rollout holds ``n_steps`` steps of each).
        insertion_time: Settling phase of each training episode, not scored. Seconds.
        evaluation_time: Scored phase of each training episode, and the fitness window, so that
            an episode's return is its fitness. Seconds (> 0).
        normalize: Normalise observations and rewards (``VecNormalize``, running statistics).
        clip_obs: Normalised observations are clipped to ``[-clip_obs, clip_obs]``.
        gamma: Discount of the reward normalisation (the return it scales by); the algorithm's
            own ``gamma`` should be the same (:func:`make_ppo` takes it from here).
        subprocess: One process per env (``SubprocVecEnv``) instead of all in this one.
        batched: All envs in one native vector env
            (:class:`~revolve_env.envs.sb3_vector.NativeVecEnv`: the robots stepped in one
            batch, bit for bit the single envs' steps, for less work per step); False:
            ``DummyVecEnv`` of single envs. Ignored with ``subprocess``.
    """

    n_envs: int = 4
    insertion_time: float = 0.5
    evaluation_time: float = 2.5
    normalize: bool = True
    clip_obs: float = 10.0
    gamma: float = 0.99
    subprocess: bool = False
    batched: bool = True

    def __post_init__(self) -> None:
        if isinstance(self.n_envs, bool) or not isinstance(self.n_envs, int) or self.n_envs < 1:
            raise ValueError(f"n_envs must be an integer >= 1, got {self.n_envs!r}")
        if not (math.isfinite(self.insertion_time) and self.insertion_time >= 0):
            raise ValueError("insertion_time must be a finite number of seconds >= 0, got "
                             f"{self.insertion_time}")
        if not (math.isfinite(self.evaluation_time) and self.evaluation_time > 0):
            raise ValueError("evaluation_time must be a positive number of seconds (an episode "
                             "that ends in the insertion phase earns 0), got "
                             f"{self.evaluation_time}")
        if not (math.isfinite(self.clip_obs) and self.clip_obs > 0):
            raise ValueError(f"clip_obs must be a positive number, got {self.clip_obs}")
        if not 0 < self.gamma <= 1:
            raise ValueError(f"gamma must be in (0, 1], got {self.gamma}")


@dataclass(frozen=True, slots=True, eq=False)
class ObservationNormalization:
    """Frozen observation statistics: ``clip((obs - mean) / sqrt(var + epsilon), -clip, clip)``.

    What ``VecNormalize`` does to an observation, with statistics that no longer change
    (float32 out, as ``VecNormalize.normalize_obs``).

    Attributes:
        mean: Mean of each observation value (units of the value).
        var: Variance of each value.
        clip: Bound of the normalised values.
        epsilon: Added to the variance (no division by 0).
    """

    mean: NDArray[np.float64]
    var: NDArray[np.float64]
    clip: float
    epsilon: float

    def __post_init__(self) -> None:
        for name in ("mean", "var"):
            value = np.array(getattr(self, name), dtype=np.float64)  # a copy: frozen
            if value.ndim != 1 or not np.isfinite(value).all():
                raise ValueError(f"{name} must be a finite vector, got shape {value.shape}")
            value.flags.writeable = False
            object.__setattr__(self, name, value)
        if self.mean.shape != self.var.shape or (self.var < 0).any():
            raise ValueError("mean and var must have one shape and var must be >= 0")
        if not (math.isfinite(self.clip) and self.clip > 0 and math.isfinite(self.epsilon)
                and self.epsilon >= 0):
            raise ValueError(f"clip must be > 0 and epsilon >= 0, got {self.clip}, "
                             f"{self.epsilon}")

    @classmethod
    def of(cls, venv: VecNormalize) -> ObservationNormalization:
        """A frozen copy of ``venv``'s current observation statistics."""
        if not venv.norm_obs:
            raise ValueError("this VecNormalize does not normalise observations")
        rms: Any = venv.obs_rms
        return cls(rms.mean, rms.var, float(venv.clip_obs), float(venv.epsilon))

    def __call__(self, observation: NDArray[np.floating[Any]]) -> NDArray[np.float32]:
        """The normalised observation (any leading batch dimensions)."""
        out = np.clip((np.asarray(observation, dtype=np.float64) - self.mean)
                      / np.sqrt(self.var + self.epsilon), -self.clip, self.clip)
        return out.astype(np.float32)


@dataclass(frozen=True, slots=True, eq=False)
class _Maker:
    """A picklable maker of one monitored training env (for ``SubprocVecEnv`` too)."""

    env_id: str
    kwargs: dict[str, Any]

    def __call__(self) -> gym.Env[Any, Any]:
        from stable_baselines3.common.monitor import Monitor

        with warnings.catch_warnings():
            if self.env_id == LOCOMOTION_ID:  # chosen on purpose (RoboGen's sensors only)
                warnings.filterwarnings("ignore", message=".*Locomotion-v0 is out of date",
                                        category=DeprecationWarning)
            # No TimeLimit: the env truncates itself at the end of its (short) episode.
            env = gym.make(self.env_id, max_episode_steps=-1, **self.kwargs)
        return Monitor(env)


def make_vec_env(robot: Robot | str | os.PathLike[str] = "spider",
                 config: VecEnvConfig | None = None, *, seed: int = 0,
                 env_id: str = LOCOMOTION_V1_ID, **env_kwargs: Any) -> VecEnv:
    """The normalised, short-episode vector env of ``robot`` for stable-baselines3, in one call.

    ``config.n_envs`` copies of ``env_id`` (hinge angles and velocities observed), stepped in one
    batch (:class:`~revolve_env.envs.sb3_vector.NativeVecEnv`, unless ``config.batched`` is
    off), each episode ``config.insertion_time + config.evaluation_time`` seconds with the
    fitness window equal to the evaluation time (the return is the fitness, in metres), each env
    reporting as a ``Monitor`` (so ``model.ep_info_buffer`` and ``rollout/ep_rew_mean`` work),
    seeded ``seed, seed + 1, ...``,
    under ``VecNormalize(norm_obs=True, norm_reward=True)`` unless ``config.normalize`` is off.

    Args:
        robot: A Robot, an example name or a robot JSON file (resolved once, here).
        config: Episodes, envs and normalisation (``None``: :class:`VecEnvConfig`'s defaults).
        seed: Seed of the first env's first reset (env ``i``: ``seed + i``).
        env_id: The Gymnasium id (``Locomotion-v1``; ``Locomotion-v0`` observes the sensors
            only).
        **env_kwargs: More :class:`~revolve_env.envs.LocomotionEnv` keywords: ``task``
            (default :data:`TRAINING_TASK`: the fitness gain every control period as the
            reward; at the paper's 5 Hz pose rate the reward is 0 on 11 steps of 12), ``action``
            (``"targets"`` or ``"modulate"``, which runs the robot's own network under the
            policy), ``engine``, ``conditions``, ``control_period``, ...; the episode's times are
            ``config``'s.

    Returns:
        The ``VecNormalize`` (or, without normalisation, the plain ``VecEnv``).

    Raises:
        ImportError: stable-baselines3 is not installed (one line: what to install).
        ValueError: an episode time among ``env_kwargs``, or a bad robot or keyword (the env's
            own one-line errors, raised here before any process starts).
    """
    _sb3()
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecNormalize

    config = VecEnvConfig() if config is None else config
    clash = sorted(set(env_kwargs) & set(_EPISODE_KEYS))
    if clash:
        raise ValueError(f"{', '.join(clash)}: the episode's times are VecEnvConfig's "
                         "(insertion_time, evaluation_time; the fitness window is the latter)")
    kwargs = {"robot": resolve_robot(robot)[0], "insertion_time": config.insertion_time,
              "evaluation_time": config.evaluation_time,
              "fitness_window": config.evaluation_time, "task": TRAINING_TASK, **env_kwargs}
    _Maker(env_id, kwargs)().close()  # bad keywords fail here, in one line, not in a worker
    makers: list[Callable[[], gym.Env[Any, Any]]] = [
        _Maker(env_id, kwargs) for _ in range(config.n_envs)]
    venv: VecEnv
    if config.subprocess and config.n_envs > 1:
        venv = SubprocVecEnv(makers, start_method="forkserver")
    elif config.batched:
        from revolve_env.envs.sb3_vector import NativeVecEnv

        venv = NativeVecEnv(env_id, config.n_envs, **kwargs)
    else:
        venv = DummyVecEnv(makers)
    venv.seed(seed)
    if not config.normalize:
        return venv
    return VecNormalize(venv, norm_obs=True, norm_reward=True, clip_obs=config.clip_obs,
                        gamma=config.gamma)


def ppo_settings(action: str = "targets") -> dict[str, Any]:
    """The PPO keyword arguments ``benchmarks/bench_rl.py`` found (see its docstring).

    Args:
        action: The env's action mode: ``"modulate"`` starts with a small exploration noise
            (std 0.22) so that training begins on the robot's own gait.
    """
    log_std = -1.5 if action == "modulate" else 0.0
    return {"n_steps": 128, "batch_size": 64, "n_epochs": 10, "learning_rate": 3e-4,
            "gae_lambda": 0.95, "clip_range": 0.2, "ent_coef": 0.0,
            "policy_kwargs": {"log_std_init": log_std, "net_arch": [64, 64]}}


def make_ppo(venv: VecEnv, *, seed: int = 0, **overrides: Any) -> PPO:
    """stable-baselines3 PPO on ``venv`` with :func:`ppo_settings` (CPU, ``MlpPolicy``).

    Args:
        venv: The env of :func:`make_vec_env` (its action mode picks the exploration noise, its
            reward normalisation's ``gamma`` is PPO's).
        seed: PPO's seed (the policy's initial weights, its sampling and the envs' resets).
        **overrides: Any PPO keyword argument, replacing the settings' (``policy_kwargs`` as a
            whole).
    """
    sb3 = _sb3()
    from stable_baselines3.common.logger import Logger
    from stable_baselines3.common.vec_env import VecNormalize

    action = venv.get_attr("action_mode", [0])[0]
    settings = {**ppo_settings(action), "gamma": venv.gamma if isinstance(venv, VecNormalize)
                else 0.99, "verbose": 0, **overrides}
    model: PPO = sb3.PPO("MlpPolicy", venv, seed=seed, device="cpu", **settings)
    if not settings["verbose"] and settings.get("tensorboard_log") is None:
        # SB3's default logger makes an empty SB3-<time> folder in the temporary folder at
        # every learn(), even when it writes nothing.
        model.set_logger(Logger(folder=None, output_formats=[]))
    return model


def policy_fitness(model: Any, venv: VecEnv, *, seeds: Iterable[int] = (0,),
                   insertion_time: float = DEFAULT_INSERTION_TIME,
                   evaluation_time: float = DEFAULT_EVALUATION_TIME) -> float:
    """Fitness of ``model``'s deterministic policy in the paper's window, statistics frozen.

    One episode per seed (one by default) of the env ``venv`` trains on (same robot,
    observation and action modes, engine and conditions), but ``insertion_time`` +
    ``evaluation_time`` seconds long with the fitness window equal to the evaluation time. The
    observations are normalised with a frozen copy of ``venv``'s statistics
    (:class:`ObservationNormalization`): ``venv`` is not stepped and nothing in it changes.

    Args:
        model: A trained SB3 model (anything with ``predict(obs, deterministic=True)``).
        venv: Its training env from :func:`make_vec_env`.
        seeds: The episodes' reset seeds (the start and noise of ``conditions``). The hinges
            start at rest (``reset_noise_scale=0``, the paper's start) unless the training env
            was given ``conditions`` or a ``reset_noise_scale`` of its own.
        insertion_time: Settling phase, not scored. Seconds.
        evaluation_time: Scored phase and fitness window. Seconds.

    Returns:
        The fitness ``f = v + 5 s`` of the episode, the mean over the episodes when several
        seeds are given (a blown-up episode counts 0; for each episode's, call it per seed).
        Metres.

    Raises:
        ValueError: ``seeds`` is empty.
    """
    from stable_baselines3.common.vec_env import VecNormalize

    from revolve_env.envs.episode import run_episode

    seeds = list(seeds)
    if not seeds:
        raise ValueError("policy_fitness needs at least one seed")
    from revolve_env.envs.locomotion import LocomotionEnv

    spec = venv.get_attr("spec", [0])[0]
    normalize = (ObservationNormalization.of(venv)
                 if isinstance(venv, VecNormalize) and venv.norm_obs else None)
    kwargs = {**spec.kwargs, "insertion_time": insertion_time,
              "evaluation_time": evaluation_time, "fitness_window": evaluation_time}
    if "conditions" not in kwargs:  # the paper's start, unless the training env chose its own
        kwargs.setdefault("reset_noise_scale", 0.0)
    env = LocomotionEnv(**kwargs)

    def act(observation: NDArray[np.float64]) -> NDArray[np.float32]:
        obs = normalize(observation) if normalize is not None else observation
        action, _ = model.predict(obs, deterministic=True)
        return np.asarray(action, dtype=np.float32)

    try:
        fitness = []
        for seed in seeds:
            info = run_episode(env, seed, act)
            fitness.append(0.0 if info["blow_up"] is not None else float(info["fitness"]))
        return float(np.mean(fitness))
    finally:
        env.close()
