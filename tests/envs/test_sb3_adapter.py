"""PopulationVecEnv: the uniform-space population env as an SB3 VecEnv of slots (no training)."""

from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path

import numpy as np
import pytest

from revolve_env.body.examples import gecko, snake, spider
from revolve_env.envs.checks import BirthsAndDeaths
from revolve_env.envs.population import population_env
from revolve_env.envs.sb3_adapter import PopulationVecEnv


def _vec(n_slots: int = 3, **kwargs: object) -> PopulationVecEnv:
    defaults: dict[str, object] = {
        "space_mode": "uniform", "proprioception": True, "max_births": 12, "birth_radius": 3.0,
        "insertion_time": 0.05,
        # rewards at every step: a late-born agent lives too few steps for two 5 Hz poses
        "task": {"name": "locomotion", "pose_rate": "every-period"},
        "lifecycle": BirthsAndDeaths(birth_every=6, death_every=9,
                                     newborns=((gecko(), "agent"), (snake(3), "brain"))),
    }
    env = population_env(**{**defaults, **kwargs})
    return PopulationVecEnv(env, n_slots, reset_options={"robots": [
        {"robot": spider(), "controlled_by": "agent"}, snake(2)]})


def test_slots_follow_births_and_deaths_and_late_born_agents_get_obs_and_rewards() -> None:
    venv = _vec()
    venv.seed(0)
    obs = venv.reset()
    n_obs = venv.env.observation_space("robot_0").shape[0]
    assert obs.shape == (3, venv.observation_space.shape[0]) and obs.dtype == np.float32
    assert venv.observation_space.shape[0] == n_obs + n_obs + 10  # observation, its mask, act mask
    assert venv.slot_agents == ["robot_0", None, None]  # the brain-driven snake takes no slot
    assert np.all(obs[1:] == 0)
    rewarded: dict[str, float] = {}
    observed: dict[str, int] = {}
    births: list[tuple[int, int, str]] = []
    deaths: list[tuple[int, dict[str, object]]] = []
    rng = np.random.default_rng(0)
    for step in range(1, 61):
        before = list(venv.slot_agents)
        obs, rewards, dones, infos = venv.step(rng.uniform(-1, 1, (3, 10)).astype(np.float32))
        for i, (info, agent) in enumerate(zip(infos, venv.slot_agents, strict=True)):
            assert info["agent"] == agent
            if agent is None:
                assert np.all(obs[i] == 0) and (rewards[i] == 0 or dones[i])
            else:
                assert np.any(obs[i] != 0)
                observed[agent] = observed.get(agent, 0) + 1
            prev = before[i]
            if prev is not None and not dones[i]:
                rewarded[prev] = rewarded.get(prev, 0.0) + abs(float(rewards[i]))
            if dones[i] and "episode" in info:
                deaths.append((step, info))
                assert info["TimeLimit.truncated"] is True  # a removal: bootstrap the value
                assert info["terminal_observation"].shape == obs[i].shape
            if agent is not None and agent != prev:
                births.append((step, i, agent))
                assert dones[i]  # the slot's previous episode (or empty stretch) ends
    born_late = {a for _, _, a in births}
    assert {"robot_2", "robot_4"} <= born_late  # the geckos born by lifecycle (steps 6, 18)
    for agent in born_late:
        assert observed[agent] > 0 and rewarded.get(agent, 0.0) > 0, agent
    assert deaths, "the oldest robots die every 9 steps"
    assert all(d["episode"]["l"] > 0 for _, d in deaths)
    venv.close()


def test_padding_of_actions_and_bad_shapes() -> None:
    venv = _vec(n_slots=2, lifecycle=None)
    venv.seed(1)
    venv.reset()
    with pytest.raises(ValueError, match=r"actions must have shape \(2, 10\)"):
        venv.step(np.zeros((2, 8), np.float32))
    # Entries past the spider's 8 hinges are dropped (the env would ignore them anyway).
    venv.step(np.full((2, 10), 0.5, np.float32))
    with pytest.raises(ValueError, match="space_mode='uniform'"):
        PopulationVecEnv(population_env(space_mode="exact"), 2)
    with pytest.raises(ValueError, match="n_slots"):
        PopulationVecEnv(population_env(space_mode="uniform"), 0)
    venv.close()


def test_overflow_is_unslotted_and_an_empty_world_resets() -> None:
    venv = _vec(n_slots=1, max_cycles=20)
    venv.seed(2)
    venv.reset()
    for _ in range(20):
        _, _, dones, infos = venv.step(np.zeros((1, 10), np.float32))
    assert venv.unslotted  # gecko born at step 6 while the spider held the only slot
    assert venv.resets == 2  # max_cycles truncated every robot: a new population episode
    assert dones[0] and infos[0]["TimeLimit.truncated"] and infos[0]["agent"] == "robot_0"
    venv.close()


@pytest.mark.slow
def test_shared_policy_example_trains_and_late_born_agents_get_observations_and_rewards(
        tmp_path: Path) -> None:
    """A few PPO iterations of examples/multi_agent_shared_policy.py, births every 40 steps."""
    path = Path(__file__).resolve().parents[2] / "examples" / "multi_agent_shared_policy.py"
    spec = importlib.util.spec_from_file_location("multi_agent_shared_policy", path)
    assert spec is not None and spec.loader is not None
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    args = argparse.Namespace(iterations=3, slots=4, n_steps=128, birth_every=40, death_every=60,
                              episode_steps=300, seed=0, engine="pybullet")
    rows = example.run(args)
    assert len(rows) == 3
    assert all(np.isfinite(r["rate"]) for r in rows)
    # Robots born after the population episode began were driven, observed and rewarded.
    assert sum(r["late_born"] for r in rows) >= 3
    assert all(r["late_observed"] >= 1 and r["late_rewarded"] >= 1 for r in rows)
    example.plot(rows, tmp_path / "curve.png", args)
    assert (tmp_path / "curve.png").stat().st_size > 0
