"""Terrains: the ground robots walk on, as pure data (no physics engine here).

A terrain is a frozen spec; every terrain but :class:`Flat` is a square heightfield of side
``size`` metres centred on the origin, sampled every ``resolution`` metres. Its height grid
(:meth:`Heightfield.heights`) is computed here with NumPy, once, and each backend builds its
ground from that very grid (MuJoCo's ``hfield``, pybullet's ``GEOM_HEIGHTFIELD``), so both
engines hold the same geometry. Between samples the ground is the triangle surface both engines
collide with: each grid cell is split along its diagonal from (x0, y0) to (x1, y1)
(MuJoCo's split; the pybullet backend turns its heightfield to match), and
:meth:`Heightfield.height_at` is that surface, the one home of ``h(x, y)``.

Shipped (:data:`TERRAINS`, one line each): ``"flat"`` (the plane, the default: nothing changes),
``"rugged"`` (smoothed random bumps from a seed of its own, so no other random number moves),
``"crater"`` (a pit ringed by a rim) and ``"bowl"`` (a wide paraboloid). The defaults are mild:
the example walkers still walk on each (``benchmarks/bench_terrains.py``, ``docs/terrains.md``).

Beyond a heightfield's edge there is no ground: robots are placed on it only
(:meth:`Heightfield.ground_under` refuses a footprint that reaches past the edge).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.ndimage import gaussian_filter

__all__ = ["TERRAINS", "Bowl", "Crater", "Flat", "Heightfield", "Rugged", "Terrain",
           "TerrainError", "make_terrain", "terrain_table"]

_MAX_SAMPLES = 2049
"""Most samples per side of a height grid (about 4 million in all)."""


class TerrainError(ValueError):
    """An unknown terrain, a bad terrain parameter, or a robot placed off the terrain."""


@dataclass(frozen=True, slots=True)
class Flat:
    """The infinite horizontal plane z = 0 (the default ground; nothing changes with it)."""

    name: ClassVar[str] = "flat"

    def height_at(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        """Ground height under (x, y): 0 everywhere. Metres."""
        return np.zeros(np.broadcast(np.asarray(x), np.asarray(y)).shape)

    def ground_under(self, x: float, y: float, radius: float) -> float:
        """Highest ground under a disc of ``radius`` about (x, y): 0. Metres."""
        return 0.0


@dataclass(frozen=True, slots=True)
class Heightfield:
    """A square height grid centred on the origin (the base of every non-flat terrain).

    Attributes:
        size: Side of the square. Metres.
        resolution: Spacing of the samples (rounded so that a whole number of cells fits
            ``size``). Metres.
    """

    name: ClassVar[str] = "heightfield"
    size: float = 10.0
    resolution: float = 0.05

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "seed":
                continue
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise TerrainError(f"{self.name} terrain: {f.name} must be a number, "
                                   f"got {value!r}")
            if not (math.isfinite(value) and value > 0):
                raise TerrainError(f"{self.name} terrain: {f.name} must be a positive finite "
                                   f"number, got {value!r}")
        cells = self.size / self.resolution
        if not 2 <= round(cells) < _MAX_SAMPLES:
            raise TerrainError(f"{self.name} terrain: size / resolution must give 2 to "
                               f"{_MAX_SAMPLES - 1} cells per side, got {cells:.6g}")

    @property
    def samples(self) -> int:
        """Samples per side of the grid."""
        return round(self.size / self.resolution) + 1

    @property
    def spacing(self) -> float:
        """Distance between neighbouring samples. Metres."""
        return self.size / (self.samples - 1)

    def axis(self) -> NDArray[np.float64]:
        """Coordinates of the samples along x (and y), from -size/2 to size/2. Metres."""
        return np.linspace(-self.size / 2, self.size / 2, self.samples)

    def heights(self) -> NDArray[np.float64]:
        """The height grid, ``[iy, ix]`` at (axis[ix], axis[iy]) (read-only, cached). Metres."""
        return _grid(self)

    def _profile(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Height at sample points (subclasses). Metres."""
        raise NotImplementedError

    def height_at(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        """Ground height under (x, y), the engines' triangle surface; NaN off the grid. Metres."""
        grid = self.heights()
        half, s, n = self.size / 2, self.spacing, self.samples
        u = (np.asarray(x, dtype=np.float64) + half) / s
        v = (np.asarray(y, dtype=np.float64) + half) / s
        i = np.clip(np.floor(u), 0, n - 2).astype(np.intp)
        j = np.clip(np.floor(v), 0, n - 2).astype(np.intp)
        fu, fv = u - i, v - j
        h00, h10 = grid[j, i], grid[j, i + 1]
        h01, h11 = grid[j + 1, i], grid[j + 1, i + 1]
        below = fu >= fv  # the triangle (x0, y0), (x1, y0), (x1, y1)
        h = np.where(below, h00 + fu * (h10 - h00) + fv * (h11 - h10),
                     h00 + fv * (h01 - h00) + fu * (h11 - h01))
        off = (u < 0) | (u > n - 1) | (v < 0) | (v > n - 1)
        return np.where(off, np.nan, h)

    def ground_under(self, x: float, y: float, radius: float) -> float:
        """Highest ground under a disc of ``radius`` about (x, y) (its grid cells' samples).

        Raises:
            TerrainError: the disc reaches past the terrain's edge.
        """
        half, s = self.size / 2, self.spacing
        if max(abs(x), abs(y)) + radius > half:
            raise TerrainError(
                f"a robot of footprint radius {radius:.3f} m at ({x:.3f}, {y:.3f}) m reaches "
                f"past the edge of the {self.name} terrain (size {self.size:g} m, edges at "
                f"+-{half:g} m)")
        lo_i, hi_i = (math.floor((x - radius + half) / s), math.ceil((x + radius + half) / s))
        lo_j, hi_j = (math.floor((y - radius + half) / s), math.ceil((y + radius + half) / s))
        return float(self.heights()[lo_j:hi_j + 1, lo_i:hi_i + 1].max())

    def check_disc(self, radius: float, what: str) -> None:
        """Refuse a disc about the origin (e.g. the birth disc) that reaches past the edge.

        Raises:
            TerrainError: naming ``what`` (e.g. ``"the birth disc: birth_radius"``), the radius
                and the terrain.
        """
        if radius > self.size / 2:
            raise TerrainError(f"{what} ({radius:g} m) reaches past the edge of the "
                               f"{self.name} terrain (size {self.size:g} m, edges at "
                               f"+-{self.size / 2:g} m)")


@functools.lru_cache(maxsize=8)
def _grid(terrain: Heightfield) -> NDArray[np.float64]:
    """A terrain's height grid (a pure function of the frozen spec, memoised)."""
    xs = terrain.axis()
    grid = np.ascontiguousarray(terrain._profile(xs[None, :], xs[:, None]), dtype=np.float64)
    grid = np.broadcast_to(grid, (xs.size, xs.size)).copy()
    grid.flags.writeable = False
    return grid


@dataclass(frozen=True, slots=True)
class Rugged(Heightfield):
    """Smoothed random bumps: white noise blurred over ``scale``, stretched to [0, height].

    Attributes:
        height: Highest bump above the lowest hollow. Metres.
        scale: Width of the bumps (the blur's standard deviation). Metres.
        seed: Seed of the terrain's own generator (a terrain parameter, not the world's stream).
    """

    name: ClassVar[str] = "rugged"
    height: float = 0.02
    scale: float = 0.1
    seed: int = 0

    def __post_init__(self) -> None:
        Heightfield.__post_init__(self)
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise TerrainError(f"rugged terrain: seed must be an integer >= 0, got {self.seed!r}")

    def _profile(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        rng = np.random.default_rng(self.seed)
        noise = gaussian_filter(rng.standard_normal((y.size, x.size)),
                                self.scale / self.spacing, mode="wrap")
        low, high = noise.min(), noise.max()
        out: NDArray[np.float64] = (noise - low) / (high - low) * self.height
        return out


@dataclass(frozen=True, slots=True)
class Crater(Heightfield):
    """A pit ringed by a rim: ``height * (r / radius)**2`` inside, a Gaussian fall outside.

    The centre (where robots start) is at 0; the rim, ``height`` high at ``radius`` from the
    centre, falls back towards 0 over about ``width``.

    Attributes:
        height: Height of the rim. Metres.
        radius: Distance of the rim from the centre. Metres.
        width: Width of the rim's outer fall (the Gaussian's standard deviation). Metres.
    """

    name: ClassVar[str] = "crater"
    height: float = 0.03
    radius: float = 1.5
    width: float = 0.5

    def _profile(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        r = np.hypot(x, y)
        out: NDArray[np.float64] = np.where(
            r <= self.radius, self.height * (r / self.radius) ** 2,
            self.height * np.exp(-0.5 * ((r - self.radius) / self.width) ** 2))
        return out


@dataclass(frozen=True, slots=True)
class Bowl(Heightfield):
    """A wide paraboloid: ``depth * ((r / radius)**2 - 1)`` up to ``radius``, flat beyond.

    The centre (where robots start) is ``depth`` below the flat ground around the bowl.

    Attributes:
        depth: Depth of the centre below the rim. Metres.
        radius: Radius of the bowl. Metres.
    """

    name: ClassVar[str] = "bowl"
    resolution: float = 0.1
    depth: float = 0.2
    radius: float = 4.0

    def _profile(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        r = np.minimum(np.hypot(x, y) / self.radius, 1.0)
        out: NDArray[np.float64] = self.depth * (r ** 2 - 1.0)
        return out


Terrain = Flat | Heightfield
"""Any terrain spec."""

TERRAINS: dict[str, type[Terrain]] = {
    "flat": Flat,
    "rugged": Rugged,
    "crater": Crater,
    "bowl": Bowl,
}
"""Terrain name -> its spec class (a new terrain is one class and one line here)."""


def make_terrain(terrain: Terrain | str | Mapping[str, Any] | None = None) -> Terrain:
    """A terrain spec from a spec, a name, or a table ``{"name": ..., <parameters>}``.

    ``None`` is :class:`Flat`. A table is what :func:`terrain_table` writes (and an
    experiment's ``[world.terrain]`` holds).

    Raises:
        TerrainError: unknown name, unknown or bad parameter (one line naming it).
    """
    if terrain is None:
        return Flat()
    if isinstance(terrain, Flat | Heightfield):
        return terrain
    if isinstance(terrain, str):
        name, params = terrain, {}
    elif isinstance(terrain, Mapping):
        params = dict(terrain)
        name = params.pop("name", None)
        if not isinstance(name, str):
            raise TerrainError(f"a terrain table needs a name (one of {', '.join(TERRAINS)}), "
                               f"got {terrain!r}")
    else:
        raise TerrainError(f"a terrain is a name (one of {', '.join(TERRAINS)}), a table or a "
                           f"spec, got {terrain!r}")
    if name not in TERRAINS:
        raise TerrainError(f"unknown terrain {name!r}: choose one of {', '.join(TERRAINS)}")
    cls = TERRAINS[name]
    known = [f.name for f in fields(cls)]
    unknown = sorted(set(params) - set(known))
    if unknown:
        raise TerrainError(f"{name} terrain has no parameter {', '.join(map(repr, unknown))}; "
                           f"its parameters: {', '.join(known) or 'none'}")
    return cls(**params)


def terrain_table(terrain: Terrain) -> dict[str, Any]:
    """A terrain as plain data ``{"name": ..., <parameters>}`` (:func:`make_terrain` reads it)."""
    return {"name": terrain.name, **{f.name: getattr(terrain, f.name) for f in fields(terrain)}}
