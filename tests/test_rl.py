"""revolve_env.rl: the benchmark's normalised, short-episode vector env in one call, PPO with its
settings, and evaluation on another window with the normalisation statistics frozen."""

from __future__ import annotations

import sys
from collections.abc import Iterator

import numpy as np
import pytest

from revolve_env import rl
from revolve_env.body.examples import gecko, spider
from revolve_env.registration import LOCOMOTION_ID

pytest.importorskip("stable_baselines3")

from stable_baselines3.common.vec_env import VecNormalize  # noqa: E402

# 0.1 s + 0.4 s: 30-step episodes, so that a test sees several.
QUICK = rl.VecEnvConfig(n_envs=2, insertion_time=0.1, evaluation_time=0.4)


@pytest.fixture(autouse=True)
def one_torch_thread() -> Iterator[None]:
    """Torch on one thread, as the benchmark runs it (two threads on a busy two-core machine
    are several times slower)."""
    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)


def test_the_vec_env_is_normalised_monitored_and_short() -> None:
    venv = rl.make_vec_env("spider", QUICK, seed=3)
    assert isinstance(venv, VecNormalize) and venv.norm_obs and venv.norm_reward
    assert venv.num_envs == 2
    assert venv.observation_space.shape == (6 + 2 * 8,)  # Locomotion-v1: IMU, angles, speeds
    assert venv.get_attr("spec")[0].kwargs["fitness_window"] == 0.4
    obs = venv.reset()
    rng = np.random.default_rng(0)
    raw, dones, infos = [], 0, []
    for _ in range(90):
        obs, _, done, info = venv.step(rng.uniform(-1, 1, (2, 8)).astype(np.float32))
        raw.append(venv.get_original_obs())
        dones += int(done.sum())
        infos += [i for i, d in zip(info, done, strict=True) if d]
    assert dones == 6  # 3 episodes of 30 steps in each env
    assert all(i["episode"]["l"] == 30 for i in infos)  # Monitor's record
    # The episode's return is its fitness (the window is the evaluation time).
    assert all(i["episode"]["r"] == pytest.approx(i["fitness"], abs=1e-5) for i in infos)
    assert np.abs(obs).max() <= QUICK.clip_obs
    # The running statistics follow the raw observations (the accelerometer's gravity: ~9.8).
    assert venv.obs_rms.mean[2] == pytest.approx(np.mean([r[:, 2] for r in raw]), rel=0.2)
    venv.close()


def test_frozen_statistics_normalise_as_vec_normalize_does_and_stay_frozen() -> None:
    venv = rl.make_vec_env(gecko(), QUICK, seed=0)
    assert isinstance(venv, VecNormalize)
    venv.reset()
    for _ in range(20):
        venv.step(np.zeros((2, 6), np.float32))
    frozen = rl.ObservationNormalization.of(venv)
    raw = venv.get_original_obs()
    np.testing.assert_array_equal(frozen(raw), venv.normalize_obs(raw))
    mean = frozen.mean.copy()
    for _ in range(20):  # training goes on: the live statistics move, the copy does not
        venv.step(np.ones((2, 6), np.float32))
    assert not np.array_equal(venv.obs_rms.mean, mean)
    np.testing.assert_array_equal(frozen.mean, mean)
    with pytest.raises(ValueError, match="read-only"):
        frozen.mean[0] = 1.0
    venv.close()


def test_a_short_ppo_run_and_its_evaluation_on_the_paper_window() -> None:
    venv = rl.make_vec_env("spider", QUICK, seed=0)
    assert isinstance(venv, VecNormalize)
    model = rl.make_ppo(venv, seed=0, n_steps=256, batch_size=128, n_epochs=2)
    assert model.gamma == venv.gamma == QUICK.gamma
    assert model.policy.action_dist.action_dim == 8  # type: ignore[attr-defined]
    model.learn(2048)
    assert model.num_timesteps == 2048
    mean, var, count = venv.obs_rms.mean.copy(), venv.obs_rms.var.copy(), venv.obs_rms.count
    fitness = rl.policy_fitness(model, venv)  # 3 s + 12 s
    # The evaluation neither steps the training envs nor updates the statistics.
    assert venv.obs_rms.count == count
    np.testing.assert_array_equal(venv.obs_rms.mean, mean)
    np.testing.assert_array_equal(venv.obs_rms.var, var)
    # One episode: a float in metres, as the README prints it.
    assert isinstance(fitness, float) and np.isfinite(fitness) and fitness >= 0
    # Deterministic: the same policy and statistics give the same numbers, seed after seed
    # (ideal conditions: the seed changes nothing), and several seeds give their episodes' mean.
    short = [rl.policy_fitness(model, venv, insertion_time=0.1, evaluation_time=0.4, seeds=[seed])
             for seed in (0, 1)]
    assert short[0] == short[1] == rl.policy_fitness(model, venv, insertion_time=0.1,
                                                      evaluation_time=0.4, seeds=(0, 1))
    with pytest.raises(ValueError, match="at least one seed"):
        rl.policy_fitness(model, venv, seeds=())
    venv.close()


def test_modulate_mode_starts_on_the_robot_s_gait() -> None:
    venv = rl.make_vec_env("gecko", QUICK, action="modulate")
    assert venv.get_attr("controller")[0] == "brain"  # the robot's network runs
    assert venv.action_space.shape == (12,)
    model = rl.make_ppo(venv)
    assert float(model.policy.log_std.detach().mean()) == -1.5  # type: ignore[operator]
    # Before any training the deterministic policy is nearly the zero action: the CPG's gait.
    cpg = rl.policy_fitness(model, venv, insertion_time=0.1, evaluation_time=0.4)
    assert cpg > 0.05
    venv.close()


def test_without_normalisation_and_with_v0() -> None:
    config = rl.VecEnvConfig(n_envs=1, insertion_time=0.1, evaluation_time=0.2, normalize=False)
    venv = rl.make_vec_env(spider(), config, env_id=LOCOMOTION_ID)  # no "out of date" warning
    assert not isinstance(venv, VecNormalize)
    assert venv.observation_space.shape == (6,)
    venv.close()


def test_bad_settings_are_refused_in_one_line() -> None:
    with pytest.raises(ValueError, match="insertion phase earns 0"):
        rl.VecEnvConfig(evaluation_time=0.0)
    with pytest.raises(ValueError, match="n_envs"):
        rl.VecEnvConfig(n_envs=0)
    with pytest.raises(ValueError, match="insertion_time: the episode's times are VecEnvConfig"):
        rl.make_vec_env("spider", insertion_time=3.0)
    with pytest.raises(ValueError, match="no such robot file: spidr"):
        rl.make_vec_env("spidr")
    with pytest.raises(ValueError, match="action must be"):
        rl.make_vec_env("spider", QUICK, action="jump")


def test_missing_stable_baselines3_says_what_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "stable_baselines3", None)
    with pytest.raises(ImportError, match=r"pip install 'revolve-env\[learn\]'"):
        rl.make_vec_env("spider", QUICK)
