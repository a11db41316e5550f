"""The physics world: the only package that imports a physics engine (pybullet).

Public interface (engine-neutral: NumPy arrays and plain numbers in and out):

* :class:`WorldConfig`: timestep, control period, gravity, friction, light, servo settings.
* :class:`World`: add/remove robots, set hinge targets, step, read sensors, core poses,
  blow-up reasons, render.
* :func:`build_model`: the engine-neutral physical model (links, masses, sensors) of a robot.
"""

from revolve_env.world.config import WorldConfig
from revolve_env.world.model import RobotModel, build_model
from revolve_env.world.pybullet_world import World

__all__ = ["RobotModel", "World", "WorldConfig", "build_model"]
