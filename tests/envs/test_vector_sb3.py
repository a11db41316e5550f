"""rl.make_vec_env's native vector env: DummyVecEnv's steps and PPO's run, bit for bit."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from stable_baselines3.common.monitor import Monitor  # noqa: E402
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize  # noqa: E402

from revolve_env import rl  # noqa: E402
from revolve_env.envs.sb3_vector import NativeVecEnv  # noqa: E402
from revolve_env.envs.vector import INFO_KEYS  # noqa: E402

SHORT = {"insertion_time": 0.1, "evaluation_time": 0.25}  # 21 steps per episode


def _both(**kwargs: Any) -> tuple[Any, Any]:
    native = rl.make_vec_env("spider", rl.VecEnvConfig(n_envs=3, normalize=False, **SHORT),
                             seed=7, **kwargs)
    dummy = rl.make_vec_env("spider", rl.VecEnvConfig(n_envs=3, normalize=False, batched=False,
                                                      **SHORT), seed=7, **kwargs)
    assert isinstance(native, NativeVecEnv) and isinstance(dummy, DummyVecEnv)
    return native, dummy


def test_native_steps_are_dummy_vec_envs_bit_for_bit() -> None:
    native, dummy = _both()
    assert np.array_equal(native.reset(), dummy.reset())
    rng = np.random.default_rng(0)
    episodes = 0
    for _ in range(50):  # two episodes of every env, autoreset in the step
        actions = rng.uniform(-1, 1, (3, *native.action_space.shape)).astype(np.float32)
        native.step_async(actions)
        dummy.step_async(actions)
        o1, r1, d1, i1 = native.step_wait()
        o2, r2, d2, i2 = dummy.step_wait()
        assert np.array_equal(o1, o2) and np.array_equal(r1, r2) and np.array_equal(d1, d2)
        assert r1.dtype == r2.dtype
        for a, b in zip(i1, i2, strict=True):
            for key in INFO_KEYS:  # the single env's values, of its types
                assert a[key] == b[key] and type(a[key]) is type(b[key]), key
            assert a["TimeLimit.truncated"] == b["TimeLimit.truncated"]
            assert ("terminal_observation" in a) == ("terminal_observation" in b)
            if "episode" in b:
                episodes += 1
                assert a["episode"]["r"] == b["episode"]["r"]
                assert a["episode"]["l"] == b["episode"]["l"]
                assert np.array_equal(a["terminal_observation"], b["terminal_observation"])
    assert episodes == 6
    assert native.env_is_wrapped(Monitor) == [True] * 3
    assert native.get_attr("action_mode") == ["targets"] * 3
    assert native.get_attr("spec")[0].kwargs["proprioception"] is True
    with pytest.raises(NotImplementedError, match="batched=False"):
        native.env_method("render")
    native.close()
    dummy.close()


@pytest.mark.slow
def test_ppo_learns_the_same_policy_on_both_routes() -> None:
    params = []
    for batched in (True, False):
        venv = rl.make_vec_env("spider", rl.VecEnvConfig(n_envs=2, batched=batched, **SHORT),
                               seed=1)
        assert isinstance(venv, VecNormalize)
        model = rl.make_ppo(venv, seed=1, n_steps=32, batch_size=32, n_epochs=1).learn(128)
        params.append([p.detach().numpy().copy() for p in model.policy.parameters()])
        assert len(model.ep_info_buffer) > 0
        venv.close()
    for a, b in zip(*params, strict=True):
        assert np.array_equal(a, b)
