"""The physics world: the only package that imports a physics engine.

Public interface (engine-neutral: NumPy arrays and plain numbers in and out):

* :class:`WorldConfig`: engine, timestep, control period, gravity, friction, light, servo settings.
* :class:`World`: add/remove robots, set hinge targets, step, read sensors, core poses,
  blow-up reasons, render. The rules (servo law, sensors, blow-ups) live in the world; the
  engine is a backend behind :class:`~revolve_env.world.backend.PhysicsBackend`, chosen by
  ``WorldConfig.engine`` (one of :data:`ENGINES`: ``"pybullet"``, ``"mujoco"``).
* :func:`build_model`: the engine-neutral physical model (links, masses, sensors) of a robot.
"""

from revolve_env.world.backend import ENGINES, EngineUnavailableError, require_engine
from revolve_env.world.config import PHYSICS_REVISIONS, WorldConfig
from revolve_env.world.model import RobotModel, build_model
from revolve_env.world.world import World

__all__ = ["ENGINES", "PHYSICS_REVISIONS", "EngineUnavailableError", "RobotModel", "World",
           "WorldConfig", "build_model", "require_engine"]
