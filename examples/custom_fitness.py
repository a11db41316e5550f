"""A custom fitness from the core's trajectory, compared with the paper's ``f = v + 5 s``.

Run from the repository root: ``python examples/custom_fitness.py``.
"""

import numpy as np

import revolve_env
from revolve_env.fitness import fitness_terms

# Short evaluations so it runs in seconds; the paper uses 3 s of insertion and 12 s of fitness
# window (raise INSERTION and SECONDS for real use).
INSERTION = 0.5
SECONDS = 3.0


def forward_distance(trajectory: np.ndarray) -> float:
    """Distance travelled along +x (metres): rewards walking one way, not just moving."""
    return float(trajectory[-1, 0] - trajectory[0, 0])


def straightness(trajectory: np.ndarray) -> float:
    """Displacement over path length, in [0, 1]: 1 for a straight line."""
    terms = fitness_terms(trajectory)  # v and s of the default fitness, from the same trajectory
    return terms.s / terms.v if terms.v > 0 else 0.0


print(f"{'robot':<16}{'f = v + 5 s':>12}{'+x distance':>13}{'straightness':>14}{'v + 10 s':>10}")
scores = {}
for name in revolve_env.EXAMPLES:
    result = revolve_env.evaluate(revolve_env.example(name), seconds=SECONDS, insertion=INSERTION)
    # trajectory: the core's (x, y, z) at every control period of the fitness window, metres.
    path = result.trajectory
    # The default fitness is 0 after a blow-up; do the same.
    custom = 0.0 if result.blow_up is not None else forward_distance(path)
    heavier_s = fitness_terms(path, s_weight=10.0).fitness  # the paper's formula, reweighted
    scores[name] = (result.fitness, custom)
    print(f"{name:<16}{result.fitness:>12.3f}{custom:>13.3f}{straightness(path):>14.2f}"
          f"{heavier_s:>10.3f}")

by_default = sorted(scores, key=lambda n: scores[n][0], reverse=True)
by_custom = sorted(scores, key=lambda n: scores[n][1], reverse=True)
print(f"ranking by f = v + 5 s:  {', '.join(by_default)}")
print(f"ranking by +x distance:  {', '.join(by_custom)}")
