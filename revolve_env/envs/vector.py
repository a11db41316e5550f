"""Many copies of one robot in one batched env: ``gym.make_vec(..., "vector_entry_point")``.

:class:`LocomotionVectorEnv` is the Gymnasium ``VectorEnv`` of ``revolve_env/Locomotion-v0`` and
``-v1``: ``num_envs`` copies of :class:`~revolve_env.envs.LocomotionEnv`, each robot in a scene of
its own of one isolated :class:`~revolve_env.world.World` (``World(config, isolated=True)``, as
:func:`revolve_env.evaluate_many` uses), stepped together: one call per control period writes every
robot's targets, steps every scene (MuJoCo: :mod:`~revolve_env.world.mujoco_batch`, one
``mujoco.batch`` of the N copies of one model; pybullet: a client per robot) and reads every
robot's sensors and pose as ``(num_envs, ...)`` arrays; the observations, rewards, terminations and
truncations are those arrays.

Every rule is the single env's, from its one home: the arguments are checked and the spaces,
the episode's steps, the task, the conditions and the world's config are made by a
:class:`~revolve_env.envs.LocomotionEnv` built from the same keywords (it never makes a world);
the servo law, sensors and blow-ups are the world's; each episode's fitness window is the single
env's :class:`~revolve_env.fitness.SlidingWindowFitness`, scored by the task for all envs at once.
So sub-env ``i`` gives, bit for bit, the observations, rewards, terminations and truncations of a
single env reset with the same seed and given the same actions (tests/envs/test_vector_env.py),
with every autoreset mode of Gymnasium 1.x (``autoreset_mode``: next step, by default, as
``SyncVectorEnv``; same step; disabled, with ``reset(options={"reset_mask": ...})``).

What differs from ``SyncVectorEnv`` over single envs: no rendering (``render_mode`` must be
None); the ``blow_up`` reason's time is the vector env's clock, not the episode's.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numpy.typing import NDArray

from revolve_env.brain import BatchController
from revolve_env.envs.locomotion import LocomotionEnv, _all_finite
from revolve_env.envs.observations import hinge_values
from revolve_env.episode_length import check_time_limit
from revolve_env.evaluation import start_generator
from revolve_env.fitness import FitnessTerms, SlidingWindowFitness
from revolve_env.fitness.sampling import pose_due
from revolve_env.fitness.terms import Window
from revolve_env.tasks import score
from revolve_env.world import World
from revolve_env.world.signals import SignalReader, signal_reader

__all__ = ["INFO_KEYS", "LocomotionVectorEnv"]

INFO_KEYS = ("fitness", "fitness_v", "fitness_s", "reward_fitness", "time", "evaluating",
              "x_position", "y_position", "blow_up")


def _stack(windows: Sequence[Window]) -> Window:
    """One :class:`Window` of the robots of several one-robot windows, in order."""
    fields: list[Any] = [None if parts[0] is None else np.concatenate(parts)
                         for parts in zip(*windows, strict=True)]
    return Window(*fields)


def _rows_of(window: Window, rows: NDArray[np.intp]) -> Window:
    """The robots ``rows`` of ``window``."""
    fields: list[Any] = [None if f is None else f[rows] for f in window]
    return Window(*fields)


class LocomotionVectorEnv(VectorEnv[NDArray[np.float64], NDArray[np.float32],
                                    NDArray[Any]]):
    """``num_envs`` copies of one robot's locomotion env, stepped in one batch (see the module).

    Spaces are the single env's batched: observations ``(num_envs, m)`` float64, actions
    ``(num_envs, n)`` float32 in [-1, 1], rewards ``(num_envs,)`` float64 (metres),
    terminations and truncations ``(num_envs,)`` bool. Infos hold the single env's keys as
    ``(num_envs,)`` arrays, each with its ``_key`` mask (Gymnasium's vector info layout).

    Args:
        num_envs: Copies of the robot (>= 1).
        autoreset_mode: Gymnasium's :class:`~gymnasium.vector.AutoresetMode` (or its value):
            ``NEXT_STEP`` (default) resets an ended sub-env at the next ``step``, whose action
            for it is ignored (reward 0); ``SAME_STEP`` resets it in the step that ends it (its
            last observation and info in ``info["final_obs"]``, ``info["final_info"]``);
            ``DISABLED``: the caller resets ended sub-envs with ``options={"reset_mask": m}``.
        max_episode_steps: The registered limit ``gym.make_vec`` passes: refused when it would
            cut the env's own episode short (as ``gym.make``'s); None or -1: none.
        threads: Threads that step the robots (MuJoCo: the ``mujoco.batch`` of the copies, the
            same numbers at any count; pybullet steps in this thread).
        **kwargs: :class:`~revolve_env.envs.LocomotionEnv`'s keywords (robot, times, task,
            conditions, engine, ...), checked by it.

    Raises:
        ValueError: ``num_envs`` < 1, a ``render_mode``, a limit shorter than the episode, or
            any of the single env's one-line refusals.
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}  # noqa: RUF012

    def __init__(self, num_envs: int = 1, *,
                 autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
                 max_episode_steps: int | None = None, threads: int = 1,
                 **kwargs: Any) -> None:
        if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        if kwargs.get("render_mode") is not None:
            raise ValueError("the vector env does not render: make single envs "
                             "(gym.make) to watch a robot")
        mode = autoreset_mode if isinstance(autoreset_mode, AutoresetMode) else \
            AutoresetMode(autoreset_mode)
        env = LocomotionEnv(**kwargs)  # every argument's check and every derived setting
        check_time_limit(max_episode_steps, env)
        if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
            raise ValueError(f"threads must be an integer >= 1, got {threads!r}")
        self.threads = threads
        self.env = env
        self.env_kwargs = dict(kwargs)
        self.num_envs = num_envs
        self.autoreset_mode = mode
        self.metadata = {**self.metadata, "autoreset_mode": mode}
        self.render_mode = None
        self.single_observation_space = env.observation_space
        self.single_action_space = env.action_space
        self.observation_space = batch_space(env.observation_space, num_envs)
        self.action_space = batch_space(env.action_space, num_envs)
        self.config = env.config
        self.robot = env.robot
        self.task = env.task
        self.conditions = env.conditions
        self.controller = env.controller
        self.action_mode = env.action_mode
        self.proprioception = env.proprioception

        n = num_envs
        self._world: World | None = None
        self._handles = np.full(n, -1, dtype=np.intp)
        self._rows = np.zeros(n, dtype=np.intp)  # each env's row in the world's arrays
        self._ordered = True  # rows == arange(n): no gather needed
        self._rngs: list[np.random.Generator] = [seeding.np_random()[0] for _ in range(n)]
        self._brains: list[BatchController | None] = [None] * n
        self._brain_out = np.zeros((n, env._n_outputs))
        self._fitness = [SlidingWindowFitness(env.fitness_window,
                                              signal=env.task.signal is not None)
                         for _ in range(n)]
        self._signal: SignalReader | None = None
        self._f = np.zeros(n)  # each episode's fitness terms so far. Metres
        self._v = np.zeros(n)
        self._s = np.zeros(n)
        self._steps = np.zeros(n, dtype=np.int64)  # control periods since each env's reset
        self._time = np.zeros(n)  # each episode's clock, summed as a world's. Seconds
        self._blow_up: list[str | None] = [None] * n
        self._blown = np.zeros(n, dtype=bool)
        self._obs = np.zeros((n, len(env._obs_low)))
        self._ended = np.zeros(n, dtype=bool)  # episodes over (to reset, per the mode)
        self._started = False

    # -- gymnasium API --------------------------------------------------------------------------
    def reset(self, *, seed: int | Sequence[int | None] | None = None,
              options: dict[str, Any] | None = None
              ) -> tuple[NDArray[np.float64], dict[str, Any]]:
        """Start every sub-env's episode (or those of ``options["reset_mask"]``).

        ``seed``: None, an int (sub-env ``i`` gets ``seed + i``, as ``SyncVectorEnv``) or one
        seed per sub-env; each sub-env starts as a single env reset with its seed.
        """
        n = self.num_envs
        seeds: list[int | None]
        if seed is None:
            seeds = [None] * n
        elif isinstance(seed, int | np.integer):
            seeds = [int(seed) + i for i in range(n)]
        else:
            seeds = list(seed)
            if len(seeds) != n:
                raise ValueError(f"{len(seeds)} seeds for {n} envs")
        mask = np.ones(n, dtype=bool)
        if options is not None and "reset_mask" in options:
            mask = np.asarray(options["reset_mask"])
            if mask.dtype != np.bool_ or mask.shape != (n,):
                raise ValueError(f"options['reset_mask'] must be a bool array of shape ({n},)")
            if not mask.any() and self._started:
                raise ValueError("options['reset_mask'] resets no env")
            if not self._started and not mask.all():
                raise ValueError("the first reset must reset every env")
        if self._world is None:
            self._world = World(self.config, isolated=True, threads=self.threads)
        elif mask.all():  # a new world is cheaper than every robot's removal
            self._world.reset()
            self._handles[:] = -1
        ids = np.flatnonzero(mask)
        for i in ids.tolist():
            if seeds[i] is not None:
                self._rngs[i] = seeding.np_random(seeds[i])[0]
        self._remove(ids)
        self._insert(ids, seeds)
        self._ended[ids] = False
        self._started = True
        obs = self._observe()
        self._obs[ids] = obs[ids]
        return self._obs.copy(), self._info(np.zeros(n), ids)

    def step(self, actions: NDArray[np.float32]
             ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_],
                        NDArray[np.bool_], dict[str, Any]]:
        """Act for one control period in every sub-env (see the class doc for autoresets)."""
        if self._world is None or not self._started:
            raise RuntimeError("call reset() before step()")
        world, n, env = self._world, self.num_envs, self.env
        a = np.asarray(actions, dtype=np.float64)
        shape = (n, env._n_outputs * (2 if self.action_mode == "modulate" else 1))
        if a.shape != shape:
            raise ValueError(f"actions must have shape {shape}, got {a.shape}")
        restart = np.zeros(n, dtype=bool)
        if self._ended.any():
            if self.autoreset_mode is not AutoresetMode.NEXT_STEP:
                raise RuntimeError("the episode of envs "
                                   f"{np.flatnonzero(self._ended).tolist()} is over; reset them "
                                   "(options={'reset_mask': ...})")
            restart = self._ended.copy()
        live = np.flatnonzero(~restart)
        if not _all_finite(a[live]):
            raise ValueError(f"actions contain NaN or infinity: {a}")
        if live.size:
            targets = self._targets(np.minimum(np.maximum(a, -1.0), 1.0), live)
            flat = np.zeros((len(world.handles), env._n_outputs))
            flat[self._rows[live]] = targets[live]
            world.set_all_targets(flat.reshape(-1))
        world.step(1)
        self._steps[live] += 1
        self._time[live] += self.config.control_period
        rewards = self._advance(live)
        terminated = self._blown.copy()
        truncated = ~terminated & (self._steps >= env._total_steps)
        terminated[restart] = truncated[restart] = False
        rewards[restart] = 0.0
        obs = self._observe()
        self._obs[live] = obs[live]
        info = self._info(rewards, live)
        ended = terminated | truncated
        ids = np.flatnonzero(ended)
        if self.autoreset_mode is AutoresetMode.SAME_STEP and ids.size:
            final_obs = np.full(n, None, dtype=object)
            for i in ids.tolist():
                final_obs[i] = self._obs[i].copy()
            info["final_obs"], info["_final_obs"] = final_obs, ended.copy()
            info["final_info"] = {k: ended.copy() if k.startswith("_") else v.copy()
                                  for k, v in info.items() if not k.startswith("final")}
            info["_final_info"] = ended.copy()
        same = self.autoreset_mode is AutoresetMode.SAME_STEP
        born = np.flatnonzero(ended) if same else np.flatnonzero(restart)
        if born.size:  # new episodes, after the step: their robots start unstepped
            self._remove(born)
            self._insert(born, [None] * n)
            fresh = self._observe()
            self._obs[born] = fresh[born]
            self._info(np.zeros(n), born, info)
        self._ended = ended & (not same)
        if ids.size and not same:
            self._remove(ids)  # their final state is read: their scenes are not stepped on
        return self._obs.copy(), rewards, terminated, truncated, info

    def close_extras(self, **kwargs: Any) -> None:
        """Release the world (a later ``reset`` makes a new one)."""
        if self._world is not None:
            self._world.close()
            self._world = None
            self._handles[:] = -1
            self._started = False

    # -- episodes -------------------------------------------------------------------------------
    def _remove(self, ids: NDArray[np.intp]) -> None:
        """Take the robots of envs ``ids`` out of the world (those that have one)."""
        world = self._world
        assert world is not None
        gone = [i for i in ids.tolist() if self._handles[i] >= 0]
        if gone and len(gone) == len(world.handles):  # every robot: a fresh world is cheaper
            world.reset()
            self._handles[gone] = -1
        for i in gone:
            if self._handles[i] >= 0:
                world.remove_robot(int(self._handles[i]))
                self._handles[i] = -1
        if gone:
            self._relayout()

    def _insert(self, ids: NDArray[np.intp], seeds: Sequence[int | None]) -> None:
        """Start the episodes of envs ``ids`` as :meth:`LocomotionEnv.reset` starts one."""
        world, env = self._world, self.env
        assert world is not None
        for i in ids.tolist():
            rng = start_generator(seeds[i]) if seeds[i] is not None else self._rngs[i]
            start = self.conditions.start(rng)
            h = world.add_robot(self.robot, start.position, start.yaw)
            self._handles[i] = h
            joints = self.conditions.start_joints(rng, env._n_outputs)
            if joints is not None:
                world.set_hinge_state(h, *joints)
            if self.controller == "brain":
                brain = BatchController(self.config.brain_dt)
                brain.add(self.robot)
                self._brains[i] = brain
                self._brain_out[i] = 0.0
            self._fitness[i].reset()
            self._f[i] = self._v[i] = self._s[i] = 0.0
            self._steps[i] = 0
            self._time[i] = 0.0
            self._blow_up[i] = None
            self._blown[i] = False
        self._relayout()
        if env._insertion_steps == 0 and ids.size:  # the evaluation starts right away
            pos, sig = world.states.core_pos, self._signals()
            for i in ids.tolist():
                self._fitness[i].add(0.0, pos[self._rows[i]],
                                     None if sig is None else float(sig[self._rows[i]]))

    def _relayout(self) -> None:
        """Each env's row after births and deaths; the task's signal reader for the rows."""
        world = self._world
        assert world is not None
        rows = {h: r for r, h in enumerate(world.handles)}
        self._rows = np.array([rows.get(int(h), -1) for h in self._handles], dtype=np.intp)
        self._ordered = bool((self._rows == np.arange(self.num_envs)).all())
        self._signal = signal_reader(self.task.signal, [self.robot] * len(rows), world)

    def _signals(self) -> NDArray[np.float64] | None:
        """The task's signal of every robot of the world (rows), or None without one."""
        if self._signal is None:
            return None
        assert self._world is not None
        return self._signal.read(self._world)

    # -- one control period -------------------------------------------------------------------
    def _targets(self, action: NDArray[np.float64], live: NDArray[np.intp]
                 ) -> NDArray[np.float64]:
        """Every env's normalized targets (rows ``live``): :meth:`LocomotionEnv._targets`'s."""
        env = self.env
        targets = action
        if self.controller == "brain":
            brain_in = self._obs[:, :env._n_inputs]  # RoboGen's sensors only
            for i in live.tolist():
                if self._steps[i] % self.config.brain_stride == 0:  # else its targets hold
                    brain = self._brains[i]
                    assert brain is not None
                    out = self._brain_out[i].copy()
                    brain.step(brain_in[i].copy(), out)
                    self._brain_out[i] = out
            if self.action_mode == "targets":
                targets = self._brain_out.copy()
            else:
                k = env._n_outputs
                targets = (1.0 + action[:, :k]) * self._brain_out + action[:, k:]
        noise = self.conditions.actuator_noise
        if noise > 0:
            targets = targets.copy()
            for i in live.tolist():
                targets[i] = targets[i] + self._rngs[i].normal(0.0, noise, targets[i].shape)
        return targets

    def _advance(self, live: NDArray[np.intp]) -> NDArray[np.float64]:
        """Blow-ups, fitness samples and rewards of envs ``live`` after a step (others: 0)."""
        world, env = self._world, self.env
        assert world is not None
        n = self.num_envs
        rows = self._rows
        blown = world.blown_up
        for i in live.tolist():
            if blown[rows[i]] and self._blow_up[i] is None:
                self._blow_up[i] = world.blow_up(int(self._handles[i]))
                self._blown[i] = True
        evaluating = np.zeros(n, dtype=bool)
        evaluating[live] = self._steps[live] >= env._insertion_steps
        sample = evaluating & ~self._blown
        if sample.any():
            ages = self._steps - env._insertion_steps
            due = pose_due(ages, env._windows.stride)
            pos, sig = world.states.core_pos, self._signals()
            for i in np.flatnonzero(sample).tolist():
                fit = self._fitness[i]
                if due[i] or not len(fit):
                    fit.add(float(self._time[i]), pos[rows[i]],
                            None if sig is None else float(sig[rows[i]]))
                else:  # between pose samples the robot holds its last one: no reward
                    fit.add(float(self._time[i]), *fit.last())
        previous = self._f.copy()
        gain = env._gain
        who = np.flatnonzero(sample) if gain else live  # whose windows are read
        window = _stack([self._fitness[i].current() for i in who.tolist()]) if who.size \
            else None
        scored = np.flatnonzero(sample[who])
        if window is not None and scored.size:
            part = _rows_of(window, scored)
            at = who[scored]
            self._f[at], self._v[at], self._s[at] = score(self.task, part), part.v, part.s
        dead = live[self._blown[live]]
        self._f[dead] = self._v[dead] = self._s[dead] = 0.0
        rewards = np.zeros(n)
        if gain:
            rewards[live] = self._f[live] - previous[live]
        elif window is not None:
            rewards[live] = self.task.reward(window, self._f[live], previous[live])
        return rewards

    def _observe(self) -> NDArray[np.float64]:
        """Every env's observation now (rows of envs without a robot: zeros).

        :meth:`LocomotionEnv._get_obs`'s rule: the sensors (and hinge angles and speeds), zeros
        after a blow-up or on a non-finite value, then the noise, then clipped to the bounds.
        """
        world, env, n = self._world, self.env, self.num_envs
        assert world is not None
        count = len(world.handles)
        obs = world.sensor_values().reshape(count, env._n_inputs)
        if self.proprioception:
            k = env._n_outputs
            angles, speeds = hinge_values(world)
            obs = np.concatenate((obs, angles.reshape(count, k), speeds.reshape(count, k)),
                                 axis=1)
        if self._ordered and count == n:
            out = obs.copy()
        else:
            out = np.zeros((n, obs.shape[1]))
            present = self._rows >= 0
            out[present] = obs[self._rows[present]]
        bad = self._blown | ~np.isfinite(out).all(axis=1)
        out[bad] = 0.0
        noise = self.conditions.sensor_noise
        if noise > 0:
            for i in np.flatnonzero(~bad & (self._rows >= 0)).tolist():
                out[i] += self._rngs[i].normal(0.0, noise, out.shape[1])
        low, high = env._obs_low, env._obs_high
        ok = ~bad
        out[ok] = np.minimum(np.maximum(out[ok], low), high)
        return out

    def _info(self, rewards: NDArray[np.float64], ids: NDArray[np.intp],
              info: dict[str, Any] | None = None) -> dict[str, Any]:
        """The single env's info keys as arrays (rows ``ids`` written into ``info``)."""
        n, env = self.num_envs, self.env
        if info is None:
            info = {"fitness": np.zeros(n), "fitness_v": np.zeros(n), "fitness_s": np.zeros(n),
                    "reward_fitness": np.zeros(n), "time": np.zeros(n),
                    "evaluating": np.zeros(n, dtype=bool), "x_position": np.zeros(n),
                    "y_position": np.zeros(n), "blow_up": np.full(n, None, dtype=object)}
            for key in INFO_KEYS:
                info["_" + key] = np.zeros(n, dtype=bool)
        world = self._world
        assert world is not None
        pos = world.states.core_pos
        rows = self._rows[ids]
        info["fitness"][ids] = self._f[ids]
        info["fitness_v"][ids] = self._v[ids]
        info["fitness_s"][ids] = self._s[ids]
        info["reward_fitness"][ids] = rewards[ids]
        info["time"][ids] = self._steps[ids] * self.config.control_period
        info["evaluating"][ids] = self._steps[ids] >= env._insertion_steps
        info["x_position"][ids] = pos[rows, 0]
        info["y_position"][ids] = pos[rows, 1]
        for i in ids.tolist():
            info["blow_up"][i] = self._blow_up[i]
        for key in INFO_KEYS:
            info["_" + key][ids] = True
        return info

    def terms(self) -> list[FitnessTerms]:
        """Each sub-env's fitness terms so far (metres), as its ``info`` gives them."""
        return [FitnessTerms(float(f), float(v), float(s))
                for f, v, s in zip(self._f, self._v, self._s, strict=True)]


