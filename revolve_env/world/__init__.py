"""The physics world: the only package that imports a physics engine.

Public interface (engine-neutral: NumPy arrays and plain numbers in and out):

* :class:`WorldConfig`: engine, timestep, control period, gravity, friction, light, servo settings.
* :class:`World`: add/remove robots, set hinge targets, step, read sensors, core poses,
  blow-up reasons, render. The rules (servo law, sensors, blow-ups) live in the world; the
  engine is a backend behind :class:`~revolve_env.world.backend.PhysicsBackend`, chosen by
  ``WorldConfig.engine`` (one of :data:`ENGINES`: ``"pybullet"``, ``"mujoco"``; by default
  :data:`DEFAULT_ENGINE`, MuJoCo).
* :func:`engine`: an engine's record in the one table of engines
  (:mod:`revolve_env.world.engines`): its package, physics revision and capabilities.
* :func:`build_model`: the engine-neutral physical model (links, masses, sensors) of a robot.
"""

from revolve_env.world.config import DEFAULT_ENGINE, WorldConfig
from revolve_env.world.engines import (
    ENGINES,
    PHYSICS_REVISIONS,
    Engine,
    EngineUnavailableError,
    engine,
    require_engine,
    with_engine,
)
from revolve_env.world.model import RobotModel, build_model
from revolve_env.world.world import World

__all__ = ["DEFAULT_ENGINE", "ENGINES", "PHYSICS_REVISIONS", "Engine", "EngineUnavailableError",
           "RobotModel", "World", "WorldConfig", "build_model", "engine", "require_engine",
           "with_engine"]
