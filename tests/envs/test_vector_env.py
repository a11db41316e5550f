"""The native vector env: bit for bit N single envs, every autoreset mode, Gymnasium's checks."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from gymnasium.vector import AutoresetMode, SyncVectorEnv

import revolve_env  # noqa: F401  (registers the ids)
from revolve_env.conditions import EvaluationConditions
from revolve_env.envs.locomotion import LocomotionEnv
from revolve_env.envs.vector import LocomotionVectorEnv
from revolve_env.registration import LOCOMOTION_ID, LOCOMOTION_V1_ID, vector_spec

SHORT = {"insertion_time": 0.1, "evaluation_time": 0.25}  # 6 + 15 = 21 steps per episode


def _pair(n: int, mode: AutoresetMode, **kwargs: Any) -> tuple[LocomotionVectorEnv,
                                                                SyncVectorEnv]:
    kwargs = {**SHORT, **kwargs}
    vec = LocomotionVectorEnv(n, autoreset_mode=mode, **kwargs)
    sync = SyncVectorEnv([lambda: LocomotionEnv(**kwargs) for _ in range(n)],
                         autoreset_mode=mode)
    return vec, sync


def _same(a: Any, b: Any) -> bool:
    return bool(np.array_equal(np.asarray(a), np.asarray(b)))


def _run(vec: LocomotionVectorEnv, sync: SyncVectorEnv, steps: int, seed: int = 3,
         mid_reset: int | None = None) -> int:
    """Step both with the same random actions; the number of steps compared (fails on a diff)."""
    o1, i1 = vec.reset(seed=seed)
    o2, i2 = sync.reset(seed=seed)
    assert _same(o1, o2)
    assert _same(i1["x_position"], i2["x_position"])
    rng = np.random.default_rng(seed)
    n = vec.num_envs
    for t in range(steps):
        if t == mid_reset:  # a partial reset: sub-envs 0 and 2 start again, mid-episode
            mask = np.zeros(n, dtype=bool)
            mask[::2] = True
            o1, _ = vec.reset(seed=[100 + i for i in range(n)], options={"reset_mask": mask})
            o2, _ = sync.reset(seed=[100 + i for i in range(n)],
                               options={"reset_mask": mask.copy()})
            assert _same(o1, o2)
        a = rng.uniform(-1, 1, (n, *vec.single_action_space.shape)).astype(np.float32)
        r1, r2 = vec.step(a), sync.step(a)
        for k, name in enumerate(("obs", "reward", "terminated", "truncated")):
            assert _same(r1[k], r2[k]), f"step {t}: {name} differs"
        for key in ("fitness", "fitness_v", "fitness_s", "time", "evaluating", "x_position"):
            assert _same(r1[4][key], r2[4][key]), f"step {t}: info {key} differs"
        if "final_obs" in r2[4]:
            ended = r2[4]["_final_obs"]
            assert _same(r1[4]["_final_obs"], ended)
            for i in np.flatnonzero(ended):
                assert _same(r1[4]["final_obs"][i], r2[4]["final_obs"][i])
    vec.close()
    sync.close()
    return steps


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_bit_for_bit_n_single_envs_mujoco(mode: AutoresetMode) -> None:
    pytest.importorskip("mujoco")
    vec, sync = _pair(3, mode, engine="mujoco", proprioception=True)
    _run(vec, sync, 50, mid_reset=30)  # two autoresets of every env and a partial reset


def test_bit_for_bit_with_noise_random_starts_and_a_pose_rate() -> None:
    pytest.importorskip("mujoco")
    conditions = EvaluationConditions(heading="random", position_jitter=0.05, sensor_noise=0.1,
                                      actuator_noise=0.05, reset_noise_scale=0.1)
    vec, sync = _pair(3, AutoresetMode.NEXT_STEP, engine="mujoco", conditions=conditions,
                      proprioception=True, task={"name": "locomotion", "pose_rate": 10.0})
    _run(vec, sync, 46)


def test_bit_for_bit_with_the_robots_own_network_modulated() -> None:
    pytest.importorskip("mujoco")
    vec, sync = _pair(2, AutoresetMode.NEXT_STEP, engine="mujoco", action="modulate",
                      proprioception=True)
    _run(vec, sync, 25)


@pytest.mark.slow
def test_bit_for_bit_n_single_envs_pybullet() -> None:
    vec, sync = _pair(3, AutoresetMode.NEXT_STEP, engine="pybullet", proprioception=True)
    _run(vec, sync, 46, mid_reset=30)


def test_disabled_autoreset_asks_for_a_reset_mask() -> None:
    pytest.importorskip("mujoco")
    vec = LocomotionVectorEnv(2, autoreset_mode=AutoresetMode.DISABLED, engine="mujoco",
                              **SHORT)
    vec.reset(seed=0)
    zeros = np.zeros((2, *vec.single_action_space.shape), dtype=np.float32)
    for _ in range(21):
        _, _, _, truncated, _ = vec.step(zeros)
    assert truncated.all()
    with pytest.raises(RuntimeError, match=r"envs \[0, 1\] is over"):
        vec.step(zeros)
    vec.reset(options={"reset_mask": np.array([True, True])})
    vec.step(zeros)
    vec.close()


def test_make_vec_through_the_vector_spec() -> None:
    pytest.importorskip("mujoco")
    venv = gym.make_vec(vector_spec(LOCOMOTION_V1_ID), num_envs=4,
                        vectorization_mode="vector_entry_point", engine="mujoco", **SHORT)
    assert isinstance(venv.unwrapped, LocomotionVectorEnv)
    assert venv.observation_space.shape == (4, *venv.single_observation_space.shape)
    assert venv.metadata["autoreset_mode"] is AutoresetMode.NEXT_STEP
    obs, info = venv.reset(seed=0)
    assert obs.shape == venv.observation_space.shape and info["_fitness"].all()
    venv.close()
    plain = gym.make_vec(vector_spec(LOCOMOTION_ID), num_envs=2,
                         vectorization_mode="vector_entry_point", engine="mujoco", **SHORT)
    assert plain.single_observation_space.shape == (6,)  # the spider's IMU only (v0)
    plain.close()


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"num_envs": 0}, "num_envs must be an integer >= 1"),
    ({"render_mode": "rgb_array"}, "does not render"),
    ({"max_episode_steps": 4}, "max_episode_steps=4 ends every episode within"),
    ({"controller": "nobody"}, "controller must be 'agent' or 'brain'"),
])
def test_bad_arguments_are_refused_in_one_line(kwargs: dict[str, Any], message: str) -> None:
    with pytest.raises(ValueError, match=message) as error:
        LocomotionVectorEnv(**{"num_envs": 2, **SHORT, **kwargs})
    assert "\n" not in str(error.value)


def test_each_sub_env_passes_gymnasiums_check_env() -> None:
    pytest.importorskip("mujoco")
    vec = LocomotionVectorEnv(2, engine="mujoco", **SHORT)
    for i in range(vec.num_envs):  # each sub-env is the single env of the same keywords
        env = LocomotionEnv(**vec.env_kwargs)
        assert env.observation_space == vec.single_observation_space
        assert env.action_space == vec.single_action_space
        check_env(env, skip_render_check=True)
        env.close()
        assert i < vec.num_envs
    vec.close()


def test_a_bad_action_is_refused() -> None:
    pytest.importorskip("mujoco")
    vec = LocomotionVectorEnv(2, engine="mujoco", **SHORT)
    vec.reset(seed=0)
    with pytest.raises(ValueError, match="actions must have shape"):
        vec.step(np.zeros((3, 8), dtype=np.float32))
    bad = np.zeros((2, *vec.single_action_space.shape), dtype=np.float32)
    bad[1, 0] = np.nan
    with pytest.raises(ValueError, match="NaN or infinity"):
        vec.step(bad)
    vec.close()


def test_two_threads_give_the_same_steps() -> None:
    pytest.importorskip("mujoco")
    one = LocomotionVectorEnv(4, engine="mujoco", **SHORT)
    two = LocomotionVectorEnv(4, engine="mujoco", threads=2, **SHORT)
    assert np.array_equal(one.reset(seed=1)[0], two.reset(seed=1)[0])
    rng = np.random.default_rng(1)
    for _ in range(25):
        a = rng.uniform(-1, 1, one.action_space.shape).astype(np.float32)
        for x, y in zip(one.step(a)[:4], two.step(a)[:4], strict=True):
            assert np.array_equal(x, y)
    assert two._world is not None and two._world.backend._batch.nthread == 2  # type: ignore
    one.close()
    two.close()
    with pytest.raises(ValueError, match="threads must be an integer >= 1"):
        LocomotionVectorEnv(2, threads=0, **SHORT)
