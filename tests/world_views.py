"""One robot's slice of a world's batched arrays (the world itself has only the batched API)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from revolve_env.world import World


def hinge_targets(world: World, handle: int) -> NDArray[np.float64]:
    """The position targets of one robot's active hinges, output order. Radians."""
    row = int(world.rows([handle])[0])
    offsets = world.output_offsets
    return world.targets[offsets[row]:offsets[row + 1]]
