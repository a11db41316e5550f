"""RLlib's route: PopulationMultiAgentEnv with births and deaths, and PPO with one shared policy.

Skipped when RLlib cannot be imported (the ``rllib`` extra is not installed).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

pytest.importorskip("ray.rllib", reason="needs RLlib (the rllib extra)")

from revolve_env.body.examples import gecko, snake, spider  # noqa: E402
from revolve_env.envs.checks import BirthsAndDeaths  # noqa: E402
from revolve_env.envs.rllib import INFO_KEYS, PopulationMultiAgentEnv  # noqa: E402

# Births every 4 steps (agent-driven, so RLlib sees them), the oldest robot removed every 6.
LIFE = BirthsAndDeaths(birth_every=4, death_every=6,
                       newborns=((snake(3), "agent"), (spider(), "agent")))


def _config(**kwargs: Any) -> dict[str, Any]:
    return {"initial_robots": [{"robot": gecko(), "controlled_by": "agent"}, snake(2)],
            "lifecycle": LIFE, "max_births": 12, "birth_radius": 3.0, "insertion_time": 0.05,
            **kwargs}


def test_it_steps_through_a_birth_and_a_death_with_every_space_declared() -> None:
    # Rewards every control period (at the default 5 Hz pose rate only every 12th step pays).
    env = PopulationMultiAgentEnv(_config(max_cycles=14, task={"name": "locomotion",
                                                               "pose_rate": "every-period"}))
    # Every possible agent is declared before any birth: RLlib's stock ParallelPettingZooEnv
    # knows only reset's agents and fails at the first birth.
    assert set(env.observation_spaces) == set(env.action_spaces) == {
        f"robot_{k}" for k in range(12)}
    obs, infos = env.reset(seed=0)
    assert list(obs) == env.agents == ["robot_0"]  # the brain-driven snake is no RLlib agent
    assert set(infos["robot_0"]) == set(INFO_KEYS)
    seen, dead = set(obs), set()
    rng = np.random.default_rng(0)
    for k in range(1, 15):
        actions = {a: rng.uniform(-1, 1, env.action_spaces[a].shape).astype(np.float32)
                   for a in env.agents}
        obs, rewards, terms, truncs, infos = env.step(actions)
        assert not set(obs) & dead  # a dead agent never comes back
        for a, o in obs.items():
            assert env.observation_spaces[a].contains(o) and np.isfinite(rewards[a])
        dead |= {a for a in obs if terms[a] or truncs[a]}
        seen |= set(obs)
        assert truncs["__all__"] == (k == 14) and not terms["__all__"]
    assert {"robot_2", "robot_3", "robot_4"} <= seen  # born at steps 4, 8, 12
    assert "robot_0" in dead  # removed at step 6 (robot_1, the snake, is removed at 12)
    assert env.agents == []
    assert any(r != 0.0 for r in rewards.values())  # past the 0.05 s insertion
    with pytest.raises(ValueError, match="space_mode='uniform'"):
        PopulationMultiAgentEnv({"space_mode": "exact"})
    env.close()


def test_the_episode_terminates_when_no_robot_is_left() -> None:
    env = PopulationMultiAgentEnv({"initial_robots": [{"robot": gecko(),
                                                       "controlled_by": "agent"}]})
    env.reset(seed=1)
    env.env.remove_robot("robot_0")
    obs, _, terms, truncs, infos = env.step({"robot_0": np.zeros(10, np.float32)})
    assert terms == {"robot_0": True, "__all__": True} and not truncs["__all__"]
    assert infos["robot_0"]["death"] == "removed"


@pytest.mark.slow
def test_ppo_trains_one_shared_policy_while_robots_are_born_and_die() -> None:
    import ray
    from ray.rllib.algorithms.ppo import PPOConfig

    ray.init(num_cpus=1, include_dashboard=False, log_to_driver=False)
    try:
        config = (PPOConfig()
                  .environment(PopulationMultiAgentEnv, env_config=_config(max_cycles=60))
                  .env_runners(num_env_runners=0, rollout_fragment_length=60)
                  .training(train_batch_size_per_learner=240, minibatch_size=60, num_epochs=1)
                  .multi_agent(policies={"shared"},
                               policy_mapping_fn=lambda agent_id, episode, **kw: "shared")
                  .debugging(seed=0))
        algo = config.build_algo()
        weights = [algo.get_module("shared").get_state()]
        sampled: dict[str, float] = {}
        for _ in range(2):
            result = algo.train()
            sampled = result["env_runners"]["num_agent_steps_sampled_lifetime"]
            weights.append(algo.get_module("shared").get_state())
            assert np.isfinite(result["learners"]["shared"]["total_loss"])
        algo.stop()
    finally:
        ray.shutdown()
    # Robots born after reset (ids 2 and up) gave the shared policy its samples.
    assert any(int(a.split("_")[1]) >= 2 and n > 0 for a, n in sampled.items())
    assert result["env_runners"]["num_episodes"] > 0
    for before, after in zip(weights, weights[1:], strict=False):
        changed = [not np.array_equal(np.asarray(before[k]), np.asarray(after[k]))
                   for k in before]
        assert any(changed)  # each iteration moved the shared policy
