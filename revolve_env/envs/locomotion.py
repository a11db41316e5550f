"""Single-robot locomotion task: ``revolve_env/Locomotion-v0`` and ``-v1`` (with proprioception).

One RoboGen robot on a flat plane; the episode is an insertion phase followed by an evaluation
phase, and the return is the robot's fitness at the task (``task=``, :mod:`revolve_env.tasks`),
by default the locomotion fitness ``f = v + 5 s``. The start (heading, position jitter) and the
noise follow ``conditions`` (:class:`~revolve_env.conditions.EvaluationConditions`), drawn as
:func:`revolve_env.evaluate` draws them, so an episode reset with seed ``k`` starts where
``evaluate(robot, seed=k, conditions=...)`` starts.
"""

from __future__ import annotations

import dataclasses
import math
import os
import warnings
from collections.abc import Mapping
from typing import Any, Literal

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from revolve_env.body.examples import resolve_robot
from revolve_env.body.parts import light_inputs
from revolve_env.body.robot import Layer, Robot
from revolve_env.body.validate import Limits
from revolve_env.cameras import Camera, check_size, make_camera
from revolve_env.conditions import (
    EvaluationConditions,
    add_sensor_noise,
    with_noise_shortcuts,
    with_reset_noise,
)
from revolve_env.envs.observations import hinge_values, proprio_bounds, saturated_sensor_bounds
from revolve_env.episode_length import (
    DEFAULT_EVALUATION_TIME,
    DEFAULT_INSERTION_TIME,
    DEFAULT_ROBOT,
    episode_steps,
)
from revolve_env.evaluation import start_generator
from revolve_env.fitness import DEFAULT_WINDOW, FitnessTerms, Window
from revolve_env.rollout import RobotWindow, Rollout, TaskWindows, task_rule
from revolve_env.setting import Setting, env_parts
from revolve_env.tasks import BaseTask, Task, make_task
from revolve_env.terrain import Terrain
from revolve_env.world import World, WorldConfig, compiled, with_engine
from revolve_env.world.signals import SignalReader, signal_reader

__all__ = ["LocomotionEnv"]

#: The action arrays the compiled env step takes as they are (1-D and C-contiguous too).
_STEP_DTYPES = (np.dtype(np.float32), np.dtype(np.float64))


def _all_finite(a: NDArray[np.float64]) -> bool:
    """Whether every entry is finite (fast path: one reduction; exact on overflow)."""
    return math.isfinite(float(np.add.reduce(a, axis=None))) or bool(np.isfinite(a).all())


def _check_arguments(render_mode: str | None, render_modes: list[str], insertion_time: float,
                     evaluation_time: float, fitness_window: float, sensor_noise: float,
                     actuator_noise: float, controller: str, action: str) -> None:
    """Refuse bad :class:`LocomotionEnv` arguments by name (times in seconds)."""
    if render_mode is not None and render_mode not in render_modes:
        raise ValueError(f"render_mode must be one of {render_modes} or None, "
                         f"got {render_mode!r}")
    for name, value in (("insertion_time", insertion_time), ("sensor_noise", sensor_noise),
                        ("actuator_noise", actuator_noise)):
        if not (math.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be a finite number >= 0, got {value}")
    for name, value in (("evaluation_time", evaluation_time),
                        ("fitness_window", fitness_window)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive number of seconds, got {value}")
    if controller not in ("agent", "brain"):
        raise ValueError(f"controller must be 'agent' or 'brain', got {controller!r}")
    if action not in ("targets", "modulate"):
        raise ValueError(f"action must be 'targets' or 'modulate', got {action!r}")
    if action == "modulate" and controller != "brain":
        raise ValueError(
            "action='modulate' scales the brain's outputs: it needs controller='brain'"
        )


def _info(fitness: float, v: float, s: float, reward: float, time: float, evaluating: bool,
          x: float, y: float, blow_up: str | None) -> dict[str, Any]:
    """A step's info dict (the class doc's Info): its one home, for the compiled and general steps.

    Args:
        fitness: The task's fitness now.
        v: The window's path length. Metres.
        s: Its straight displacement. Metres.
        reward: The step's reward.
        time: Since reset. Seconds.
        evaluating: Whether past insertion.
        x: The core's x. Metres.
        y: Its y. Metres.
        blow_up: The blow-up's reason, or None.
    """
    return {"fitness": fitness, "fitness_v": v, "fitness_s": s, "reward_fitness": reward,
            "time": time, "evaluating": evaluating, "x_position": x, "y_position": y,
            "blow_up": blow_up}


class LocomotionEnv(gym.Env[NDArray[np.float64], NDArray[np.float32]]):
    """Make a RoboGen modular robot walk: reward is the step's increase of its fitness.

    ## Description
    The robot (any valid :class:`~revolve_env.body.robot.Robot`, or a path to its JSON) is dropped
    on an infinite flat plane. For ``insertion_time`` seconds it settles (its controller already
    acts; nothing is scored); then for ``evaluation_time`` seconds its core is tracked and the
    fitness ``f = v + 5 s`` is computed over a sliding window of ``fitness_window`` seconds, where
    ``v`` is the horizontal path length of the core and ``s`` its straight horizontal displacement
    over the window. With the defaults (window = evaluation time) the undiscounted return equals
    the fitness at the end of the episode.

    ## Action Space
    ``Box(-1, 1, (n,), float32)``. With ``action="targets"`` (default), ``n`` is the number of
    active hinges, in traversal order (the robot's output neuron order):

    | Index | Action                              | Min | Max | Unit                    |
    |-------|-------------------------------------|-----|-----|-------------------------|
    | i     | position target of active hinge i   | -1  | 1   | normalized (1 = 45 deg) |

    With ``controller="brain"`` and ``action="targets"`` the robot's own network drives the
    hinges and the action is ignored. With ``action="modulate"`` (brain required) ``n`` is twice
    the number of hinges: target ``i`` is ``clip((1 + a[i]) * brain[i] + a[n/2 + i], -1, 1)``, so
    the zero action leaves the brain's gait unchanged.

    ## Observation Space
    ``Box(low, high, (m,), float64)``: every sensor value in traversal order (the robot's input
    neuron order); per part type:

    | Part          | Values                                    | Min  | Max | Unit           |
    |---------------|-------------------------------------------|------|-----|----------------|
    | core          | accelerometer x, y, z (core frame, incl.  | -157 | 157 | m/s^2 (16 g)   |
    |               | the reaction to gravity)                  |      |     |                |
    | core          | gyroscope x, y, z (core frame)            | -34.9| 34.9| rad/s          |
    | touch sensor  | left half touching, right half touching   | 0    | 1   | binary         |
    | light sensor  | light intensity                           | 0    | 1   | dimensionless  |

    With ``proprioception=True`` (``Locomotion-v1``) ``2 n`` values follow, for the ``n`` active
    hinges in action order (``m = sensors + 2 n``):

    | Index          | Observation                       | Min  | Max  | Unit                  |
    |----------------|-----------------------------------|------|------|-----------------------|
    | sensors + i    | angle of active hinge i           | -pi  | pi   | rad (0 = as built)    |
    | sensors + n + i| angular velocity of active hinge i| -200 | 200  | rad/s                 |

    (the velocity bound is ``world_config.max_angular_speed``: a faster hinge is a blow-up). The
    robot's own network (``controller="brain"``) still reads RoboGen's sensors only.

    Readings saturate at the bounds (the IMU's full-scale range, as on the real board).
    ``conditions.sensor_noise`` adds Gaussian noise of that standard deviation to every value
    (then clipped to the bounds); ``conditions.actuator_noise`` adds Gaussian noise to every
    normalized hinge target. Both draw from the generator seeded by ``reset(seed=...)``
    (``np_random``).

    ## Starting state
    The robot is dropped at the origin with heading 0, or where ``conditions`` put it: a random
    heading (``heading="random"``, uniform in ``[0, 2 pi)``) and/or a position drawn uniformly
    from a disc of radius ``position_jitter`` metres around the origin. Then, as in Gymnasium's
    MuJoCo envs, every active hinge starts at an angle drawn uniformly from
    ``[-reset_noise_scale, reset_noise_scale]`` radians and a speed drawn uniformly from the same
    interval in radians per second (default 0.1: :data:`~revolve_env.conditions.
    DEFAULT_RESET_NOISE_SCALE`), so ``reset(seed=0)`` and ``reset(seed=1)`` give different
    episodes; ``reset_noise_scale=0`` starts every hinge at rest at 0. The start is drawn at
    every reset: from :func:`revolve_env.evaluation.start_generator` of the reset's seed (so the
    env and :func:`revolve_env.evaluate` with the same conditions start alike for the same seed),
    or from ``np_random`` when reset gets no seed. Nothing is drawn for a fixed heading without
    jitter and no reset noise. Given ``conditions`` (an experiment's) keep their own
    ``reset_noise_scale`` (0 unless set): the paper's start.

    ## Rewards
    ``task`` (:mod:`revolve_env.tasks`; default :class:`~revolve_env.tasks.Locomotion`, the
    fitness above) scores the window and gives each step's reward: for the shipped tasks
    ``reward = fitness(t) - fitness(t - control_period)``, 0 during insertion. If the simulation
    blows up (NaN, or a part faster than a sane speed) the fitness is set to 0, so that step's
    reward is minus the fitness so far, and the episode terminates.

    ## Episode End
    * Truncation: when ``insertion_time + evaluation_time`` seconds have been simulated
      (:func:`~revolve_env.registration.episode_steps`; 900 steps with the defaults, the
      registered ``max_episode_steps``). ``gym.make`` refuses a ``max_episode_steps`` that would
      end an episode earlier (:mod:`revolve_env.registration` says why).
    * Termination: only on a simulation blow-up.

    ## Info
    ``fitness`` (the task's), ``fitness_v``, ``fitness_s`` (metres; path length and
    displacement over the window, whatever the task),
    ``reward_fitness`` (the reward), ``time`` (seconds since reset), ``evaluating`` (past
    insertion), ``x_position``, ``y_position`` (core, metres) and ``blow_up`` (the reason string,
    or None).

    ## Versions
    * ``v1``: ``proprioception=True``: hinge angles and velocities follow the sensors.
    * ``v0``: observations are RoboGen's sensors only (kept for older code; Gymnasium warns
      that it is out of date when it is made).

    ## Arguments
    | Keyword            | Default   | Meaning                                                    |
    |--------------------|-----------|------------------------------------------------------------|
    | robot              | "spider"  | Robot, example name or path to its JSON                   |
    |                    |           | (:func:`~revolve_env.body.examples.resolve_robot`);        |
    |                    |           | validated before any physics                               |
    | render_mode        | None      | "rgb_array" or "human" (MuJoCo's or pybullet's window;    |
    |                    |           | without a display it warns once and draws nothing)         |
    | width, height      | 480, 360  | frame size ("rgb_array"), as Gymnasium's MujocoEnv. Pixels |
    | camera             | "track"   | a :class:`~revolve_env.cameras.Camera` or the name of |
    |                    |           | one (:data:`~revolve_env.cameras.CAMERAS`: "track"    |
    |                    |           | follows the core at 1 m, "far", "top", "fixed")            |
    | insertion_time     | None      | settling phase, not scored. Seconds; None: the setting's,  |
    |                    |           | 3.0                                                        |
    | evaluation_time    | None      | scored phase. Seconds; None: the setting's ``seconds``,    |
    |                    |           | 12.0                                                       |
    | control_period     | None      | time per env step. Seconds (a multiple of the timestep);   |
    |                    |           | None: ``world_config``'s (1/60 s by default)               |
    | fitness_window     | 12.0      | sliding window of the fitness. Seconds                     |
    | conditions         | None      | start heading, jitter and noise (an                        |
    |                    |           | :class:`~revolve_env.conditions.EvaluationConditions`);    |
    |                    |           | None: ``IDEAL`` (heading 0 at the origin, no noise) with   |
    |                    |           | the default ``reset_noise_scale``                          |
    | reset_noise_scale  | None      | half-width of the uniform noise on the hinges' start       |
    |                    |           | angles (rad) and speeds (rad/s); None: the conditions'     |
    |                    |           | when given, else 0.1; 0: start at rest (see Starting state)|
    | sensor_noise       | 0.0       | std of Gaussian sensor noise (units of each sensor); a     |
    |                    |           | shortcut for ``conditions``, not with it                   |
    | actuator_noise     | 0.0       | std of Gaussian noise on normalized targets (likewise)     |
    | controller         | None      | "agent": the action drives; "brain": the robot's network;  |
    |                    |           | None: "brain" with ``action="modulate"``, else "agent"     |
    | action             | "targets" | "targets" or "modulate" (scale/offset the brain's outputs) |
    | proprioception     | False     | observe hinge angles and velocities (True in ``-v1``)      |
    | world_config       | None      | a :class:`~revolve_env.world.WorldConfig` (physics)        |
    | limits             | None      | validation limits                                          |
    |                    |           | (:class:`~revolve_env.body.validate.Limits`)               |
    | engine             | None      | "mujoco" or "pybullet"; None: ``world_config``'s (mujoco)   |
    | task               | None      | what the robot is rewarded for: a task, a name or a table  |
    |                    |           | (:func:`~revolve_env.tasks.make_task`); None: Locomotion   |
    | terrain            | None      | the ground: "flat", "rugged", "crater", "bowl", a table or |
    |                    |           | a spec (:mod:`~revolve_env.terrain`); None:                |
    |                    |           | ``world_config``'s (flat)                                  |
    | setting            | None      | a :class:`~revolve_env.setting.Setting`: world (engine,    |
    |                    |           | terrain, timings), task, conditions, insertion and         |
    |                    |           | evaluation times at once; a keyword above given beside it  |
    |                    |           | changes that part (its conditions keep their reset noise)  |
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 60}  # noqa: RUF012 (gymnasium API)
    #: Whether an episode steps in the compiled env step where it applies (MuJoCo, the extension
    #: usable, no noise, ``action="targets"``, a shipped task rewarded by its gain, no window):
    #: one C++ call per step to the same numbers; False: the general Python step (tests and
    #: benchmarks compare the two).
    _fast_step = True

    def __init__(
        self,
        robot: Robot | str | os.PathLike[str] = DEFAULT_ROBOT,
        render_mode: Literal["rgb_array", "human"] | None = None,
        insertion_time: float | None = None,
        evaluation_time: float | None = None,
        control_period: float | None = None,
        fitness_window: float = DEFAULT_WINDOW,
        sensor_noise: float = 0.0,
        actuator_noise: float = 0.0,
        controller: Literal["agent", "brain"] | None = None,
        action: Literal["targets", "modulate"] = "targets",
        world_config: WorldConfig | None = None,
        limits: Limits | None = None,
        proprioception: bool = False,
        engine: str | None = None,
        conditions: EvaluationConditions | None = None,
        task: Task | str | Mapping[str, Any] | None = None,
        terrain: Terrain | str | Mapping[str, Any] | None = None,
        width: int = 480,
        height: int = 360,
        camera: str | Camera = "track",
        reset_noise_scale: float | None = None,
        setting: Setting | None = None,
    ) -> None:
        given = conditions is not None or setting is not None
        world_config, task, conditions = env_parts(setting, world_config, task, conditions)
        if insertion_time is None:
            insertion_time = DEFAULT_INSERTION_TIME if setting is None else setting.insertion
        if evaluation_time is None:
            evaluation_time = DEFAULT_EVALUATION_TIME if setting is None else setting.seconds
        self.width, self.height = check_size(width, height)
        self.camera = make_camera(camera)
        robot = resolve_robot(robot, limits)[0]
        if controller is None:  # the robot's network runs under the policy's modulation
            controller = "brain" if action == "modulate" else "agent"
        self.task = make_task(task)
        # The gain (every shipped task's reward) in floats: no arrays for one robot per step.
        self._gain = type(self.task).reward is BaseTask.reward
        _check_arguments(render_mode, self.metadata["render_modes"], insertion_time,
                         evaluation_time, fitness_window, sensor_noise, actuator_noise,
                         controller, action)
        self.conditions = with_reset_noise(
            with_noise_shortcuts(conditions, sensor_noise, actuator_noise), reset_noise_scale,
            conditions_given=given)
        self.reset_noise_scale = self.conditions.reset_noise_scale

        config = world_config if world_config is not None else WorldConfig()
        if control_period is not None:  # replace() validates it against the timestep
            config = dataclasses.replace(config, control_period=control_period)
        config = with_engine(config, engine).with_terrain(terrain)
        self.config = config
        self.robot = robot
        self.render_mode = render_mode
        self.insertion_time = float(insertion_time)
        self.evaluation_time = float(evaluation_time)
        self.fitness_window = float(fitness_window)
        self.sensor_noise = self.conditions.sensor_noise
        self.actuator_noise = self.conditions.actuator_noise
        self.controller = controller
        self.action_mode = action
        self.proprioception = bool(proprioception)
        dt = self.config.control_period
        self.metadata = {**self.metadata, "render_fps": round(1.0 / dt)}  # one frame per step
        self._insertion_steps, self._total_steps = episode_steps(
            self.insertion_time, self.evaluation_time, dt)
        if self._total_steps <= self._insertion_steps:
            raise ValueError(f"evaluation_time {evaluation_time} s is shorter than one control "
                             f"period ({dt} s)")

        self._n_outputs = len(robot.neurons_of(Layer.OUTPUT))
        low, high = saturated_sensor_bounds(robot)
        self._n_inputs = len(low)  # sensor values (the brain's inputs)
        if self.proprioception:
            p_low, p_high = proprio_bounds(self._n_outputs, self.config)
            low, high = np.concatenate((low, p_low)), np.concatenate((high, p_high))
        self._obs_low, self._obs_high = low, high
        if controller == "brain" and len(robot.neurons_of(Layer.INPUT)) != self._n_inputs:
            raise ValueError(f"the robot's network has {len(robot.neurons_of(Layer.INPUT))} input "
                             f"neurons but its body has {self._n_inputs} sensor values")
        if self._n_outputs == 0:
            raise ValueError("the robot has no active hinge: there is nothing to control")
        n_act = 2 * self._n_outputs if action == "modulate" else self._n_outputs
        self.observation_space = spaces.Box(low, high, dtype=np.float64)
        self.action_space = spaces.Box(-1.0, 1.0, (n_act,), dtype=np.float32)

        self._world: World | None = None
        # The episode's rollout (its periods, the brain's held outputs; its brain, unless the
        # compiled step steps the brain: see compiled.EnvStep, one owner per episode).
        self._run: Rollout | None = None
        self._handle = -1
        self._start = np.zeros(3)
        # The task's window of the robot (TaskError: a pose rate that does not fit).
        self._windows = TaskWindows(self.task, self.fitness_window, dt, self._insertion_steps)
        # The same window in floats (no arrays per step); False: the one-column TaskWindows
        # above, to the same numbers bit for bit (tests and benchmarks compare the two paths).
        self._robot_window = RobotWindow(self.task, self.fitness_window, dt, self._insertion_steps)
        self._window: RobotWindow | compiled.CompiledWindow = self._robot_window
        self._fast_windows = True
        # The episode's compiled step (None: the general step); the task's rule for it.
        self._fast: compiled.EnvStep | None = None
        self._rule = task_rule(self.task) if self._gain else None
        self._signal: SignalReader | None = None
        self._terms = FitnessTerms(0.0, 0.0, 0.0)
        self._step_count = 0
        self._obs = np.zeros(len(low))
        self._blow_up: str | None = None

    # -- gymnasium API -----------------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float64], dict[str, Any]]:
        """Start an episode (``seed`` seeds the start and the noise); the first observation, info.

        The start is drawn as the class doc (Starting state) says.
        """
        super().reset(seed=seed)
        if self._world is None:
            self._world = self._make_world()
        else:
            self._world.reset()
        rng = start_generator(seed) if seed is not None else self.np_random
        start = self.conditions.start(rng)
        # The robot's own network drives it ("targets") or is modulated by the action.
        self._run = Rollout(self._world)
        self._handle = self._run.add(
            self.robot, start.position, start.yaw,
            network=self.robot if self.controller == "brain" else None,
            drives=self.action_mode == "targets")
        if not self.camera.track:  # a fixed camera looks at where the core started
            self._start = self._world.core_position(self._handle).copy()
        joints = self.conditions.start_joints(rng, self._n_outputs)
        if joints is not None:
            self._world.set_hinge_state(self._handle, *joints)
        self._signal = signal_reader(self.task.signal, [self.robot], self._world)
        self._windows.clear()
        self._windows.add(1)
        self._fast = self._compiled_step()
        self._window = self._robot_window if self._fast is None else self._fast.window
        self._window.clear()
        if self._insertion_steps == 0:  # the evaluation starts right away, from here
            self._sample(0.0, self._world.core_position(self._handle).reshape(1, 3))
        self._terms = FitnessTerms(0.0, 0.0, 0.0)
        self._step_count = 0
        self._blow_up = None
        self._obs = self._get_obs()
        if self.render_mode == "human":
            self.render()
        return self._obs.copy(), self._get_info(0.0)

    def step(
        self, action: NDArray[np.float32]
    ) -> tuple[NDArray[np.float64], float, bool, bool, dict[str, Any]]:
        """Act for one ``control_period`` (seconds); the reward is the fitness gain, in metres."""
        fast = self._fast
        if fast is not None and self._blow_up is None and self._step_count < self._total_steps:
            run = self._run
            assert run is not None
            taken: NDArray[np.float32] | NDArray[np.float64] = action
            if type(action) is not np.ndarray or action.ndim != 1 or \
                    action.dtype not in _STEP_DTYPES or not action.flags.c_contiguous:
                # as the general step reads it (its errors for what does not convert)
                taken = np.ascontiguousarray(action, dtype=np.float64).reshape(-1)
            code = fast.step(taken, self._obs, run.periods, self._step_count + 1)
            if code == fast.done:  # all of it: the world, the window, the observation
                run.periods += 1
                n = self._step_count = self._step_count + 1
                # (the task's terms are the compiled step's, fast.terms: self._terms is set
                # from them when Python finishes a step)
                reward, f, v, s, x, y = fast.out.tolist()
                return self._obs.copy(), reward, False, n >= self._total_steps, _info(
                    f, v, s, reward, n * self.config.control_period, n >= self._insertion_steps,
                    x, y, None)
            if code != fast.bad_action:  # an event: the env's part in Python
                return self._finish_fast(fast, code)
        return self._step(action)

    def _step(
        self, action: NDArray[np.float32]
    ) -> tuple[NDArray[np.float64], float, bool, bool, dict[str, Any]]:
        """:meth:`step` on the general path (the NumPy rules and Python floats)."""
        if self._world is None:
            raise RuntimeError("call reset() before step()")
        if self._blow_up is not None or self._step_count >= self._total_steps:
            raise RuntimeError("the episode is over; call reset()")
        run = self._run
        assert run is not None
        act = self._checked(np.asarray(action, dtype=np.float64).reshape(-1))
        assert self._fast is None, "the compiled step took a valid action"
        # RoboGen's sensors only (not the hinges) are the brain's inputs
        values = self._obs[: self._n_inputs] if run.thinking else None
        if self.controller == "agent":
            blown = run.period(None, (None, act), self.actuator_noise, self.np_random)
        elif self.action_mode == "targets":
            blown = run.period(values, None, self.actuator_noise, self.np_random)
        else:  # the action scales and offsets the brain's outputs
            n = self._n_outputs
            if values is not None:
                run.think(values)
            targets = (1.0 + act[:n]) * run.outputs + act[n:]
            blown = run.period(None, (None, targets), self.actuator_noise, self.np_random)
        return self._finish(blown)

    def _finish_fast(self, fast: compiled.EnvStep, code: int
                     ) -> tuple[NDArray[np.float64], float, bool, bool, dict[str, Any]]:
        """A step the compiled step stopped in (``code``): the rest on the general path."""
        world, run = self._world, self._run
        assert world is not None and run is not None
        if code == fast.brain_diverged:  # the brain stepped; its targets flag the robot
            world.set_all_targets(run.outputs)
            world.step(1)
        run.periods += 1
        self._terms = FitnessTerms(*fast.terms)
        out = self._finish(run.blown())
        fast.terms = (self._terms.fitness, self._terms.v, self._terms.s)
        if not fast.current():  # a replay remade the scene: step the new one
            again = world.compiled_step()
            assert again is not None, "a MuJoCo world keeps its compiled step"
            fast.adopt(again)
        return out

    def _finish(self, blown: NDArray[np.bool_] | None
                ) -> tuple[NDArray[np.float64], float, bool, bool, dict[str, Any]]:
        """The env's part of a step after the world's period (``blown``: its blow-up screen)."""
        world = self._world
        assert world is not None
        self._step_count += 1

        self._blow_up = None if blown is None else world.blow_up(self._handle)
        window: Window | bool = False
        if self._step_count >= self._insertion_steps and self._blow_up is None:
            # between pose samples the robot holds its last one: no reward
            window = self._sample(world.time, world.states.core_pos)
        reward = self._get_reward(window)
        terminated = self._blow_up is not None
        truncated = not terminated and self._step_count >= self._total_steps
        self._obs = self._get_obs()
        if self.render_mode == "human":
            self.render()
        return self._obs.copy(), reward, terminated, truncated, self._get_info(reward)

    def render(self) -> NDArray[np.uint8] | None:
        """Frame on the core: an RGB (height, width, 3) array, or None with "human" (a window)."""
        if self._world is None or self.render_mode is None:
            return None
        cam = self.camera
        target = self._world.core_position(self._handle) if cam.track else self._start
        if self.render_mode == "human":
            self._world.look_at(target, cam.distance)
            return None
        return self._world.render(self.width, self.height, target, cam.distance, cam.yaw,
                                  cam.pitch)

    def close(self) -> None:
        """Release the physics world (and its window); the next ``reset()`` makes a new one."""
        if self._world is not None:
            self._world.close()
            self._world = None
        self._fast = None

    # -- private -----------------------------------------------------------------------------------
    def _make_world(self) -> World:
        if self.render_mode == "human":
            try:
                return World(self.config, gui=True)
            except RuntimeError as exc:
                warnings.warn(f"render_mode='human' without a window: {exc}", stacklevel=3)
        return World(self.config)

    def _compiled_step(self) -> compiled.EnvStep | None:
        """The episode's compiled step, None where the general step must take it."""
        world = self._world
        assert world is not None
        if (not (self._fast_step and self._fast_windows) or self._rule is None
                or self.action_mode != "targets" or self.sensor_noise > 0
                or self.actuator_noise > 0 or self.render_mode == "human"
                or world.blow_up(self._handle) is not None):
            return None
        state, _ = world.plan(self._handle)
        signal = light_inputs(self.robot) if self.task.signal is not None else np.zeros(0)
        return compiled.env_step(
            world, self._n_outputs, self._n_inputs,
            state.joint_start + state.active_local, self.proprioception, self._obs_low,
            self._obs_high, self._rule, self.fitness_window, self._insertion_steps,
            self._robot_window.stride, signal.astype(np.intp),
            self.robot if self.controller == "brain" else None,
            self._run.outputs if self.controller == "brain" and self._run is not None else None,
            world.compiled_step())

    @property
    def _brain_out(self) -> NDArray[np.float64]:
        """The brain's outputs (held between its steps), normalized."""
        assert self._run is not None
        return self._run.outputs

    def _checked(self, action: NDArray[np.float64]) -> NDArray[np.float64]:
        """The action, checked and clipped to [-1, 1]."""
        if action.shape != self.action_space.shape:
            raise ValueError(
                f"action must have shape {self.action_space.shape}, got {action.shape}"
            )
        if not _all_finite(action):
            raise ValueError(f"action contains NaN or infinity: {action}")
        return np.minimum(np.maximum(action, -1.0), 1.0)

    def _get_obs(self) -> NDArray[np.float64]:
        world = self._world
        assert world is not None
        # the world's arrays: of its one robot
        if self._blow_up is None and self.proprioception and self.sensor_noise <= 0:
            # Finite and without noise, the hinge values' saturation (hinge_values) is the clip
            # below (the same bounds): clipped once, the same numbers.
            obs = np.concatenate((world.sensor_values(), world.hinge_angles(),
                                  world.hinge_velocities()))
            if _all_finite(obs):
                return np.minimum(np.maximum(obs, self._obs_low, out=obs), self._obs_high,
                                  out=obs)
        obs = world.sensor_values().copy()
        if self.proprioception:
            obs = np.concatenate((obs, *hinge_values(world)))
        if self._blow_up is not None or not _all_finite(obs):
            return np.zeros(len(self._obs_low))
        obs = add_sensor_noise(obs, self.sensor_noise, self.np_random, self._obs_low,
                               self._obs_high)
        return np.minimum(np.maximum(obs, self._obs_low, out=obs), self._obs_high, out=obs)

    def _signal_now(self) -> NDArray[np.float64] | None:
        """The task's signal of the robot now, shape (1,) (None: the task has none)."""
        if self._signal is None:
            return None
        assert self._world is not None
        return self._signal.read(self._world)

    def _sample(self, time: float, position: NDArray[np.float64]) -> Window | bool:
        """Sample the robot's window at ``time`` (seconds) at its core ``position`` (1, 3).

        Returns:
            The window after it (the general path), or True (the float path: in
            :attr:`_window`).
        """
        if not self._fast_windows:
            return self._windows.push(time, position, np.array([self._step_count]), None,
                                      self._signal_now())
        assert self._world is not None
        signal = None
        if self._signal is not None:  # a held pose keeps its signal too: nothing to read
            signal = 0.0 if self._window.holds(self._step_count) else \
                float(self._signal.read(self._world)[0])
        x, y = position[0, :2].tolist()
        self._window.push(time, x, y, self._step_count, signal)
        return True

    def _get_reward(self, window: Window | bool) -> float:
        """The step's reward from the robot's ``window`` after it.

        ``window``: False when not sampled; True when in :attr:`_window` (the float path).
        """
        previous = self._terms.fitness
        if self._blow_up is not None:
            self._terms = FitnessTerms(0.0, 0.0, 0.0)
        elif window is True:
            terms = self._window.terms()
            self._terms = terms if isinstance(terms, FitnessTerms) else FitnessTerms(*terms)
        elif not isinstance(window, bool):
            f = self._windows.score(window)
            self._terms = FitnessTerms(float(f[0]), float(window.v[0]), float(window.s[0]))
        if self._gain:
            return self._terms.fitness - previous
        if isinstance(window, bool):
            window = self._robot_window.current() if self._fast_windows else \
                self._windows.ring.current()
        return float(self.task.reward(window, np.array([self._terms.fitness]),
                                      np.array([previous]))[0])

    def _get_info(self, reward: float) -> dict[str, Any]:
        assert self._world is not None
        pos = self._world.states.core_pos[0]
        terms = self._terms
        return _info(terms.fitness, terms.v, terms.s, reward,
                     self._step_count * self.config.control_period,
                     self._step_count >= self._insertion_steps, float(pos[0]), float(pos[1]),
                     self._blow_up)
