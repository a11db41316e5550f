"""The native vector env as a stable-baselines3 ``VecEnv`` (what ``rl.make_vec_env`` builds).

:class:`NativeVecEnv` drives a :class:`~revolve_env.envs.vector.LocomotionVectorEnv` (autoreset
in the same step, SB3's contract) and gives SB3 what ``DummyVecEnv`` over ``Monitor``-wrapped
single envs gives: per env an info dict with the single env's keys, ``terminal_observation`` and
``TimeLimit.truncated`` when its episode ends, and Monitor's ``episode`` entry (``r`` the return,
``l`` the steps, ``t`` wall seconds since the env was made), so ``ep_info_buffer``,
``rollout/ep_rew_mean`` and ``VecNormalize`` work unchanged. Seeds and resets follow
``DummyVecEnv``'s: ``seed(s)`` then ``reset()`` seeds env ``i`` with ``s + i`` once; later
episodes draw from each env's own generator. So a PPO run is, bit for bit, the run over
``DummyVecEnv`` of single envs (tests/envs/test_vector_sb3.py), for less work per step.

Needs stable-baselines3 (the ``learn`` extra); ``import revolve_env`` does not import this module.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Iterable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.envs.registration import EnvSpec
from gymnasium.vector import AutoresetMode
from numpy.typing import NDArray
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import VecEnv
from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices, VecEnvObs, VecEnvStepReturn

from revolve_env.envs.vector import INFO_KEYS, LocomotionVectorEnv

__all__ = ["NativeVecEnv"]


class NativeVecEnv(VecEnv):
    """``LocomotionVectorEnv`` behind SB3's ``VecEnv`` interface (see the module doc).

    Args:
        env_id: The Gymnasium id whose env this is (``Locomotion-v0`` or ``-v1``): its registered
            keywords come first, and ``get_attr("spec")`` gives its spec with every keyword.
        num_envs: Envs stepped together.
        **kwargs: :class:`~revolve_env.envs.LocomotionEnv`'s keywords.
    """

    def __init__(self, env_id: str, num_envs: int, **kwargs: Any) -> None:
        registered = gym.spec(env_id)
        env_kwargs = {**registered.kwargs, **kwargs}
        self.venv = LocomotionVectorEnv(num_envs, autoreset_mode=AutoresetMode.SAME_STEP,
                                        **env_kwargs)
        self.spec: EnvSpec = dataclasses.replace(registered, kwargs=env_kwargs,
                                                 max_episode_steps=None)
        super().__init__(num_envs, self.venv.single_observation_space,
                         self.venv.single_action_space)
        self._actions: NDArray[Any] = np.zeros(0, dtype=np.float32)  # step_async's
        self._returns = np.zeros(num_envs)
        self._lengths = np.zeros(num_envs, dtype=np.int64)
        self._t0 = time.time()

    # -- stepping -----------------------------------------------------------------------------
    def reset(self) -> VecEnvObs:
        """Start every env's episode (seeded once after :meth:`seed`); the observations."""
        seeds = list(self._seeds)
        obs, info = self.venv.reset(seed=seeds)
        self.reset_infos = self._infos(info, range(self.num_envs))
        self._reset_seeds()
        self._reset_options()
        self._returns[:] = 0.0
        self._lengths[:] = 0
        return obs

    def step_async(self, actions: NDArray[Any]) -> None:
        """Keep the actions for :meth:`step_wait`."""
        self._actions = np.asarray(actions)

    def step_wait(self) -> VecEnvStepReturn:
        """Step every env; an ended episode restarts at once (see the module doc)."""
        obs, rewards, terminated, truncated, info = self.venv.step(self._actions)
        dones = terminated | truncated
        self._returns += rewards  # summed as Monitor sums its list: in step order
        self._lengths += 1
        infos = self._infos(info, range(self.num_envs))
        ended = np.flatnonzero(dones)
        if ended.size:
            final = self._infos(info["final_info"], ended.tolist())
            now = round(time.time() - self._t0, 6)
            for i, last in zip(ended.tolist(), final, strict=True):
                last["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
                last["terminal_observation"] = info["final_obs"][i]
                last["episode"] = {"r": round(float(self._returns[i]), 6),
                                   "l": int(self._lengths[i]), "t": now}
                infos[i] = last
                self.reset_infos[i] = self._infos(info, [i])[0]
            self._returns[ended] = 0.0
            self._lengths[ended] = 0
        for i in np.flatnonzero(~dones).tolist():
            infos[i]["TimeLimit.truncated"] = False
        return obs, rewards.astype(np.float32), dones, infos

    @staticmethod
    def _infos(info: dict[str, Any], ids: Iterable[int]) -> list[dict[str, Any]]:
        """The single env's info dicts of envs ``ids`` from the vector env's arrays."""
        # one tolist() per key (Python scalars, as item() gives them) instead of one per entry
        columns = [(key, info[key].tolist()) for key in INFO_KEYS]
        return [{key: column[i] for key, column in columns} for i in ids]

    def close(self) -> None:
        """Release the vector env's world."""
        self.venv.close()

    # -- attributes ---------------------------------------------------------------------------
    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """The single env's attribute (the same for every env); ``spec``: :attr:`spec`."""
        value = self.spec if attr_name == "spec" else getattr(self.venv.env, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Not available: the envs share one batched state.

        Raises:
            NotImplementedError: always.
        """
        raise NotImplementedError(f"cannot set {attr_name!r} on the envs of one native vector "
                                  "env; make it with the keyword instead")

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None,
                   **method_kwargs: Any) -> list[Any]:
        """Not available: there are no single env objects to call.

        Raises:
            NotImplementedError: always.
        """
        raise NotImplementedError(f"the native vector env has no single envs to call "
                                  f"{method_name!r} on; use rl.VecEnvConfig(batched=False)")

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper[Any, Any, Any, Any]],
                       indices: VecEnvIndices = None) -> list[bool]:
        """True for ``Monitor`` (its ``episode`` infos are given), else False."""
        return [wrapper_class is Monitor for _ in self._get_indices(indices)]

    def get_images(self) -> Sequence[NDArray[Any] | None]:
        """No pictures: the native vector env does not render."""
        return [None for _ in range(self.num_envs)]
