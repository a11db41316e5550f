"""Infancy learning with stable-baselines3: PPO modulates one robot's own gait.

Run from the repository root: ``python examples/infancy_ppo.py`` (needs ``pip install .[learn]``).
"""

import numpy as np

import revolve_env
from evolution.learning import SB3Learner, TrainingCenter

# With action="modulate" the robot's network (its CPG) keeps running and the policy scales and
# offsets its outputs, so the zero action is the inborn gait and training starts from it.
# A tiny budget so that it runs in seconds: 256 PPO steps of 1/60 s plus the learner's two
# evaluations of 2.5 s (inborn and trained), which the budget pays for too. For real use raise
# BUDGET (thousands of simulated seconds), n_steps, n_envs, and use vec_env="subproc".
learner = SB3Learner(
    "PPO",
    action="modulate",
    n_envs=1,
    vec_env="dummy",        # all envs in this process; "subproc": one process per env
    insertion=0.5,          # seconds of settling in each training episode
    seconds=2.0,            # scored seconds of each training episode (and the fitness window)
    algorithm_kwargs={"n_steps": 128, "batch_size": 64, "n_epochs": 2},
)
BUDGET = 256 / 60 + 2 * (0.5 + 2.0)  # simulated seconds: 256 env steps + two evaluations

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
# an agent-controlled robot of the population env (or of Locomotion-v0 with controller="agent").
agent = result.policy
env = revolve_env.population_env(max_births=1, insertion_time=0.5,
                                 control_period=learner.control_period)  # as in training
observations, infos = env.reset(seed=0, options={"robots": [
    {"robot": robot, "controlled_by": "agent"}]})
agent.reset()
for _ in range(round(2.5 / env.config.control_period)):
    actions = {a: agent.act(observations[a]).astype(np.float32) for a in env.agents}
    observations, rewards, terminations, truncations, infos = env.step(actions)
print(f"policy in the population env: fitness {infos['robot_0']['fitness']:.3f} m")
env.close()
