"""stable-baselines3 in the Training Center: train any SB3 algorithm on the infant's Gym env.

:class:`SB3Learner` trains an SB3 algorithm class (``PPO``, ``SAC``, ``TD3``, ... or its name)
on ``revolve_env/Locomotion-v0`` with the infant's body (``-v1`` with ``proprioception=True``:
the hinge angles and velocities observed too), in vectorised envs (``SubprocVecEnv``, or in this
process the native vector env, every robot stepped in one batch:
:class:`~revolve_env.envs.sb3_vector.NativeVecEnv`). Two action modes:

* ``action="targets"``: the policy sets every hinge target directly (the network is unused);
* ``action="modulate"``: the robot's own network (its CPG) keeps running and the policy scales
  and offsets its outputs; the zero action is the inborn gait, so training starts from it.

The training env is :func:`revolve_env.rl.make_vec_env`'s, the one ``benchmarks/bench_rl.py``
found PPO to need: observations and rewards normalised (``VecNormalize``; ``normalize=False``
turns it off) and short episodes (``insertion`` + ``seconds``); PPO starts from
:func:`revolve_env.rl.ppo_settings` (a small exploration noise in ``"modulate"`` mode, so
that the infant trains on its own gait), under ``algorithm_kwargs``. The observation
statistics are frozen when training ends and go with the policy
(:class:`~revolve_env.rl.ObservationNormalization` in :class:`PolicyAgent` and its file).

The trained policy becomes a :class:`PolicyAgent`: a small adapter that maps the robot's
observation (its sensor values, in input-neuron order, then with proprioception its hinge angles
and velocities) to hinge targets each control period, and
therefore drives the robot as an *agent-controlled* robot in the population env
(``add_robot(robot, controlled_by="agent")``) or in the single-robot env with
``controller="agent"``.

Budget: every simulated second is charged, the learner's own two evaluations (the inborn
controller and the trained policy, one episode of ``insertion + seconds`` each) included. The
rest buys ``rest / control_period`` training steps (summed over the parallel envs); on-policy
algorithms (PPO, A2C) train in whole rollouts of ``n_steps * n_envs`` steps, so the steps are
rounded *down* to whole rollouts (SB3 itself would round up and overspend). The smallest budget
(:attr:`SB3Learner.min_budget`) pays for the two evaluations and one rollout (off-policy: the
``learning_starts`` steps and one ``train_freq``); the Training Center refuses a smaller one.
:attr:`LearningResult.sim_seconds` reports what was used, never more than the budget.

Saved policies (:mod:`evolution.learning.policy_file`): an experiment keeps every trained
policy in its results folder as a file of numbers and plain data that loads without running
code (the SB3 policy network's parameters, its constructor arguments, the robot it was trained
on, the action mode and the control period); the store references it with the file's SHA-256
and a digest of the policy's parameters, and loading checks both and the body.

The policy lives outside the genome, so an SB3 learner is Darwinian only
(:class:`~evolution.learning.base.TrainingCenter` refuses ``"lamarckian"`` for it).

SB3 and torch are imported only when a learner trains (``pip install 'revolve-env[learn]'``).
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal, Protocol

import numpy as np
from numpy.typing import NDArray

from evolution.learning.base import LearningResult, check_budget
from revolve_env.body.robot import Layer, Robot
from revolve_env.conditions import IDEAL, EvaluationConditions
from revolve_env.registration import LOCOMOTION_ID, LOCOMOTION_V1_ID
from revolve_env.rl import INSTALL_HINT, ObservationNormalization, VecEnvConfig, ppo_settings
from revolve_env.setting import DEFAULT_ENGINE
from revolve_env.tasks import Locomotion, Task
from revolve_env.terrain import Flat, Terrain

if TYPE_CHECKING:
    from revolve_env.brain import BatchController

__all__ = [
    "Policy",
    "PolicyAgent",
    "SB3Learner",
    "rollout_fitness",
]

ActionMode = Literal["targets", "modulate"]


class Policy(Protocol):
    """What :class:`PolicyAgent` needs of a trained policy: SB3's ``predict``."""

    def predict(
        self, observation: NDArray[Any], /, *, deterministic: bool = ...
    ) -> tuple[NDArray[Any], object]:
        """The action for one observation, and the policy's recurrent state (unused here)."""


def _algorithm_class(algorithm: type | str) -> type:
    if not isinstance(algorithm, str):
        return algorithm
    try:
        import stable_baselines3
    except ImportError as error:  # pragma: no cover - depends on the installation
        raise ImportError(f"SB3Learner: {INSTALL_HINT}") from error
    cls = getattr(stable_baselines3, algorithm, None)
    if not isinstance(cls, type):
        known = [n for n in ("A2C", "DDPG", "DQN", "PPO", "SAC", "TD3")
                 if hasattr(stable_baselines3, n)]
        raise ValueError(
            f"stable_baselines3 has no algorithm {algorithm!r}; known: {', '.join(known)}"
        )
    return cls


def _make_env(robot: Robot, action: ActionMode, insertion: float, seconds: float,
              control_period: float, engine: str = DEFAULT_ENGINE,
              conditions: EvaluationConditions = IDEAL, proprioception: bool = False,
              task: Task | None = None, terrain: Terrain | None = None) -> Any:
    """The infant's single-robot env, for the learner's two evaluations.

    Returns a :class:`~revolve_env.envs.LocomotionEnv`, typed ``Any`` because its declared
    action type (float32) does not admit the float64 targets :func:`rollout_fitness` sends on
    purpose (exact targets).
    """
    from revolve_env.envs import LocomotionEnv

    return LocomotionEnv(
        robot,
        insertion_time=insertion,
        evaluation_time=seconds,
        fitness_window=seconds,
        control_period=control_period,
        controller="brain" if action == "modulate" else "agent",
        action=action,
        engine=engine,
        conditions=conditions,
        proprioception=proprioception,
        task=task,
        terrain=terrain,
    )


class PolicyAgent:
    """A trained policy as a robot controller: observation in, hinge targets out.

    Use one agent per robot: in ``"modulate"`` mode it runs the robot's network (its state
    evolves with every :meth:`act`), exactly as the training env did.

    Args:
        policy: An SB3 policy (``model.policy``) with ``predict(obs, deterministic=...)``.
        robot: The robot it was trained on.
        action: ``"targets"`` or ``"modulate"`` (as in training).
        control_period: The period between two calls of :meth:`act`. Seconds.
        normalization: The frozen observation statistics the policy was trained with (the
            policy sees ``normalization(observation)``; the robot's network, the raw one), or
            ``None``: the policy sees raw observations.
        proprioception: The policy observes the robot's sensors followed by its hinge angles
            and velocities (``Locomotion-v1``, ``population_env(proprioception=True)``);
            ``False``: the sensors only (``Locomotion-v0``). The robot's network reads the
            sensors either way.

    Attributes:
        n_inputs: Sensor values (the robot's input neurons).
        n_outputs: Active hinges (the robot's output neurons).
        n_observations: Values of the observation :meth:`act` takes.
    """

    def __init__(
        self, policy: Policy, robot: Robot, action: ActionMode, control_period: float,
        normalization: ObservationNormalization | None = None, proprioception: bool = False,
    ) -> None:
        if action not in ("targets", "modulate"):
            raise ValueError(f"action must be 'targets' or 'modulate', got {action!r}")
        if not (math.isfinite(control_period) and control_period > 0):
            raise ValueError(
                f"control_period must be a positive number of seconds, got {control_period}"
            )
        self.policy = policy
        self.robot = robot
        self.action = action
        self.control_period = float(control_period)
        self.n_inputs = len(robot.neurons_of(Layer.INPUT))
        self.n_outputs = len(robot.neurons_of(Layer.OUTPUT))
        self.proprioception = bool(proprioception)
        self.n_observations = self.n_inputs + (2 * self.n_outputs if proprioception else 0)
        if normalization is not None and normalization.mean.shape != (self.n_observations,):
            raise ValueError(f"normalization has {normalization.mean.shape[0]} values; the "
                             f"policy observes {self.n_observations}")
        self.normalization = normalization
        self._brain: BatchController | None = None
        self._handle = 0
        self._out = np.zeros(self.n_outputs)

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state["_brain"] = None  # the compiled controller is rebuilt (state 0) after unpickling
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        state.setdefault("normalization", None)  # pickled before these existed
        state.setdefault("proprioception", False)
        state.setdefault("n_observations", state["n_inputs"])
        self.__dict__.update(state)

    def reset(self) -> None:
        """Start a new episode: the network's state and time go back to 0."""
        if self._brain is not None:
            self._brain.reset()

    def get_state(self) -> tuple[list[float], float] | None:
        """The running network's state and time (``"modulate"``), for a snapshot; else ``None``."""
        if self._brain is None:
            return None
        h = self._handle
        return [float(v) for v in self._brain.get_state(h)], float(self._brain.time(h))

    def set_state(self, state: tuple[list[float], float] | None) -> None:
        """Continue from :meth:`get_state` (``None``: a network that never ran)."""
        self._brain = None
        if state is None:
            return
        from revolve_env.brain import BatchController

        self._brain = BatchController(self.control_period)
        self._handle = self._brain.add(self.robot)
        self._brain.set_state(self._handle, np.asarray(state[0], dtype=np.float64),
                              float(state[1]))

    def policy_action(self, observation: np.ndarray) -> np.ndarray:
        """The policy's deterministic action (the env's action space) for one observation."""
        obs = np.asarray(observation, dtype=np.float64).reshape(-1)
        if obs.shape != (self.n_observations,):
            raise ValueError(f"observation must have shape ({self.n_observations},), got "
                             f"{obs.shape}")
        seen = obs if self.normalization is None else self.normalization(obs)
        action, _ = self.policy.predict(seen, deterministic=True)
        action = np.asarray(action, dtype=np.float64).reshape(-1)
        expected = self.n_outputs * (2 if self.action == "modulate" else 1)
        if action.shape != (expected,):
            raise ValueError(f"the policy gave an action of shape {action.shape}; {self.action!r} "
                             f"needs ({expected},) for {self.n_outputs} hinges")
        return action

    def act(self, observation: np.ndarray) -> np.ndarray:
        """Normalised hinge targets in [-1, 1] (one per active hinge) for one observation.

        In ``"modulate"`` mode this also advances the robot's network by one control period.
        """
        obs = np.ascontiguousarray(observation, dtype=np.float64).reshape(-1)
        a: NDArray[np.float64] = np.clip(self.policy_action(obs), -1.0, 1.0)
        if self.action == "targets":
            return a
        if self._brain is None:
            from revolve_env.brain import BatchController

            self._brain = BatchController(self.control_period)
            self._handle = self._brain.add(self.robot)
        self._brain.step(obs[: self.n_inputs], self._out)  # the network reads the sensors
        n = self.n_outputs
        targets: NDArray[np.float64] = np.clip((1.0 + a[:n]) * self._out + a[n:], -1.0, 1.0)
        return targets

    __call__ = act


def rollout_fitness(agent: PolicyAgent | None, robot: Robot, insertion: float, seconds: float,
                    control_period: float, seed: int, engine: str = DEFAULT_ENGINE,
                    conditions: EvaluationConditions = IDEAL, task: Task | None = None,
                    terrain: Terrain | None = None) -> float:
    """Fitness of one episode of ``robot`` driven by ``agent`` (``None``: by its own network).

    The agent drives the single-robot env with ``controller="agent"``: the same path as an
    agent-controlled robot in the population env. The task's fitness (metres for the default);
    0 after a blow-up.
    """
    if agent is None:
        env = _make_env(robot, "modulate", insertion, seconds, control_period, engine,
                        conditions, task=task, terrain=terrain)
    else:
        env = _make_env(robot, "targets", insertion, seconds, control_period, engine,
                        conditions, agent.proprioception, task, terrain)
        agent.reset()
    from revolve_env.envs.episode import run_episode  # loads the physics engine: when used

    try:
        # The agent's actions are float64: exact targets.
        info = run_episode(env, seed, None if agent is None else agent.act)
        return 0.0 if info["blow_up"] is not None else float(info["fitness"])
    finally:
        env.close()


@dataclass(frozen=True, slots=True, eq=False)
class SB3Learner:
    """Trains an SB3 algorithm on the infant's single-robot env (see the module docstring).

    Attributes:
        algorithm: An SB3 algorithm class (``stable_baselines3.PPO``, ``SAC``, ``TD3``, ...) or
            its name.
        policy: The SB3 policy name (``"MlpPolicy"``).
        action: ``"modulate"`` (on top of the robot's CPG; default) or ``"targets"``.
        n_envs: Parallel training envs.
        vec_env: ``"subproc"`` (one process per env) or ``"dummy"`` (all in this process, in
            one native vector env: the same steps as ``DummyVecEnv`` of single envs).
        insertion: Settling time of each training episode. Seconds.
        seconds: Scored part of each training episode (and the fitness window). Seconds.
        control_period: Time per env step. Seconds (a multiple of the physics timestep).
        engine: The physics engine of the training envs (``"pybullet"`` or ``"mujoco"``).
        conditions: Start heading and jitter, sensor and actuator noise of every training
            episode and of the two evaluations (an experiment's ``[evaluation]`` table).
        algorithm_kwargs: Keyword arguments of the algorithm (``n_steps``, ...); for PPO over
            :func:`revolve_env.rl.ppo_settings`.
        normalize: Train on normalised observations and rewards (``VecNormalize``); the policy
            keeps the observation statistics of the end of training.
        proprioception: The policy also observes the hinge angles and velocities
            (``Locomotion-v1``); the world it drives the robot in must observe them too
            (``population_env(proprioception=True)``; an experiment's engine does it for a
            ``learning.proprioception = true`` table). Without them, in ``"modulate"`` mode the
            policy cannot see the gait's phase and learns far more slowly (bench_rl.py).
        task: What the policy is rewarded for and the evaluations score
            (:mod:`revolve_env.tasks`; an experiment's task).
        terrain: The ground of the training envs and evaluations (:mod:`revolve_env.terrain`;
            an experiment's ``world.terrain``).
        settings: ``"benchmark"``: PPO starts from :func:`revolve_env.rl.ppo_settings`;
            ``"sb3-defaults"``: from SB3's own defaults (the learner before it took the
            benchmark's settings; with ``normalize=False`` it trains exactly as that one did,
            which is how results stored then resume). Under ``algorithm_kwargs`` either way.
    """

    algorithm: type | str = "PPO"
    policy: str = "MlpPolicy"
    action: ActionMode = "modulate"
    n_envs: int = 2
    vec_env: Literal["subproc", "dummy"] = "subproc"
    insertion: float = 0.5
    seconds: float = 4.0
    control_period: float = 1.0 / 60.0
    engine: str = DEFAULT_ENGINE
    algorithm_kwargs: Mapping[str, Any] = field(default_factory=dict)
    conditions: EvaluationConditions = IDEAL
    normalize: bool = True
    proprioception: bool = False
    task: Task = Locomotion()
    terrain: Terrain = Flat()
    settings: Literal["benchmark", "sb3-defaults"] = "benchmark"

    learns_policy = True  # class constant: the controller is the policy, not the genome's network

    def __post_init__(self) -> None:
        if self.action not in ("targets", "modulate"):
            raise ValueError(f"action must be 'targets' or 'modulate', got {self.action!r}")
        if self.vec_env not in ("subproc", "dummy"):
            raise ValueError(f"vec_env must be 'subproc' or 'dummy', got {self.vec_env!r}")
        if self.settings not in ("benchmark", "sb3-defaults"):
            raise ValueError(f"settings must be 'benchmark' or 'sb3-defaults', got "
                             f"{self.settings!r}")
        for flag in ("normalize", "proprioception"):
            if not isinstance(getattr(self, flag), bool):
                raise ValueError(f"{flag} must be true or false, got {getattr(self, flag)!r}")
        if not isinstance(self.n_envs, int) or self.n_envs < 1:
            raise ValueError(f"n_envs must be an integer >= 1, got {self.n_envs!r}")
        for name in ("seconds", "control_period"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number of seconds, got {value}")
        if not (math.isfinite(self.insertion) and self.insertion >= 0):
            raise ValueError(
                f"insertion must be a finite number of seconds >= 0, got {self.insertion}"
            )
        _algorithm_class(self.algorithm)  # fail early on an unknown name

    @property
    def _evaluation_seconds(self) -> float:
        """The learner's own two evaluations (inborn, trained). Seconds."""
        return 2 * (self.insertion + self.seconds)

    def _algorithm_kwargs(self) -> dict[str, Any]:
        """The algorithm's keyword arguments: PPO's start from the benchmark's settings.

        With ``settings="sb3-defaults"``, from SB3's own defaults (nothing added).
        """
        from stable_baselines3 import PPO

        cls = _algorithm_class(self.algorithm)
        benchmark = self.settings == "benchmark" and issubclass(cls, PPO)
        base = ppo_settings(self.action) if benchmark else {}
        return {**base, **dict(self.algorithm_kwargs)}

    def _rollout(self) -> tuple[int, int]:
        """``(steps per env of one rollout, steps before the first update)`` of the algorithm."""
        cls = _algorithm_class(self.algorithm)
        defaults = {name: p.default for name, p in inspect.signature(cls).parameters.items()
                    if p.default is not inspect.Parameter.empty}
        kwargs = {**defaults, **self._algorithm_kwargs()}
        from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm

        if issubclass(cls, OnPolicyAlgorithm):  # PPO, A2C: one rollout, then an update
            return int(kwargs["n_steps"]), 0
        freq = kwargs.get("train_freq", 1)
        freq = int(freq[0] if isinstance(freq, tuple) else freq)
        return freq, int(kwargs.get("learning_starts", 0))

    def _min_steps(self) -> int:
        per_env, starts = self._rollout()
        return per_env * self.n_envs + starts

    def training_steps(self, budget: float) -> int:
        """Training steps ``budget`` seconds pay for after the two evaluations (whole rollouts)."""
        steps = math.floor((budget - self._evaluation_seconds) / self.control_period + 1e-9)
        per_env, starts = self._rollout()
        if starts == 0:  # on-policy: SB3 rounds up to whole rollouts, so round down here
            steps -= steps % (per_env * self.n_envs)
        return max(steps, 0)

    @property
    def min_budget(self) -> float:
        """The smallest budget for one learning step: two evaluations and one rollout. Seconds."""
        return self._min_steps() * self.control_period + self._evaluation_seconds

    def learn(self, robot: Robot, budget: float, rng: np.random.Generator) -> LearningResult:
        """Train for ``budget`` simulated seconds; the result carries the :class:`PolicyAgent`.

        Raises:
            ValueError: a budget below :attr:`min_budget`, or a robot the env refuses.
        """
        from stable_baselines3.common.callbacks import BaseCallback
        from stable_baselines3.common.logger import Logger
        from stable_baselines3.common.vec_env import VecNormalize

        from revolve_env.brain import get_params
        from revolve_env.rl import make_vec_env

        steps = self.training_steps(check_budget(budget))
        if steps < self._min_steps():
            raise ValueError(f"a budget of {budget} s leaves {steps} training steps after the "
                             f"learner's two evaluations; one learning step needs "
                             f"{self._min_steps()} (min_budget: {self.min_budget:g} s)")
        seed = int(rng.integers(0, 2**31 - 1))
        algorithm_kwargs = self._algorithm_kwargs()
        config = VecEnvConfig(n_envs=self.n_envs, insertion_time=self.insertion,
                              evaluation_time=self.seconds, normalize=self.normalize,
                              gamma=float(algorithm_kwargs.get("gamma", 0.99)),
                              subprocess=self.vec_env == "subproc")
        # Locomotion-v0 observes what a robot's network does (its sensors), v1 the hinges too.
        venv = make_vec_env(robot, config, seed=seed,
                            env_id=LOCOMOTION_V1_ID if self.proprioception else LOCOMOTION_ID,
                            action=self.action, control_period=self.control_period,
                            engine=self.engine, conditions=self.conditions,
                            task=self.task, terrain=self.terrain)
        episodes: list[float] = []
        failures = [0]

        class _Record(BaseCallback):
            """Collects the fitness at the end of every training episode."""

            def _on_step(self) -> bool:
                for done, info in zip(self.locals["dones"], self.locals["infos"], strict=True):
                    if done:
                        blown = info.get("blow_up") is not None
                        failures[0] += int(blown)
                        episodes.append(0.0 if blown else float(info["fitness"]))
                return True

        try:
            model = _algorithm_class(self.algorithm)(
                self.policy, venv, seed=seed, device="cpu", verbose=0, **algorithm_kwargs
            )
            # A logger with no output: SB3's default one makes an empty SB3-<time> folder in the
            # system's temporary folder at every learn(), even when it writes nothing.
            model.set_logger(Logger(folder=None, output_formats=[]))
            model.learn(total_timesteps=steps, callback=_Record())
            used = int(model.num_timesteps)
            normalization = (ObservationNormalization.of(venv)
                             if isinstance(venv, VecNormalize) else None)
        finally:
            venv.close()
        agent = PolicyAgent(model.policy, robot, self.action, self.control_period, normalization,
                            self.proprioception)
        eval_seed = int(rng.integers(0, 2**31 - 1))
        inborn = rollout_fitness(None, robot, self.insertion, self.seconds, self.control_period,
                                 eval_seed, self.engine, self.conditions, self.task, self.terrain)
        trained = rollout_fitness(agent, robot, self.insertion, self.seconds, self.control_period,
                                  eval_seed, self.engine, self.conditions, self.task,
                                  self.terrain)
        agent.reset()
        return LearningResult(
            robot=robot,
            params=get_params(robot),
            fitness=tuple(episodes),
            inborn_fitness=inborn,
            best_fitness=trained,
            evaluations=len(episodes),
            sim_seconds=used * self.control_period + self._evaluation_seconds,
            failures=failures[0],
            policy=agent,
        )
