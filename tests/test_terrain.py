"""Terrains as pure data: the height grid, h(x, y), the ground under a footprint, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from revolve_env.terrain import (
    TERRAINS,
    Bowl,
    Crater,
    Flat,
    Heightfield,
    Rugged,
    TerrainError,
    make_terrain,
    terrain_table,
)

_size = st.floats(0.5, 6.0)
_cells = st.integers(4, 120)


@st.composite
def heightfields(draw: st.DrawFn) -> Heightfield:
    """A random heightfield of any shipped kind, its parameters within their ranges."""
    size = draw(_size)
    resolution = size / draw(_cells)
    kind = draw(st.sampled_from(["rugged", "crater", "bowl"]))
    if kind == "rugged":
        return Rugged(size=size, resolution=resolution, height=draw(st.floats(1e-3, 0.5)),
                      scale=draw(st.floats(0.01, 1.0)), seed=draw(st.integers(0, 2**32)))
    if kind == "crater":
        return Crater(size=size, resolution=resolution, height=draw(st.floats(1e-3, 0.5)),
                      radius=draw(st.floats(0.05, 3.0)), width=draw(st.floats(0.01, 1.0)))
    return Bowl(size=size, resolution=resolution, depth=draw(st.floats(1e-3, 0.5)),
                radius=draw(st.floats(0.05, 3.0)))


@settings(max_examples=60, deadline=None)
@given(heightfields())
def test_the_grid_is_finite_square_and_within_the_terrain_s_range(t: Heightfield) -> None:
    grid = t.heights()
    assert grid.shape == (t.samples, t.samples)
    assert np.isfinite(grid).all()
    assert not grid.flags.writeable
    assert math.isclose(t.spacing * (t.samples - 1), t.size)
    if isinstance(t, Rugged):  # stretched to exactly [0, height]
        assert grid.min() == 0.0 and math.isclose(grid.max(), t.height)
    elif isinstance(t, Crater):
        assert grid.min() >= 0.0 and grid.max() <= t.height + 1e-12
    elif isinstance(t, Bowl):
        assert grid.min() >= -t.depth - 1e-12 and grid.max() <= 0.0


@settings(max_examples=60, deadline=None)
@given(heightfields(), st.data())
def test_h_is_the_triangle_surface_through_the_samples(t: Heightfield, data: st.DataObject,
                                                       ) -> None:
    """At the samples h is the grid; inside a cell it lies between the cell's corners and is
    linear along the cell's diagonal from (x0, y0) to (x1, y1) (the engines' triangles)."""
    grid, axis = t.heights(), t.axis()
    i = data.draw(st.integers(0, t.samples - 2))
    j = data.draw(st.integers(0, t.samples - 2))
    assert t.height_at(axis[i], axis[j]) == pytest.approx(grid[j, i], abs=1e-12)
    u, v = data.draw(st.floats(0, 1)), data.draw(st.floats(0, 1))
    x, y = axis[i] + u * t.spacing, axis[j] + v * t.spacing
    corners = grid[j:j + 2, i:i + 2]
    h = float(t.height_at(x, y))
    assert corners.min() - 1e-12 <= h <= corners.max() + 1e-12
    middle = float(t.height_at(axis[i] + 0.5 * t.spacing, axis[j] + 0.5 * t.spacing))
    assert middle == pytest.approx((grid[j, i] + grid[j + 1, i + 1]) / 2, abs=1e-12)


@settings(max_examples=60, deadline=None)
@given(heightfields(), st.data())
def test_the_ground_under_a_footprint_is_at_least_every_height_under_it(
        t: Heightfield, data: st.DataObject) -> None:
    half = t.size / 2
    radius = data.draw(st.floats(0.0, 0.45 * half))
    x = data.draw(st.floats(-(half - radius), half - radius))
    y = data.draw(st.floats(-(half - radius), half - radius))
    top = t.ground_under(x, y, radius)
    angle = np.linspace(0, 2 * np.pi, 64)
    for r in (0.0, 0.5 * radius, radius):
        assert (t.height_at(x + r * np.cos(angle), y + r * np.sin(angle)) <= top + 1e-12).all()
    assert top <= t.heights().max()


def test_off_the_grid_there_is_no_ground_and_no_placement() -> None:
    t = Rugged(size=2.0)
    assert np.isnan(t.height_at(1.01, 0.0)) and np.isfinite(t.height_at(0.99, 0.0))
    with pytest.raises(TerrainError, match=r"reaches past the edge of the rugged terrain \(size 2"):
        t.ground_under(0.9, 0.0, 0.2)
    with pytest.raises(TerrainError, match=r"^the birth disc: birth_radius \(1.5 m\) reaches "
                       r"past the edge of the rugged terrain \(size 2 m, edges at \+-1 m\)$"):
        t.check_disc(1.5, "the birth disc: birth_radius")
    t.check_disc(1.0, "the birth disc")


def test_the_flat_terrain_is_the_plane_everywhere() -> None:
    f = Flat()
    assert f.ground_under(1e6, -1e6, 3.0) == 0.0
    assert (f.height_at(np.arange(5.0), 1.0) == 0.0).all()


def test_the_rugged_seed_is_the_terrain_s_own() -> None:
    """The grid depends on its seed only, and drawing it moves no other random number."""
    state = np.random.get_state()
    other = np.random.default_rng(5)
    expected = np.random.default_rng(5).random(3)
    a = Rugged(seed=3, size=3.0).heights()
    assert np.array_equal(a, Rugged(seed=3, size=3.0, height=0.02).heights())
    assert not np.array_equal(a, Rugged(seed=4, size=3.0).heights())
    assert np.array_equal(other.random(3), expected)
    assert all(np.array_equal(x, y) if isinstance(x, np.ndarray) else x == y
               for x, y in zip(np.random.get_state(), state, strict=True))


def test_names_tables_and_specs_all_make_terrains() -> None:
    assert make_terrain(None) == Flat() == make_terrain("flat")
    assert set(TERRAINS) == {"flat", "rugged", "crater", "bowl"}
    for name in TERRAINS:
        t = make_terrain(name)
        assert t.name == name
        assert make_terrain(terrain_table(t)) == t
    t = make_terrain({"name": "rugged", "height": 0.05, "seed": 7})
    assert t == Rugged(height=0.05, seed=7)
    assert make_terrain(t) is t
    assert terrain_table(Bowl(depth=0.1)) == {"name": "bowl", "size": 10.0, "resolution": 0.1,
                                               "depth": 0.1, "radius": 4.0}


@pytest.mark.parametrize(("value", "message"), [
    ("lava", r"unknown terrain 'lava': choose one of flat, rugged, crater, bowl"),
    ({"height": 0.1}, "a terrain table needs a name"),
    ({"name": "bowl", "height": 0.1}, r"bowl terrain has no parameter 'height'; its parameters"),
    ({"name": "flat", "size": 3}, "flat terrain has no parameter 'size'"),
    ({"name": "rugged", "height": -0.1}, "rugged terrain: height must be a positive finite"),
    ({"name": "rugged", "height": float("nan")}, "rugged terrain: height must be a positive"),
    ({"name": "crater", "radius": "2"}, "crater terrain: radius must be a number, got '2'"),
    ({"name": "bowl", "size": True}, "bowl terrain: size must be a number"),
    ({"name": "rugged", "seed": -1}, "seed must be an integer >= 0"),
    ({"name": "rugged", "seed": 1.5}, "seed must be an integer >= 0"),
    ({"name": "rugged", "size": 10.0, "resolution": 0.001}, "size / resolution must give"),
    ({"name": "bowl", "size": 1.0, "resolution": 1.0}, "size / resolution must give"),
    (3, "a terrain is a name"),
])
def test_bad_terrains_are_refused_in_one_line(value: object, message: str) -> None:
    with pytest.raises(TerrainError, match=message) as info:
        make_terrain(value)  # type: ignore[arg-type]
    assert "\n" not in str(info.value)
