"""revolve-env: online and offline evolution of physically constructible modular robots.

Importing the package registers the single-robot Gymnasium envs ``revolve_env/Locomotion-v1``
(``gymnasium.make("revolve_env/Locomotion-v1")``: the spider; ``robot=`` a Robot, an example name
or a JSON file) and ``-v0`` (without proprioception, kept for older code); see
:mod:`revolve_env.registration`.
The physics engine (MuJoCo, the default, or pybullet, chosen by ``engine=`` / ``setting=`` /
``WorldConfig.engine``) is
imported only when a world is made (``evaluate``, ``population_env``, the envs), so the pure
layers (``revolve_env.body``, ``evolution``) never load it.
"""

from __future__ import annotations

import importlib
from typing import Any

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
    resolve_robot,
    save,
    to_json,
    validate,
)
from revolve_env.conditions import IDEAL, EvaluationConditions
from revolve_env.registration import LOCOMOTION_ID, LOCOMOTION_V1_ID, register_envs

__version__ = "0.1.0"

register_envs()

# Names served lazily (PEP 562) because they import the physics engine.
_LAZY = {
    "evaluate": ("revolve_env.evaluation", "evaluate"),
    "evaluate_many": ("revolve_env.evaluation", "evaluate_many"),
    "EvaluationResult": ("revolve_env.evaluation", "EvaluationResult"),
    "Setting": ("revolve_env.setting", "Setting"),
    "World": ("revolve_env.world", "World"),
    "ENGINES": ("revolve_env.world", "ENGINES"),
    "DEFAULT_ENGINE": ("revolve_env.world", "DEFAULT_ENGINE"),
    "PHYSICS_REVISIONS": ("revolve_env.world", "PHYSICS_REVISIONS"),
    "require_engine": ("revolve_env.world", "require_engine"),
    "engine": ("revolve_env.world", "engine"),
    "with_engine": ("revolve_env.world", "with_engine"),
    "WorldConfig": ("revolve_env.world", "WorldConfig"),
    "LocomotionEnv": ("revolve_env.envs.locomotion", "LocomotionEnv"),
    "PopulationEnv": ("revolve_env.envs.population", "PopulationEnv"),
    "PopulationOptions": ("revolve_env.envs.population", "PopulationOptions"),
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
    "DEFAULT_ENGINE",
    "ENGINES",
    "PHYSICS_REVISIONS",
    "EXAMPLES",
    "IDEAL",
    "LOCOMOTION_ID",
    "LOCOMOTION_V1_ID",
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
    "PopulationOptions",
    "Robot",
    "RobotError",
    "Setting",
    "TERRAINS",
    "TerrainError",
    "require_engine",
    "engine",
    "with_engine",
    "World",
    "WorldConfig",
    "evaluate",
    "evaluate_many",
    "example",
    "from_json",
    "load",
    "make_terrain",
    "population_env",
    "resolve_robot",
    "save",
    "to_json",
    "validate",
]
