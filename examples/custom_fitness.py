"""A fitness of your own: a task class, used by evaluate() and by the Gymnasium env.

A task scores every robot's fitness window at once, from arrays (``revolve_env.tasks``): here,
the distance walked along +x, whichever way the robot started. The same class is the reward of
``gymnasium.make("revolve_env/Locomotion-v1", task=...)`` (the reward of a step is the task's
fitness gain), ``population_env(task=...)`` and the learners' ``CandidateEvaluation(task=...)``;
``ForwardDistance().to_dict()`` is plain data, and ``make_task`` makes it again from its dotted
path (``"your_package.your_module:ForwardDistance"``) when it lives in an importable module.

Run from the repository root: ``python examples/custom_fitness.py``.
"""

from dataclasses import dataclass

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

import revolve_env
from revolve_env.fitness import Window
from revolve_env.tasks import BaseTask, DirectedLocomotion


@dataclass(frozen=True)
class ForwardDistance(BaseTask):
    """Metres walked along +x over the window (negative when walking back), times ``weight``."""

    weight: float = 1.0

    def fitness(self, window: Window) -> NDArray[np.float64]:
        # One entry per robot: their window's first and last core positions, (n, 2) each.
        forward: NDArray[np.float64] = self.weight * (window.end[:, 0] - window.start[:, 0])
        return forward


# Short evaluations so it runs in seconds; the paper uses 3 s of insertion and 12 s of fitness
# window (raise INSERTION and SECONDS for real use).
INSERTION = 0.5
SECONDS = 3.0

print(f"{'robot':<16}{'f = v + 5 s':>12}{'+x distance':>13}{'heading 90':>12}")
scores = {}
for name in revolve_env.EXAMPLES:
    robot = revolve_env.example(name)
    paper = revolve_env.evaluate(robot, seconds=SECONDS, insertion=INSERTION)  # the default
    mine = revolve_env.evaluate(robot, seconds=SECONDS, insertion=INSERTION,
                                task=ForwardDistance())
    # A shipped task with a parameter, by name and table (as a config would store it).
    north = revolve_env.evaluate(robot, seconds=SECONDS, insertion=INSERTION,
                                 task={"name": "directed-locomotion", "heading": np.pi / 2})
    scores[name] = (paper.fitness, mine.fitness)
    print(f"{name:<16}{paper.fitness:>12.3f}{mine.fitness:>13.3f}{north.fitness:>12.3f}")

by_default = sorted(scores, key=lambda n: scores[n][0], reverse=True)
by_custom = sorted(scores, key=lambda n: scores[n][1], reverse=True)
print(f"ranking by f = v + 5 s:  {', '.join(by_default)}")
print(f"ranking by +x distance:  {', '.join(by_custom)}")

# The same task as the reward of the single-robot env: an episode's return is its fitness.
env = gym.make("revolve_env/Locomotion-v1", robot=revolve_env.example("spider"),
               controller="brain", insertion_time=INSERTION, evaluation_time=SECONDS,
               task=ForwardDistance())
env.reset(seed=0)
episode_return, done = 0.0, False
while not done:
    _, reward, terminated, truncated, info = env.step(np.zeros(env.action_space.shape))
    episode_return += float(reward)
    done = terminated or truncated
env.close()
print(f"spider in Locomotion-v1 with ForwardDistance: return {episode_return:.3f} m, "
      f"fitness {info['fitness']:.3f} m (the same)")
print(f"stored as {ForwardDistance(weight=2.0).to_dict()}; a shipped one as "
      f"{DirectedLocomotion(heading=1.0).to_dict()}")
