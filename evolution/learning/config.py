"""Learning settings in experiment configs: the ``[learning]`` table.

An experiment config with learning is an ordinary experiment TOML (see
:class:`~evolution.experiments.loop.config.ExperimentConfig`) plus a ``[learning]`` table::

    [learning]
    learner     = "cma-es"       # "cma-es", "random-search" or "sb3"
    budget      = 90.0           # simulated seconds of learning per infant
    inheritance = "lamarckian"   # or "darwinian"
    sigma       = 0.15           # cma-es: initial step; random-search: perturbation
                                 # (both a fraction of each parameter's range)
    popsize     = 8              # cma-es: candidates per generation; random-search: batch size
    insertion   = 1.0            # settling time of each candidate evaluation, seconds
    seconds     = 6.0            # fitness window of each candidate evaluation, seconds
    workers     = 1              # processes evaluating candidates (1: inside the robot's worker)
    conditions  = { heading = 0.0 }   # optional: the conditions infants learn under; default: the
                                 # experiment's [evaluation] table (they learn as they will live)
    # sb3 only: algorithm = "PPO", action = "modulate", n_envs = 2, vec_env = "subproc",
    #           control_period = 0.0166667, algorithm_kwargs = { n_steps = 256 },
    #           normalize = true (VecNormalize of observations and rewards),
    #           proprioception = false (true: the policy also observes hinge angles and speeds;
    #           the online world then observes them for every agent-controlled robot),
    #           settings = "benchmark" (PPO starts from revolve_env.rl.ppo_settings, under
    #           algorithm_kwargs; "sb3-defaults": from SB3's own defaults)

Results stored before the learner trained on normalised envs with the benchmark's settings (schema
version 5 and older) had neither ``normalize`` nor ``settings``: the store's upgrade writes
``normalize = false`` and ``settings = "sb3-defaults"`` into their ``sb3`` tables
(:data:`~evolution.experiments.store.schema.SB3_OF_OLD_RUNS`), with which the learner trains
exactly as it did then, so that such a run resumes to the numbers it would have had uninterrupted.

A ``budget`` too small for one learning step is refused here (a ``ValueError``; in an experiment
config a one-line ``ConfigError``): CMA-ES needs the inborn evaluation and one generation
(``(1 + popsize) * (insertion + seconds)``), random search the inborn evaluation and one
candidate, SB3 its two evaluations and one rollout (``n_steps * n_envs`` steps; off-policy:
``learning_starts`` and one ``train_freq``). Each learner's ``min_budget`` gives the figure.
With ``learner = "sb3"`` the run saves every trained policy in ``<results>/policies/`` and the
policy drives the robot (see :mod:`evolution.experiments.loop.evolve`).

:class:`~evolution.experiments.loop.config.ExperimentConfig` keeps the table
(``config.learning``): it is stored with the results, :func:`evolution.run` builds the Training
Center from it, and :func:`evolution.resume` (``revolve resume``) rebuilds the same one. ``revolve
run FILE.toml`` and the shipped ``scenario1_learning`` / ``scenario3_learning`` configs go this way.
:meth:`ExperimentConfig.training_center` gives the center of a config (for inspection, or to
pass as ``infancy=``: the same center is accepted); :func:`training_center_from_dict` builds the
center from the table alone.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from evolution.learning.base import Learner, TrainingCenter
from evolution.learning.params import CandidateEvaluation, CMAESLearner, RandomSearchLearner
from evolution.learning.sb3 import SB3Learner
from revolve_env.conditions import IDEAL, EvaluationConditions
from revolve_env.setting import DEFAULT_ENGINE
from revolve_env.tasks import Locomotion, Task
from revolve_env.terrain import Flat, Terrain

__all__ = ["LEARNERS", "policies_observe_hinges", "training_center_from_dict"]

LEARNERS = ("cma-es", "random-search", "sb3")
"""Names accepted by ``learner``."""

_COMMON = {"learner", "budget", "inheritance", "insertion", "seconds", "conditions"}
_KEYS = {
    "cma-es": _COMMON | {"sigma", "popsize", "workers"},
    "random-search": _COMMON | {"sigma", "popsize", "workers"},
    "sb3": _COMMON | {"algorithm", "policy", "action", "n_envs", "vec_env", "control_period",
                      "algorithm_kwargs", "normalize", "proprioception", "settings"},
}


def policies_observe_hinges(data: Mapping[str, Any] | None) -> bool:
    """Whether the policies a ``[learning]`` table trains observe hinge angles and velocities.

    The world that hosts them must observe them too (the online engine's population env).
    """
    return bool(data is not None and data.get("learner") == "sb3"
                and data.get("proprioception", False) is True)


def training_center_from_dict(data: Mapping[str, Any], engine: str = DEFAULT_ENGINE,
                              conditions: EvaluationConditions = IDEAL,
                              task: Task | None = None,
                              terrain: Terrain | None = None) -> TrainingCenter:
    """The Training Center a ``[learning]`` table describes (keys: module docstring).

    ``engine`` is the physics engine the learner simulates in (an experiment's
    ``world.engine``: infants learn in the engine their run lives in); ``conditions`` the
    conditions of its evaluations and episodes (an experiment's ``[evaluation]`` table: infants
    learn under the conditions they are evaluated and live in), unless the table has its own
    ``conditions`` (runs stored before conditions existed learned under
    :data:`~revolve_env.conditions.IDEAL`: the store's upgrade writes that there); ``task``
    what the learner scores (an experiment's task: infants learn what they are selected for);
    ``terrain`` the ground it learns on (an experiment's ``world.terrain``; None: the plane).

    Raises:
        ValueError: unknown learner or key (named, with the known ones), a missing budget, or a
            value out of range.
    """
    data = dict(data)
    name = data.get("learner")
    if name not in LEARNERS:
        raise ValueError(f"learning.learner must be one of {', '.join(LEARNERS)}, got {name!r}")
    unknown = sorted(set(data) - _KEYS[name])
    if unknown:
        raise ValueError(f"unknown learning key(s) for {name}: {', '.join(unknown)}; known: "
                         f"{', '.join(sorted(_KEYS[name]))}")
    if "budget" not in data:
        raise ValueError("learning.budget (simulated seconds per infant) is required")
    if "conditions" in data:
        table = data["conditions"]
        if not isinstance(table, Mapping):
            raise ValueError(f"learning.conditions must be a table, got {table!r}")
        conditions = EvaluationConditions.from_dict(table)
    # Any, not float: spread as keyword arguments beside arguments of other types.
    timing: dict[str, Any] = {k: float(data[k]) for k in ("insertion", "seconds") if k in data}
    scored = task if task is not None else Locomotion()
    ground = terrain if terrain is not None else Flat()
    learner: Learner
    if name == "sb3":
        kwargs = {k: data[k] for k in ("algorithm", "policy", "action", "n_envs", "vec_env",
                                       "control_period", "normalize", "proprioception",
                                       "settings")
                  if k in data}
        learner = SB3Learner(**kwargs, **timing, engine=engine, conditions=conditions,
                             algorithm_kwargs=dict(data.get("algorithm_kwargs", {})), task=scored,
                             terrain=ground)
    else:
        evaluation = CandidateEvaluation(**timing, workers=int(data.get("workers", 1)),
                                         engine=engine, conditions=conditions, task=scored,
                                         terrain=ground)
        if name == "cma-es":
            learner = CMAESLearner(sigma0=float(data.get("sigma", 0.15)),
                                   popsize=data.get("popsize", 8), evaluation=evaluation)
        else:
            learner = RandomSearchLearner(sigma=float(data.get("sigma", 0.15)),
                                          batch_size=int(data.get("popsize", 8)),
                                          evaluation=evaluation)
    return TrainingCenter(learner, float(data["budget"]), data.get("inheritance", "darwinian"))
