"""A task of a user's own for the experiment tests (dotted path ``experiment_tasks:Forward``).

Importing this module is recorded in :data:`IMPORTS`, so a test can tell whether reading a stored
configuration imported it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from revolve_env.fitness import Window
from revolve_env.tasks import BaseTask

IMPORTS = ["experiment_tasks"]


@dataclass(frozen=True)
class Forward(BaseTask):
    """Displacement along +x over the window, scaled. Metres."""

    scale: float = 1.0

    def fitness(self, window: Window) -> NDArray[np.float64]:
        out: NDArray[np.float64] = self.scale * (window.end[:, 0] - window.start[:, 0])
        return out
