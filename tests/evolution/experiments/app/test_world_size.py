"""The robots alive an online world holds: the survivor rule's floor and ceiling, worked out by
hand for scenario 3 and its variants, and the growth curve's arithmetic (its closed-form mean
against the mean of its values, birth by birth)."""

from __future__ import annotations

import pytest

from evolution.experiments.app.world_size import (
    ONSET,
    SCALE,
    WorldGrowth,
    rule_bounds,
    world_growth,
)
from evolution.experiments.loop.config import load_config

SCENARIO3 = load_config("scenario3")


def test_scenario_3s_world_lies_between_9_and_20_robots() -> None:
    floor, ceiling = rule_bounds(SCENARIO3)
    # floor: every tick all mature robots but min_alive (8) die, then one is born: 9
    assert floor == 9.0
    # ceiling: nobody below the bar; one more robot a tick up to 30 (max_alive), where 70 %
    # (21) die: 9 left, 10 after the birth; a sawtooth 10, 11, ..., 30, mean 20
    assert ceiling == pytest.approx(20.0, abs=0.03)


@pytest.mark.parametrize(("changes", "floor", "ceiling"), [
    # min_alive 2: the floor is 2 + the newborn; the sawtooth is the same (9 survive the cull)
    ({"min_alive": 2}, 3.0, 20.0),
    # max_alive 16: 70 % is 11, but only 8 may die (min_alive): 8 left, a sawtooth 9..16
    ({"max_alive": 16, "population_size": 10}, 9.0, 12.5),
    # cull_fraction 0.5: 15 of 30 die, a sawtooth 16..30
    ({"cull_fraction": 0.5}, 9.0, 23.0),
    # fertile_age 45 s, three intervals: the two youngest are spared at every selection, so the
    # cull comes at 28 mature (30 alive) and kills 19 of them: 11 left, a sawtooth 12..30
    ({"fertile_age": 45.0}, 9.0, 21.0),
    # death_threshold 0: the bar is 0, nobody of positive fitness dies but at the cull
    ({"death_threshold": 0.0}, 20.0, 20.0),
])
def test_the_bounds_follow_the_survivor_rule(changes: dict[str, float], floor: float,
                                             ceiling: float) -> None:
    low, high = rule_bounds(SCENARIO3.replace(**changes))
    assert low == pytest.approx(floor, abs=0.03) and high == pytest.approx(ceiling, abs=0.03)


def test_the_world_stays_at_its_start_until_the_onset_then_grows_toward_the_ceiling() -> None:
    growth = WorldGrowth(9.0, 20.0, onset=100.0, scale=50.0)
    assert growth.alive(0) == growth.alive(100) == 9.0
    # one scale past the onset: 1 - 1/e of the way
    assert growth.alive(150) == pytest.approx(9.0 + 11.0 * (1 - 0.36787944117144233))
    assert growth.alive(1e6) == pytest.approx(20.0)
    assert growth.mean_alive(15, 100) == 9.0 and growth.mean_alive(50, 50) == 9.0
    # a world measured at or above the ceiling does not grow
    assert WorldGrowth(21.0, 20.0, 0.0, 50.0).mean_alive(0, 1000) == 21.0


@pytest.mark.parametrize(("first", "last"), [(15, 3000), (15, 120), (90, 400), (1889, 3000)])
def test_the_mean_is_the_curves_integral(first: int, last: int) -> None:
    growth = WorldGrowth(9.0, 20.0, onset=100.0, scale=50.0)
    steps = 200 * (last - first)  # midpoint rule, fine enough to be exact to 1e-6
    width = (last - first) / steps
    numeric = sum(growth.alive(first + (k + 0.5) * width) for k in range(steps)) / steps
    assert growth.mean_alive(first, last) == pytest.approx(numeric, rel=1e-6)
    # a run's intervals, one per birth: within 0.1 % of the integral at scenario 3's scale
    growth = WorldGrowth(9.0, 20.0, ONSET, SCALE)
    per_birth = sum(growth.alive(b) for b in range(first, last)) / (last - first)
    assert growth.mean_alive(first, last) == pytest.approx(per_birth, rel=1e-3)


def test_scenario_3s_growth_gives_the_measured_long_runs_mean() -> None:
    # The constants were fitted on it: 9.0 robots measured at the start, 13.8 on average over
    # the 1,889 births of the run (docs/performance.md); the paper's 3000 births then give 16.0.
    growth = world_growth(SCENARIO3, 9.0)
    assert (growth.start, growth.onset, growth.scale) == (9.0, ONSET, SCALE)
    assert growth.ceiling == pytest.approx(20.0, abs=0.03)
    assert growth.mean_alive(15, 1889) == pytest.approx(13.8, abs=0.05)
    assert growth.mean_alive(15, 3000) == pytest.approx(16.0, abs=0.05)
    assert growth.mean_alive(15, 60) == 9.0  # a short study's runs never leave their start
