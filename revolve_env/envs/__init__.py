"""Gymnasium (and later PettingZoo) adapters over :mod:`revolve_env.world`.

Importing this package registers ``revolve_env/Locomotion-v0`` with Gymnasium.
"""

import gymnasium

from revolve_env.envs.locomotion import LocomotionEnv

__all__ = ["LOCOMOTION_ID", "LocomotionEnv"]

LOCOMOTION_ID = "revolve_env/Locomotion-v0"
"""Gymnasium id of :class:`LocomotionEnv`."""

if LOCOMOTION_ID not in gymnasium.registry:
    # No max_episode_steps: the env truncates itself at insertion_time + evaluation_time, which
    # are keyword arguments (a fixed step limit would be wrong for any other timing).
    gymnasium.register(id=LOCOMOTION_ID, entry_point="revolve_env.envs.locomotion:LocomotionEnv")
from revolve_env.envs.population import PopulationEnv, population_env  # noqa: E402
