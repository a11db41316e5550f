"""Gymnasium and PettingZoo adapters over :mod:`revolve_env.world`.

Importing ``revolve_env`` registers ``revolve_env/Locomotion-v1`` (the sensors, then hinge angles
and velocities) and ``revolve_env/Locomotion-v0`` (RoboGen's sensors) with Gymnasium
(:mod:`revolve_env.registration`).
"""

from revolve_env.envs.locomotion import LocomotionEnv
from revolve_env.envs.population import PopulationEnv, PopulationOptions, population_env
from revolve_env.registration import LOCOMOTION_ID, LOCOMOTION_V1_ID

__all__ = ["LOCOMOTION_ID", "LOCOMOTION_V1_ID", "LocomotionEnv", "PopulationEnv",
           "PopulationOptions", "population_env"]
