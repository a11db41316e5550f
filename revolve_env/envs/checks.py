"""Conformance checks of the envs, as library code (run by the tests, usable on your own robots).

``check_locomotion(robot)`` runs Gymnasium's ``check_env``, stable-baselines3's ``check_env`` (when
it is installed), a two-env determinism rollout and a pickle round trip of the spec-made env.
``registered_ids()`` lists this package's Gymnasium ids, so a check can cover every one of them.

``check_population(make_env)`` holds the population env to PettingZoo's contract while robots are
born and die mid-episode (:class:`BirthsAndDeaths`, by default every 10 and every 15 steps):
PettingZoo's ``parallel_api_test``, a two-env determinism rollout through the births
(:func:`check_population_determinism`, our seed test: PettingZoo's ``parallel_seed_test`` stops
after one step), ``parallel_to_aec`` with PettingZoo's ``api_test``, and SuperSuit's wrappers
(or, without SuperSuit, PettingZoo's own) constructed and stepped.
"""

from __future__ import annotations

import pickle
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.utils.env_checker import check_env, data_equivalence

from revolve_env.body.examples import bar_walker, gecko, sensor_crawler, snake, spider
from revolve_env.body.robot import Robot
from revolve_env.envs.population import Controller, PopulationEnv

__all__ = [
    "BirthsAndDeaths", "DeterminismRun", "check_determinism", "check_locomotion",
    "check_population", "check_population_determinism", "population_with_births",
    "registered_ids",
]

NAMESPACE = "revolve_env"


def registered_ids() -> list[str]:
    """Every Gymnasium id registered by this package (namespace ``revolve_env``)."""
    return sorted(i for i, spec in gym.registry.items() if spec.namespace == NAMESPACE)


def _rollout(env: gym.Env, seed: int, steps: int) -> tuple[np.ndarray, np.ndarray]:
    obs, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    observations, rewards = [obs], []
    for _ in range(steps):
        obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
        observations.append(obs)
        rewards.append(reward)
        if terminated or truncated:
            break
    return np.asarray(observations), np.asarray(rewards, dtype=np.float64)


def check_determinism(env_id: str, *, seed: int = 0, steps: int = 30, **kwargs: Any) -> None:
    """Two separately made envs given the same seed and actions must agree exactly.

    Raises:
        AssertionError: naming the first step where observations or rewards differ.
    """
    envs = [gym.make(env_id, **kwargs) for _ in range(2)]
    try:
        (obs_a, rew_a), (obs_b, rew_b) = (_rollout(e, seed, steps) for e in envs)
    finally:
        for e in envs:
            e.close()
    if obs_a.shape != obs_b.shape or not np.array_equal(obs_a, obs_b):
        raise AssertionError(f"{env_id}: observations differ between two envs seeded {seed}")
    if not np.array_equal(rew_a, rew_b):
        raise AssertionError(f"{env_id}: rewards differ between two envs seeded {seed}")


def check_locomotion(
    robot: Robot, env_id: str = "revolve_env/Locomotion-v0", *, steps: int = 30, **kwargs: Any
) -> None:
    """All conformance checks of the single-robot env on one robot.

    Args:
        robot: The robot (validated by the env).
        env_id: A registered id of this package.
        steps: Steps of the determinism rollout.
        **kwargs: More keyword arguments for the env (e.g. short ``evaluation_time`` for speed).

    Raises:
        AssertionError or the checkers' own errors, naming what failed.
    """
    kwargs = {"robot": robot, **kwargs}
    env = gym.make(env_id, **kwargs)
    try:
        with warnings.catch_warnings():
            # A headless machine has no window for render_mode="human"; the env warns and draws
            # off screen, which is what the checker's render pass then exercises.
            warnings.filterwarnings("ignore", message="render_mode='human' without a window")
            check_env(env.unwrapped)
            try:
                from stable_baselines3.common.env_checker import check_env as sb3_check_env
            except ImportError:
                pass
            else:
                sb3_check_env(env.unwrapped)
    finally:
        env.close()
    check_determinism(env_id, steps=steps, **kwargs)
    # Vector envs and process pools ship envs by pickling their constructor arguments.
    spec = gym.spec(env_id)
    clone = pickle.loads(pickle.dumps(kwargs))
    if clone["robot"] != robot:
        raise AssertionError(f"{env_id}: the robot does not survive a pickle round trip")
    pickle.loads(pickle.dumps(spec))


# -- the population env ---------------------------------------------------------------------------
def _newborns() -> tuple[tuple[Robot, Controller], ...]:
    # Every example body, of different sizes (3, 8, 2, 3, 3 active hinges; the sensor crawler's
    # touch and light sensors fill the sensor block past the IMU), under both kinds of control.
    return ((sensor_crawler(), "agent"), (spider(), "agent"), (snake(2), "brain"),
            (bar_walker(), "brain"), (snake(3), "agent"))


@dataclass(frozen=True, slots=True)
class BirthsAndDeaths:
    """A lifecycle for :class:`PopulationEnv`: births and deaths at fixed steps, inside the step.

    Step ``k`` (from 1 after ``reset``) adds a robot when ``k % birth_every == 0`` (the bodies of
    ``newborns`` in turn, at random free positions) and removes the oldest living robot when
    ``k % death_every == 0``, as PettingZoo's ``generated_agents_parallel_v0`` makes and ends its
    agents inside ``step``. Births stop once ``max_births`` is reached.

    Attributes:
        birth_every: Steps between births.
        death_every: Steps between deaths.
        newborns: ``(robot, controlled_by)`` of the successive births, cycled.
    """

    birth_every: int = 10
    death_every: int = 15
    newborns: tuple[tuple[Robot, Controller], ...] = field(default_factory=_newborns)

    def __post_init__(self) -> None:
        if self.birth_every < 1 or self.death_every < 1:
            raise ValueError(f"birth_every and death_every must be >= 1, got {self.birth_every} "
                             f"and {self.death_every}")
        if not self.newborns:
            raise ValueError("newborns must name at least one (robot, controlled_by)")

    def __call__(self, env: PopulationEnv, step: int) -> None:
        """Add and remove robots for step ``step`` of ``env``."""
        if step % self.birth_every == 0 and env.births < env.max_births:
            k = (step // self.birth_every - 1) % len(self.newborns)
            robot, controlled_by = self.newborns[k]
            env.add_robot(robot, controlled_by=controlled_by)
        if step % self.death_every == 0 and env.robot_ids:
            env.remove_robot(env.robot_ids[0])


def population_with_births(**kwargs: Any) -> PopulationEnv:
    """A population env whose robots are born every 10 steps and die every 15 (mid-episode).

    It starts with a gecko (agent-controlled) and a 3-hinge snake (brain-controlled); the keyword
    arguments override these defaults: ``lifecycle=BirthsAndDeaths()``, ``max_births=40``,
    ``birth_radius=3.0``, ``space_mode="uniform"``.
    """
    defaults: dict[str, Any] = {
        "initial_robots": [{"robot": gecko(), "controlled_by": "agent"}, snake(3)],
        "lifecycle": BirthsAndDeaths(), "max_births": 40, "birth_radius": 3.0,
        "space_mode": "uniform",
    }
    return PopulationEnv(**{**defaults, **kwargs})


@contextmanager
def _warnings_as_errors() -> Iterator[None]:
    # PettingZoo's tests report a live agent missing from a dict, or a dead one in it, as warnings.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.filterwarnings("ignore", category=DeprecationWarning)
        yield


def _check_spaces(env: PopulationEnv) -> None:
    """Every agent of possible_agents has spaces, the same objects on every call.

    Except a dead agent once its spaces are released (the step after the one that reported its
    death): a KeyError naming it dead.
    """
    for agent in env.possible_agents:
        try:
            obs_space, act_space = env.observation_space(agent), env.action_space(agent)
        except KeyError as e:
            if agent in env.agents or "is dead" not in str(e):
                raise
            continue
        if not (env.observation_space(agent) is obs_space and env.action_space(agent) is act_space):
            raise AssertionError(f"{agent}: the spaces are not the same object on every call")


def _sample(env: PopulationEnv, rng: np.random.Generator, scale: float = 1.0) -> dict[str, Any]:
    return {a: (scale * rng.uniform(-1.0, 1.0, env.action_space(a).shape)).astype(np.float32)
            for a in env.agents}


@dataclass(frozen=True, slots=True)
class DeterminismRun:
    """What :func:`check_population_determinism` went through (so a test can require births).

    Attributes:
        steps: Steps compared.
        births: Robots born after ``reset``.
        deaths: Robots reported dead (removed, blown up) or truncated.
    """

    steps: int
    births: int
    deaths: int


def check_population_determinism(
    make_env: Callable[[], PopulationEnv], *, seed: int = 0, steps: int = 60
) -> DeterminismRun:
    """Two envs given the same seed and actions agree step by step, through births and deaths.

    Compared after ``reset`` and every step: all five dicts and ``agents``. It runs ``steps``
    steps, or until no agent is left. This is the project's seed test: PettingZoo's
    ``parallel_seed_test`` stops after its first step (it tests ``any()`` of the terminations
    dict, i.e. of its keys) and seeds only the action spaces of the agents present at reset.

    Raises:
        AssertionError: naming the first step and what differs.
    """
    envs = [make_env(), make_env()]
    births = deaths = k = 0
    try:
        first = [e.reset(seed=seed) for e in envs]
        if not data_equivalence(first[0], first[1]) or envs[0].agents != envs[1].agents:
            raise AssertionError(f"reset(seed={seed}) differs between two envs")
        born = envs[0].births
        rngs = [np.random.default_rng(seed), np.random.default_rng(seed)]
        names = ("observations", "rewards", "terminations", "truncations", "infos")
        for k in range(1, steps + 1):  # noqa: B007 - k is the count of steps run
            out = [e.step(_sample(e, r)) for e, r in zip(envs, rngs, strict=True)]
            for name, a, b in zip(names, out[0], out[1], strict=True):
                if not data_equivalence(a, b):
                    raise AssertionError(f"step {k}: {name} differ between two envs seeded {seed}")
            if envs[0].agents != envs[1].agents:
                raise AssertionError(f"step {k}: agents differ between two envs seeded {seed}")
            terminations, truncations = out[0][2], out[0][3]
            deaths += sum(terminations[a] or truncations[a] for a in terminations)
            if not envs[0].agents:
                break
        births = envs[0].births - born
    finally:
        for e in envs:
            e.close()
    return DeterminismRun(k, births, deaths)


def check_population(
    make_env: Callable[[], PopulationEnv] = population_with_births, *, num_cycles: int = 60
) -> None:
    """PettingZoo conformance of a population env, with births and deaths mid-episode.

    Args:
        make_env: Makes a fresh env (with a ``lifecycle``, so that robots are born and die inside
            the steps, as converters and wrappers need).
        num_cycles: Steps per episode of each test.

    Raises:
        AssertionError or PettingZoo's and SuperSuit's own errors, naming what failed; warnings
        of PettingZoo's tests (a dict missing a live agent, a dead agent given a value) are
        raised as errors.
    """
    from pettingzoo.test import api_test, parallel_api_test
    from pettingzoo.utils.conversions import parallel_to_aec

    env = make_env()
    lifecycle = env.lifecycle
    if lifecycle is None:
        raise AssertionError("make_env must give an env with a lifecycle (births and deaths)")
    counts = {"born": 0, "died": 0}

    def counting(e: PopulationEnv, step: int) -> None:
        births, alive = e.births, len(e.robot_ids)
        lifecycle(e, step)
        counts["born"] += e.births - births
        counts["died"] += alive + e.births - births - len(e.robot_ids)

    env.lifecycle = counting
    # Before any reset no agent is born. (A separate env: in exact mode, asking an unborn agent's
    # spaces gives it the uniform ones, and the API test should see exact ones too.)
    _check_spaces(make_env())
    with _warnings_as_errors():
        # The test sets env.max_cycles = num_cycles (PettingZoo's convention), so each episode
        # ends truncated; it then expects every possible agent to have lived, but the pool of
        # possible agents holds robots never born.
        warnings.filterwarnings("ignore", message="No agents present but not all possible_agents")
        parallel_api_test(env, num_cycles=num_cycles)
    if not (counts["born"] and counts["died"]):
        raise AssertionError(f"the API test saw {counts['born']} births and {counts['died']} "
                             "deaths mid-episode: raise num_cycles")
    _check_spaces(env)  # born, dead and unborn agents
    env.close()
    run = check_population_determinism(make_env, steps=num_cycles)
    if not (run.births and run.deaths):
        raise AssertionError(f"the determinism check saw {run.births} births and {run.deaths} "
                             "deaths: raise num_cycles")
    with _warnings_as_errors():
        # Exact spaces differ between bodies and keep the raw IMU readings, unbounded: by design;
        # PettingZoo's test only suspects both (it lists the envs it lets off by name).
        warnings.filterwarnings("ignore", message=r"Agent's m\w+ observation space value is -?inf")
        warnings.filterwarnings("ignore", message="Observations are different shapes")
        api_test(parallel_to_aec(make_env()), num_cycles=num_cycles)
    _check_aec_births(make_env, num_cycles)
    _check_wrappers(make_env, num_cycles)


def _check_aec_births(make_env: Callable[[], PopulationEnv], num_cycles: int) -> None:
    """Through ``parallel_to_aec``, late-born agents take turns and see observations."""
    from pettingzoo.utils.conversions import parallel_to_aec
    from pettingzoo.utils.env_logger import EnvLogger
    from pettingzoo.utils.wrappers import ClipOutOfBoundsWrapper

    env = make_env()
    aec = ClipOutOfBoundsWrapper(parallel_to_aec(env))
    aec.reset(seed=1)
    initial = set(aec.agents)
    rng = np.random.default_rng(1)
    acted: set[str] = set()
    for agent in aec.agent_iter(max_iter=num_cycles * 8):
        obs, _, terminated, truncated, _ = aec.last()
        if terminated or truncated:
            aec.step(None)
            continue
        if not aec.observation_space(agent).contains(obs):
            raise AssertionError(f"parallel_to_aec: {agent}'s observation is outside its space")
        acted.add(agent)
        # Out-of-bounds actions: PettingZoo's ClipOutOfBoundsWrapper clips them (and would log
        # every one).
        EnvLogger.suppress_output()
        try:
            aec.step((2.0 * rng.uniform(-1, 1, aec.action_space(agent).shape)).astype(np.float32))
        finally:
            EnvLogger.unsuppress_output()
    if not acted - initial:
        raise AssertionError("parallel_to_aec: no agent born after reset ever took a turn")
    aec.close()


def _check_wrappers(make_env: Callable[[], PopulationEnv], num_cycles: int) -> None:
    """SuperSuit's pad, clip and normalize wrappers built on the env and stepped through births."""
    try:
        import supersuit as ss
    except ImportError:
        return  # PettingZoo's own ClipOutOfBoundsWrapper was stepped in _check_aec_births
    env = make_env()
    wrapped = ss.clip_actions_v0(ss.normalize_obs_v0(ss.pad_action_space_v0(
        ss.pad_observations_v0(env)), env_min=-1.0, env_max=1.0))
    obs, _ = wrapped.reset(seed=2)
    initial = set(obs)
    seen: set[str] = set()
    rng = np.random.default_rng(2)
    for _ in range(num_cycles):
        actions = {a: (2.0 * rng.uniform(-1, 1, wrapped.action_space(a).shape)).astype(np.float32)
                   for a in wrapped.agents}
        obs, rewards, _, _, _ = wrapped.step(actions)
        for agent, o in obs.items():
            if not wrapped.observation_space(agent).contains(o.astype(np.float64)):
                raise AssertionError(f"SuperSuit: {agent}'s normalized observation {o} is outside "
                                     "[-1, 1]")
        if set(obs) != set(rewards):
            raise AssertionError("SuperSuit: observations and rewards name different agents")
        seen |= set(obs)
        if not wrapped.agents:
            break
    if not seen - initial:
        raise AssertionError("SuperSuit: no agent born after reset was ever reported")
    wrapped.close()
