"""Gymnasium and PettingZoo adapters over :mod:`revolve_env.world`.

Importing this package registers ``revolve_env/Locomotion-v0`` (RoboGen's sensors) and
``revolve_env/Locomotion-v1`` (the sensors, then hinge angles and velocities) with Gymnasium.
"""

import gymnasium

from revolve_env.envs.locomotion import LocomotionEnv
from revolve_env.envs.population import PopulationEnv, population_env

__all__ = ["LOCOMOTION_ID", "LOCOMOTION_V1_ID", "LocomotionEnv", "PopulationEnv", "population_env"]

LOCOMOTION_ID = "revolve_env/Locomotion-v0"
"""Gymnasium id of :class:`LocomotionEnv` observing RoboGen's sensors only."""
LOCOMOTION_V1_ID = "revolve_env/Locomotion-v1"
"""Gymnasium id of :class:`LocomotionEnv` with ``proprioception=True``."""

# No max_episode_steps: the env truncates itself at insertion_time + evaluation_time, which are
# keyword arguments (a fixed step limit would be wrong for any other timing).
if LOCOMOTION_ID not in gymnasium.registry:
    gymnasium.register(id=LOCOMOTION_ID, entry_point="revolve_env.envs.locomotion:LocomotionEnv")
if LOCOMOTION_V1_ID not in gymnasium.registry:
    gymnasium.register(id=LOCOMOTION_V1_ID, entry_point="revolve_env.envs.locomotion:LocomotionEnv",
                       kwargs={"proprioception": True})
