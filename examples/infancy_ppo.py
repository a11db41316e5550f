"""Infancy learning with stable-baselines3: PPO modulates one robot's own gait.

Run from the repository root: ``python examples/infancy_ppo.py [ROLLOUTS]`` (needs
``pip install .[learn]``). The default, 64 PPO rollouts (32 k steps), is what it takes to end above
the inborn gait: 98 s of CPU (measured 2026-11-27 under ``nice`` on a loaded 2-core machine).
Fewer rollouts (``2``: a few seconds) show the steps without the gain.
"""

import sys

import numpy as np
import torch

import revolve_env
from evolution.learning import SB3Learner, TrainingCenter
from revolve_env.tasks import Locomotion

torch.set_num_threads(1)  # a small network: more threads only wait for each other

# With action="modulate" the robot's network (its CPG) keeps running and the policy scales and
# offsets its outputs, so the zero action is the inborn gait and training starts from it. What
# makes PPO improve on the spider's tuned gait (benchmarks/bench_rl.py): the policy sees the
# hinge angles and velocities (proprioception: the gait's phase; with the IMU alone it barely
# learns), normalised observations and rewards (the learner's default), short episodes, and
# about 30 k steps: with fewer, PPO's first updates move the gait as often down as up. The reward
# is the fitness gain at every control period (pose_rate="every-period"): at the default pose rate
# (5 Hz, the paper's) it is 0 between pose samples, 11 steps in 12, and this short training then
# barely improves on the gait (2.06 -> 2.09 m).
TASK = Locomotion(pose_rate="every-period")
learner = SB3Learner(
    "PPO",
    action="modulate",
    proprioception=True,
    n_envs=4,
    vec_env="dummy",        # all envs in this process; "subproc": one process per env
    insertion=0.5,          # seconds of settling in each training episode
    seconds=2.5,            # scored seconds of each training episode (and the fitness window)
    task=TASK,
)
ROLLOUTS = int(sys.argv[1]) if len(sys.argv) > 1 else 64
STEPS = ROLLOUTS * 512  # PPO rollouts of 128 steps in each of the 4 envs
BUDGET = STEPS / 60 + 2 * (0.5 + 2.5)  # simulated seconds: the steps and two evaluations

# The policy lives outside the genome, so an SB3 learner is Darwinian only.
center = TrainingCenter(learner, budget=BUDGET, inheritance="darwinian")
robot = revolve_env.example("spider")
outcome = center.infancy(robot, np.random.default_rng(0))
if outcome.result is None:
    raise SystemExit(f"learning failed, the inborn controller is kept: {outcome.failure}")
result = outcome.result
print(f"{result.sim_seconds:.1f} simulated s of training, {result.evaluations} training episodes")
print(f"inborn fitness {result.inborn_fitness:.3f} m, with the policy {result.best_fitness:.3f} m")

# The trained policy is a PolicyAgent: observation in, hinge targets out. It drives the robot as
# an agent-controlled robot of the population env (or of Locomotion-v1 with controller="agent"),
# which must observe the hinges as in training (proprioception=True).
agent = result.policy
env = revolve_env.population_env(max_births=1, insertion_time=0.5, fitness_window=2.5,
                                 proprioception=True, control_period=learner.control_period,
                                 reset_noise_scale=0.0, task=TASK)
# At the origin, heading 0, hinges at rest (no start noise): where the learner evaluated it, so
# the fitness is the learner's.
observations, infos = env.reset(seed=0, options={"robots": [
    {"robot": robot, "position": (0.0, 0.0), "yaw": 0.0, "controlled_by": "agent"}]})
agent.reset()
for _ in range(round(3.0 / env.config.control_period)):
    # float64 targets, as the learner's evaluation sends them (float32 would round them).
    actions = {a: agent.act(observations[a]) for a in env.agents}
    observations, rewards, terminations, truncations, infos = env.step(actions)
print(f"policy in the population env: fitness {infos['robot_0']['fitness']:.3f} m")
env.close()
