"""Infancy learning: CMA-ES tunes one robot's controller in the Training Center.

Run from the repository root: ``python examples/infancy_cmaes.py`` (needs ``pip install .[learn]``).
"""

import numpy as np

import revolve_env
from evolution.learning import CandidateEvaluation, CMAESLearner, TrainingCenter

# Tiny numbers so that it runs in seconds. For real use keep CandidateEvaluation's defaults
# (1 s + 6 s per candidate), raise BUDGET (the learning configs use about 120 simulated seconds)
# and workers (processes evaluating candidates at once).
evaluation = CandidateEvaluation(insertion=0.5, seconds=2.0, workers=1, engine="pybullet")
BUDGET = 25.0  # simulated seconds of learning: 10 candidates of 2.5 s (inborn + 2 generations)

center = TrainingCenter(
    CMAESLearner(sigma0=0.15, popsize=4, evaluation=evaluation),
    budget=BUDGET,
    inheritance="lamarckian",  # children inherit the learned weights; "darwinian": the inborn ones
)

robot = revolve_env.example("bar_walker")  # a slow walker: room to learn
outcome = center.infancy(robot, np.random.default_rng(0))  # never raises for a failed learner
if outcome.result is None:
    raise SystemExit(f"learning failed, the inborn controller is kept: {outcome.failure}")
result = outcome.result
print(f"{result.evaluations} evaluations, {result.sim_seconds:.1f} simulated s of learning")
print(f"learning curve (best so far, m): {np.round(result.best_so_far, 3).tolist()}")
print(f"inborn fitness {result.inborn_fitness:.3f} m, learned fitness {result.best_fitness:.3f} m "
      f"(improvement {result.improvement:+.3f} m)")
print(f"children inherit the learned controller: {outcome.genome is outcome.robot}")

# Check the learned controller outside the learner, in a fresh evaluation of the same length.
for name, candidate in (("inborn", robot), ("learned", outcome.robot)):
    check = revolve_env.evaluate(candidate, seconds=evaluation.seconds,
                                 insertion=evaluation.insertion, engine=evaluation.engine)
    print(f"re-evaluated {name}: {check.fitness:.3f} m")
