"""Selection: tournament, (mu + lambda), random survivors and the online death rule."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evolution.selection import (
    mu_plus_lambda,
    online_survivors,
    random_survivors,
    select_parents,
    tournament,
)

FITNESS = st.lists(st.floats(-100, 100), min_size=4, max_size=40)


@settings(max_examples=50, deadline=None)
@given(FITNESS, st.integers(0, 2**32 - 1))
def test_tournament_winner_beats_at_least_k_minus_one_others(f: list[float], seed: int) -> None:
    rng = np.random.default_rng(seed)
    w = tournament(f, rng, k=4)
    # The winner is the best of 4 distinct robots, so at least 3 others are no better.
    assert sum(1 for i, x in enumerate(f) if i != w and (x < f[w] or (x == f[w] and i > w))) >= 3


def test_tournament_with_k_at_least_n_returns_the_fittest_lowest_index_on_ties() -> None:
    rng = np.random.default_rng(0)
    assert tournament([1.0, 5.0, 5.0, 2.0], rng, k=10) == 1
    assert tournament([3.0, 1.0], rng, k=4, exclude=0) == 1


def test_tournament_picks_in_proportion_to_rank() -> None:
    rng = np.random.default_rng(1)
    f = np.arange(10.0)
    wins = np.bincount([tournament(f, rng) for _ in range(3000)], minlength=10)
    assert wins[:3].sum() == 0  # the 3 worst can never beat 3 others
    assert wins[9] > wins[8] > wins[7]  # P(best wins) = 4/10


def test_select_parents_are_distinct_and_reproducible() -> None:
    for seed in range(50):
        a, b = select_parents([1.0, 1.0, 1.0, 1.0, 1.0], np.random.default_rng(seed))
        assert a != b
    assert select_parents(np.arange(8.0), np.random.default_rng(3)) == select_parents(
        np.arange(8.0), np.random.default_rng(3))
    with pytest.raises(ValueError, match="at least 2"):
        select_parents([1.0], np.random.default_rng(0))


def test_mu_plus_lambda_keeps_the_fittest() -> None:
    f = [0.5, 3.0, -1.0, 3.0, 2.0, 0.0]
    assert mu_plus_lambda(f, 3).tolist() == [1, 3, 4]
    assert sorted(mu_plus_lambda(f, 6).tolist()) == list(range(6))
    with pytest.raises(ValueError, match="mu"):
        mu_plus_lambda(f, 0)
    with pytest.raises(ValueError, match="finite"):
        mu_plus_lambda([1.0, float("nan")], 1)


def test_random_survivors_are_distinct_sorted_and_cover_everyone() -> None:
    rng = np.random.default_rng(0)
    seen = set()
    for _ in range(50):
        s = random_survivors(30, 15, rng)
        assert len(set(s.tolist())) == 15 and s.tolist() == sorted(s.tolist())
        seen |= set(s.tolist())
    assert seen == set(range(30))
    with pytest.raises(ValueError):
        random_survivors(5, 6, rng)


def test_online_rule_kills_those_below_70_percent_of_the_mean() -> None:
    f = [10.0] * 10 + [1.0, 2.0]  # mean 8.58: bar 6.0
    assert online_survivors(f).tolist() == [10, 11]


def test_online_rule_never_goes_below_the_minimum() -> None:
    f = [10.0] * 7 + [1.0, 2.0, 3.0]  # 3 below the bar but only 2 may die; the least fit go
    assert online_survivors(f, min_alive=8).tolist() == [7, 8]
    assert online_survivors([10.0, 0.0] * 4).tolist() == []  # exactly 8 alive


def test_online_rule_culls_70_percent_at_the_maximum() -> None:
    f = np.linspace(10.0, 11.0, 30)  # nobody below 70 % of the mean
    dead = online_survivors(f)
    assert dead.tolist() == list(range(21))  # the 21 least fit
    assert online_survivors(f[:29]).tolist() == []  # below the maximum nothing happens


def test_online_rule_with_negative_or_zero_mean() -> None:
    # Mean -10: the bar is 30 % of |mean| below it (-13), not 70 % of it (-7, above the mean).
    f = [-10.0] * 9 + [-9.0, -11.0, -20.0]
    mean = np.mean(f)
    assert online_survivors(f).tolist() == [11]
    assert all(f[i] < mean for i in online_survivors(f))
    # Mean 0: the bar is 0; two may die, the tie among equals goes against the higher index.
    assert online_survivors([1.0] * 5 + [-1.0] * 5).tolist() == [8, 9]
