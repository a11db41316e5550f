"""Evaluate an example robot on both physics engines, directly and through Gymnasium.

Run from the repository root: ``python examples/evaluate_robot.py``.
"""

import gymnasium as gym
import numpy as np

import revolve_env

# Short times so the example finishes in seconds; the paper evaluates for 12 s after a 3 s
# insertion (raise SECONDS to 12.0 and INSERTION to 3.0 for real use).
SECONDS = 2.0
INSERTION = 0.5

spider = revolve_env.example("spider")  # also: gecko, snake, sensor_crawler, bar_walker

# 1. One call: the robot's own neural network drives it in a fresh world.
for engine in revolve_env.ENGINES:  # ("pybullet", "mujoco"); MuJoCo is the default
    result = revolve_env.evaluate(spider, seconds=SECONDS, insertion=INSERTION, seed=0,
                                  engine=engine)
    print(f"{engine}: fitness {result.fitness:.3f} m "
          f"(path v = {result.v:.3f} m, displacement s = {result.s:.3f} m, "
          f"{len(result.trajectory)} trajectory rows)")

# 2. The same robot as a Gymnasium env. With controller="brain" the robot's own network acts
# and the agent's action is ignored; with the default controller="agent" your actions are the
# hinge targets in [-1, 1]. The reward of a step is the fitness gained, so the return is the
# fitness at the end of the episode.
env = gym.make("revolve_env/Locomotion-v1", robot=spider, insertion_time=INSERTION,
               evaluation_time=SECONDS, engine="mujoco")
obs, info = env.reset(seed=0)
rng = np.random.default_rng(0)
episode_return = 0.0
terminated = truncated = False
while not (terminated or truncated):
    action = rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32)  # a random policy
    obs, reward, terminated, truncated, info = env.step(action)
    episode_return += float(reward)
env.close()
print(f"gym (mujoco, random actions): return {episode_return:.3f} m, "
      f"info fitness {info['fitness']:.3f} m")
