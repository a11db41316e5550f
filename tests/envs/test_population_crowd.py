"""A crowded MuJoCo world where robots walk into each other loses none of them."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from revolve_env import example, population_env

pytest.importorskip("mujoco", reason="the mujoco package is not installed")


@pytest.mark.parametrize("seed", [1, 5])
def test_twenty_walkers_packed_in_a_disc_collide_for_ten_seconds_and_none_blows_up(
        seed: int) -> None:
    # With MuJoCo's implicitfast integrator these two worlds lost 4 and 2 robots within 7 s
    # (touching robots flung apart at tens of m/s); see the MuJoCo backend's doc.
    robots = [example(("spider", "gecko", "snake")[i % 3]) for i in range(20)]
    env = population_env(engine="mujoco", initial_robots=robots, max_births=20,
                         birth_radius=0.7, birth_clearance=0.0, max_placement_tries=1000)
    env.reset(seed=seed)
    backend: Any = env.world.backend
    touching_steps = 0
    for _ in range(600):
        _, _, terminations, _, infos = env.step({})
        assert not any(terminations.values()), {a: infos[a].get("blow_up") for a in terminations}
        d = backend._data
        geoms = d.contact.geom[: d.ncon]
        touching_steps += bool((geoms.min(axis=1) > 0).any())  # geom 0 is the ground
    assert touching_steps > 300  # robots touch other robots most of the time
    positions = env.world.core_positions()
    assert np.isfinite(positions).all() and len(env.agents) == 20
    env.close()
