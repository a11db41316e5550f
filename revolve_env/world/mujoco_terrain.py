"""The ground of a MuJoCo scene: the plane, or a terrain's heightfield (imports ``mujoco``).

With :mod:`~revolve_env.world.mujoco_backend`, :mod:`~revolve_env.world.mujoco_scenes` and
:mod:`~revolve_env.world.mujoco_batch`, the only modules that import ``mujoco``. Every scene (the
online world, each isolated scene, a rebuilt snapshot) gets its ground here, from
:mod:`revolve_env.terrain`'s height grid.
"""

from __future__ import annotations

from revolve_env.terrain import Flat, Terrain
from revolve_env.world.mujoco_gl import mujoco  # its OpenGL backend chosen first

__all__ = ["add_ground"]


def add_ground(spec: mujoco.MjSpec, terrain: Terrain) -> mujoco.MjsGeom:
    """The ground geom of ``terrain``: the plane, or an ``hfield`` of the terrain's height grid.

    MuJoCo's hfield holds heights normalised to [0, 1] (scaled by its elevation ``size[2]``
    above the geom's origin), rows along +y from -y, columns along +x from -x, and splits each
    cell along the diagonal :mod:`~revolve_env.terrain` assumes.
    """
    ground = spec.worldbody.add_geom()
    ground.name = "ground"
    if isinstance(terrain, Flat):
        ground.type = mujoco.mjtGeom.mjGEOM_PLANE
        ground.size = [0.0, 0.0, 0.1]
        return ground
    grid = terrain.heights()
    low, high = float(grid.min()), float(grid.max())
    rise = max(high - low, 1e-9)  # a level grid: MuJoCo needs a positive elevation
    field = spec.add_hfield()
    field.name = "terrain"
    field.nrow, field.ncol = grid.shape
    field.size = [terrain.size / 2, terrain.size / 2, rise, 0.1]  # base: a 0.1 m thick slab
    field.userdata = ((grid - low) / rise).ravel().tolist()
    ground.type = mujoco.mjtGeom.mjGEOM_HFIELD
    ground.hfieldname = "terrain"
    ground.pos = [0.0, 0.0, low]
    return ground
