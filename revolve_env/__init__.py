"""revolve-env: online and offline evolution of physically constructible modular robots.

Importing the package registers the single-robot Gymnasium envs ``revolve_env/Locomotion-v0``
(``gymnasium.make("revolve_env/Locomotion-v0", robot=...)``) and ``-v1`` (with proprioception).
The physics engine (pybullet or MuJoCo, chosen by ``engine=`` / ``WorldConfig.engine``) is
imported only when a world is made (``evaluate``, ``population_env``, the envs), so the pure
layers (``revolve_env.body``, ``evolution``) never load it.
"""

from __future__ import annotations

import importlib
from typing import Any

import gymnasium

from revolve_env.body import (
    EXAMPLES,
    Activation,
    Connection,
    Layer,
    Limits,
    Neuron,
    Node,
    PartType,
    Robot,
    RobotError,
    example,
    from_json,
    load,
    save,
    to_json,
    validate,
)
from revolve_env.conditions import IDEAL, EvaluationConditions

__version__ = "0.1.0"

LOCOMOTION_ID = "revolve_env/Locomotion-v0"

if LOCOMOTION_ID not in gymnasium.registry:
    # A string entry point: registering does not import pybullet. The env truncates itself at
    # insertion_time + evaluation_time (keyword arguments), so no fixed max_episode_steps.
    gymnasium.register(id=LOCOMOTION_ID, entry_point="revolve_env.envs.locomotion:LocomotionEnv")
if "revolve_env/Locomotion-v1" not in gymnasium.registry:  # v0 with proprioception
    gymnasium.register(id="revolve_env/Locomotion-v1",
                       entry_point="revolve_env.envs.locomotion:LocomotionEnv",
                       kwargs={"proprioception": True})

# Names served lazily (PEP 562) because they import the physics engine.
_LAZY = {
    "evaluate": ("revolve_env.evaluation", "evaluate"),
    "evaluate_many": ("revolve_env.evaluation", "evaluate_many"),
    "EvaluationResult": ("revolve_env.evaluation", "EvaluationResult"),
    "World": ("revolve_env.world", "World"),
    "ENGINES": ("revolve_env.world", "ENGINES"),
    "require_engine": ("revolve_env.world", "require_engine"),
    "WorldConfig": ("revolve_env.world", "WorldConfig"),
    "LocomotionEnv": ("revolve_env.envs.locomotion", "LocomotionEnv"),
    "PopulationEnv": ("revolve_env.envs.population", "PopulationEnv"),
    "population_env": ("revolve_env.envs.population", "population_env"),
    "BatchController": ("revolve_env.brain", "BatchController"),
    # scipy (the rugged terrain's blur) is loaded only when terrains are used
    "TERRAINS": ("revolve_env.terrain", "TERRAINS"),
    "TerrainError": ("revolve_env.terrain", "TerrainError"),
    "make_terrain": ("revolve_env.terrain", "make_terrain"),
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        module, attr = _LAZY[name]
        return getattr(importlib.import_module(module), attr)
    raise AttributeError(f"module 'revolve_env' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(list(globals()) + list(_LAZY))


__all__ = [
    "ENGINES",
    "EXAMPLES",
    "IDEAL",
    "LOCOMOTION_ID",
    "Activation",
    "BatchController",
    "Connection",
    "EvaluationConditions",
    "EvaluationResult",
    "Layer",
    "Limits",
    "LocomotionEnv",
    "Neuron",
    "Node",
    "PartType",
    "PopulationEnv",
    "Robot",
    "RobotError",
    "TERRAINS",
    "TerrainError",
    "require_engine",
    "World",
    "WorldConfig",
    "evaluate",
    "evaluate_many",
    "example",
    "from_json",
    "load",
    "make_terrain",
    "population_env",
    "save",
    "to_json",
    "validate",
]
