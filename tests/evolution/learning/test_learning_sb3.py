"""The stable-baselines3 adapter: training on the infant's Gym env, and the trained policy
driving an agent-controlled robot in the population env."""

from __future__ import annotations

import pickle
import tempfile
from pathlib import Path

import numpy as np
import pytest

from evolution.learning import PolicyAgent, SB3Learner, TrainingCenter, rollout_fitness
from revolve_env.body.examples import EXAMPLES
from revolve_env.body.robot import Layer, Robot

pytest.importorskip("stable_baselines3")

DT = 1.0 / 30.0


class ZeroPolicy:
    """A policy that always answers the zero action (``predict`` as SB3 policies have it)."""

    def __init__(self, size: int) -> None:
        self.size = size

    def predict(self, obs: np.ndarray, deterministic: bool = True) -> tuple[np.ndarray, None]:
        return np.zeros(self.size, dtype=np.float32), None


def drive_in_population(agent: PolicyAgent | None, robot: Robot, insertion: float, seconds: float,
                        control_period: float) -> dict:
    """One robot at the origin of the population env for ``insertion + seconds``: driven by
    ``agent`` (agent-controlled) or by its own network (``None``). Its final info."""
    from revolve_env.envs import PopulationEnv

    steps = round((insertion + seconds) / control_period)
    env = PopulationEnv(insertion_time=insertion, fitness_window=seconds, max_cycles=steps,
                        control_period=control_period, reset_noise_scale=0.0,  # as experiments
                        proprioception=agent is not None and agent.proprioception)
    entry = {"robot": robot, "position": (0.0, 0.0), "yaw": 0.0,
             "controlled_by": "brain" if agent is None else "agent"}
    try:
        obs, _ = env.reset(seed=0, options={"robots": [entry]})
        (name,) = env.agents
        if agent is not None:
            agent.reset()
        for _ in range(steps):
            actions = {} if agent is None else {name: agent.act(obs[name])}
            obs, _, terminations, truncations, infos = env.step(actions)
        assert truncations[name] and not terminations[name]
        return infos[name]
    finally:
        env.close()


@pytest.mark.parametrize("proprioception", [False, True])
@pytest.mark.parametrize("name", ["gecko", "sensor_crawler"])
def test_zero_modulation_agent_drives_exactly_like_the_brain_in_the_population_env(
        name: str, proprioception: bool) -> None:
    robot = EXAMPLES[name]()
    n = len(robot.neurons_of(Layer.OUTPUT))
    agent = PolicyAgent(ZeroPolicy(2 * n), robot, "modulate", DT, proprioception=proprioception)
    assert agent.n_observations == len(robot.neurons_of(Layer.INPUT)) + 2 * n * proprioception
    by_brain = drive_in_population(None, robot, 0.5, 2.0, DT)
    by_agent = drive_in_population(agent, robot, 0.5, 2.0, DT)
    assert by_agent["controlled_by"] == "agent"
    assert by_agent["fitness"] > 0.1  # it walks
    assert by_agent["fitness"] == by_brain["fitness"]
    np.testing.assert_array_equal(by_agent["position"], by_brain["position"])
    # ... and the single-robot env measures the same fitness for the same agent.
    assert rollout_fitness(agent, robot, 0.5, 2.0, DT, seed=3) == by_agent["fitness"]


def test_policy_agent_refuses_mismatched_shapes() -> None:
    robot = EXAMPLES["gecko"]()
    agent = PolicyAgent(ZeroPolicy(5), robot, "targets", DT)
    with pytest.raises(ValueError, match="observation"):
        agent.act(np.zeros(3))
    with pytest.raises(ValueError, match="shape"):
        agent.act(np.zeros(6))
    with pytest.raises(ValueError, match="action"):
        PolicyAgent(ZeroPolicy(6), robot, "joints", DT)  # type: ignore[arg-type]


def test_ppo_trains_and_its_policy_drives_the_robot_in_the_population_env(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # SB3's default logger made an empty SB3-<time> folder in the temporary folder per learn().
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    robot = EXAMPLES["gecko"]()
    learner = SB3Learner("PPO", action="modulate", n_envs=2, vec_env="dummy", insertion=0.25,
                         seconds=1.0, control_period=DT,
                         algorithm_kwargs={"n_steps": 40, "batch_size": 40, "n_epochs": 2})
    # One rollout of 40 steps in each of the 2 envs, and the learner's own two evaluations of
    # 1.25 s; 79 more steps buy no second whole rollout (SB3 would round up and overspend).
    needed = 2 * 40 * DT + 2 * 1.25
    assert learner.min_budget == pytest.approx(needed)
    budget = needed + 79 * DT
    result = learner.learn(robot, budget, np.random.default_rng(0))
    assert not [p for p in tmp_path.iterdir() if p.name.startswith("SB3-")]
    # Episodes are 38 steps (1.25 s): each env finished one during 40 steps.
    assert result.evaluations == 2 == len(result.fitness)
    assert result.sim_seconds == pytest.approx(needed) and result.sim_seconds <= budget
    assert result.robot == robot  # the network is untouched; the policy is the learned part
    agent = result.policy
    assert isinstance(agent, PolicyAgent) and agent.action == "modulate"
    # It trained on normalised observations (revolve_env.rl's env) and keeps their statistics,
    # frozen, so that it sees in the population env what it saw in training.
    assert agent.normalization is not None
    assert agent.normalization.mean.shape == (len(robot.neurons_of(Layer.INPUT)),)
    assert agent.normalization.mean[2] == pytest.approx(9.81, abs=1.0)  # gravity, on average
    # The trained policy changes the gait (it is not the zero action any more).
    obs = np.zeros(len(robot.neurons_of(Layer.INPUT)))
    obs[2] = 9.81
    assert np.any(agent.policy_action(obs) != 0.0)
    # Plugged into the population env as an agent-controlled robot, it walks exactly as the
    # learner measured in the single-robot env.
    info = drive_in_population(agent, robot, 0.25, 1.0, DT)
    assert info["fitness"] == result.best_fitness
    # It survives pickling (to reach the worker process that runs the world).
    clone = pickle.loads(pickle.dumps(agent))
    assert drive_in_population(clone, robot, 0.25, 1.0, DT)["fitness"] == info["fitness"]


def test_a_proprioceptive_policy_drives_the_robot_where_it_learned(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """With proprioception the policy observes the sensors, then the hinge angles and speeds,
    in training (Locomotion-v1), in the learner's evaluation and in the population env."""
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    robot = EXAMPLES["spider"]()
    learner = SB3Learner("PPO", action="targets", n_envs=2, vec_env="dummy", insertion=0.25,
                         seconds=1.0, control_period=DT, proprioception=True,
                         algorithm_kwargs={"n_steps": 40, "batch_size": 40, "n_epochs": 2})
    result = learner.learn(robot, learner.min_budget, np.random.default_rng(1))
    agent = result.policy
    assert isinstance(agent, PolicyAgent) and agent.proprioception
    assert agent.n_observations == 6 + 2 * 8
    assert agent.normalization is not None and agent.normalization.mean.shape == (22,)
    with pytest.raises(ValueError, match=r"shape \(22,\)"):
        agent.act(np.zeros(6))  # the sensors alone are not what it observes
    info = drive_in_population(agent, robot, 0.25, 1.0, DT)
    assert info["fitness"] == result.best_fitness


def test_sb3_learners_cannot_be_lamarckian() -> None:
    learner = SB3Learner("PPO", vec_env="dummy")
    assert TrainingCenter(learner, 100.0).inheritance == "darwinian"
    with pytest.raises(ValueError, match="Lamarckian"):
        TrainingCenter(learner, 100.0, "lamarckian")


def test_sb3_budgets_count_every_simulated_second() -> None:
    """The budget pays for the learner's two evaluations and whole rollouts: too little for one
    rollout is refused (the Training Center at config time, ``learn`` too), and the training
    steps never push the total past the budget."""
    learner = SB3Learner("PPO", n_envs=2, vec_env="dummy", insertion=0.5, seconds=4.0,
                         control_period=1 / 60, algorithm_kwargs={"n_steps": 256})
    assert learner.min_budget == pytest.approx(2 * 256 / 60 + 9.0)
    # The 60 s that once bought 64 s of PPO: 51 s of training is 3060 steps, 5 whole rollouts
    # of 512; 5 * 512 / 60 + 9 = 51.67 s.
    assert learner.training_steps(60.0) == 5 * 512
    assert learner.training_steps(60.0) / 60 + 9.0 <= 60.0
    with pytest.raises(ValueError, match="too small for one learning step"):
        TrainingCenter(learner, learner.min_budget - 0.01)
    with pytest.raises(ValueError, match="one learning step needs 512"):
        learner.learn(EXAMPLES["gecko"](), 17.0, np.random.default_rng(0))
    sac = SB3Learner("SAC", n_envs=1, vec_env="dummy", insertion=0.5, seconds=4.0,
                     control_period=1 / 60, algorithm_kwargs={"learning_starts": 30})
    assert sac.min_budget == pytest.approx(31 / 60 + 9.0)
    with pytest.raises(ValueError, match="no algorithm"):
        SB3Learner("NotAnAlgorithm")
    with pytest.raises(ValueError, match="normalize must be true or false"):
        SB3Learner("PPO", normalize="yes")  # type: ignore[arg-type]
    # PPO starts from the benchmark's settings (revolve_env.rl.ppo_settings): 128 steps per env.
    assert SB3Learner("PPO", n_envs=2).min_budget == pytest.approx(2 * 128 / 60 + 9.0)


@pytest.mark.slow
def test_sac_with_direct_targets_in_subprocess_envs() -> None:
    from stable_baselines3 import SAC

    robot = EXAMPLES["snake"]()
    learner = SB3Learner(SAC, action="targets", n_envs=2, vec_env="subproc", insertion=0.25,
                         seconds=1.0, control_period=DT,
                         algorithm_kwargs={"learning_starts": 20, "batch_size": 32,
                                           "buffer_size": 1000})
    budget = 100 * DT + 2 * 1.25  # 100 training steps and the two evaluations
    result = learner.learn(robot, budget, np.random.default_rng(0))
    again = learner.learn(robot, budget, np.random.default_rng(0))
    assert result.fitness == again.fitness and result.best_fitness == again.best_fitness
    assert result.evaluations == 2 and result.policy is not None
    assert result.policy.action == "targets"
    info = drive_in_population(result.policy, robot, 0.25, 1.0, DT)
    assert info["fitness"] == result.best_fitness
