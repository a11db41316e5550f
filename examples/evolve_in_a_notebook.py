# %% [markdown]
# # Evolve robots in a notebook
#
# The evolution loop is an object you step: `Evolution(config).step()` runs one generation
# offline (one commit point online) and you read the population and its fitness after each
# step. Nothing is written to disk: a results database is only one observer you may attach
# (`evolution.run(config, out_dir)` and `revolve run` are this loop plus that observer).
#
# Written as notebook cells (`# %%`): open it in Jupyter or VS Code, or run it as a script:
# `python examples/evolve_in_a_notebook.py` from the repository root.

# %%
import os

import numpy as np

from evolution.evaluation import evaluate_task
from evolution.experiments import Evolution, Observer, Step, preset

files_before = set(os.listdir("."))

# Scenario 1's rules (offline, mu + lambda, tournament parents), shrunk to a few seconds of work.
config = preset(
    "scenario1",
    population_size=6,
    offspring_size=6,
    births=24,            # 6 random robots, then 3 generations of 6 children
    insertion=0.5,        # seconds of settling before each evaluation
    evaluation_time=2.0,  # seconds of the fitness window f = v + 5 s
    fertile_age=2.5,      # offline robots are mature once evaluated
    diversity_interval=6,
    seed=1,
    workers=1,            # evaluations in this process; 0 uses every core
)

# %% [markdown]
# ## Step it and read the population after each step

# %%
with Evolution(config) as evolution:
    while not evolution.done:
        step = evolution.step()
        fitness = evolution.fitness  # metres, in population order
        print(f"generation {step.generation}: {step.births} births, "
              f"best {np.nanmax(fitness):.3f} m, mean {np.nanmean(fitness):.3f} m, "
              f"population {[m.robot_id for m in evolution.population]}")
    best = max(evolution.population, key=lambda m: m.fitness or -np.inf)
    print(f"best robot {best.robot_id}: {best.fitness:.3f} m, "
          f"{len(list(best.robot.walk()))} parts")

# %% [markdown]
# ## An observer of your own
#
# Observers are told when the loop starts, when a robot is born, after every step (with all its
# records) and when it stops. Here: the diversity measured at each step.


# %%
class Diversity(Observer):
    """Keeps the population diversity measured at each step."""

    def __init__(self) -> None:
        self.values: list[tuple[int, float]] = []

    def stepped(self, evolution: Evolution, step: Step) -> None:
        if step.records.diversity is not None:
            self.values.append((step.births, step.records.diversity))


diversity = Diversity()
Evolution(config, observers=[diversity]).run()
print("diversity over births:", ", ".join(f"{b}: {d:.2f}" for b, d in diversity.values))

# %% [markdown]
# ## Evaluate the robots yourself: ask and tell
#
# `ask()` gives the evaluation tasks of the robots the next step needs; `tell()` takes their
# outcomes (here the standard evaluation, `evaluate_task`; any function of the task would do).

# %%
with Evolution(config) as evolution:
    while not evolution.done:
        tasks = evolution.ask()
        told = evolution.tell([evaluate_task(task) for task in tasks])
        if told is not None:
            print(f"ask/tell: {told.births} births, best {np.nanmax(evolution.fitness):.3f} m")

# %% [markdown]
# ## Online: one shared world, stepped from birth to birth
#
# Scenario 3's rules: every robot lives in one world (the population env, built when the loop
# is made), a robot is conceived every `conception_interval` seconds; a step runs to the next
# commit point (every `checkpoint_interval` births: here each birth).

# %%
online = preset("scenario3", population_size=4, min_alive=3, max_alive=6, births=8,
                insertion=0.5, evaluation_time=1.5, fertile_age=2.0, conception_interval=2.0,
                diversity_interval=0, seed=1)
with Evolution(online) as evolution:
    while not evolution.done:
        step = evolution.step()
        print(f"t = {step.sim_time:.1f} s: {step.births} births, "
              f"{len(evolution.population)} alive, fitness {np.round(evolution.fitness, 3)}")

# %%
print(f"files written: {len(set(os.listdir('.')) - files_before)}")
