"""The Triangle of Life state machine: legal order, timing, recorded times."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from evolution.lifecycle import (
    LEGAL_TRANSITIONS,
    Lifecycle,
    LifecycleError,
    LifecycleTiming,
    Stage,
    stage_of,
)


def test_full_life_records_every_transition_with_its_time() -> None:
    life = Lifecycle(7)
    life.conceive(10.0, "parents 1,2")
    life.deliver(10.0)
    assert life.alive and not life.fertile
    made = life.advance_to_age(20.0)  # 30 s: past insertion (13 s) and fertility (25 s)
    assert [(t.source, t.target, t.time) for t in made] == [
        (Stage.DELIVERY, Stage.INFANCY, 13.0),
        (Stage.INFANCY, Stage.MATURITY, 25.0),
    ]
    assert life.fertile
    life.die(40.0, "survivor selection")
    assert not life.alive
    assert [t.target for t in life.transitions] == [
        Stage.CONCEPTION, Stage.DELIVERY, Stage.INFANCY, Stage.MATURITY, Stage.DEATH]
    assert life.transitions[0].source is None
    assert life.transitions[-1].note == "survivor selection"
    assert all(t.robot_id == 7 for t in life.transitions)


@pytest.mark.parametrize("age, stage", [(0.0, Stage.DELIVERY), (2.99, Stage.DELIVERY),
                                        (3.0, Stage.INFANCY), (14.99, Stage.INFANCY),
                                        (15.0, Stage.MATURITY), (1e6, Stage.MATURITY)])
def test_default_timing_is_the_papers(age: float, stage: Stage) -> None:
    assert LifecycleTiming().stage_at(age) is stage


def test_young_robot_stays_in_delivery() -> None:
    life = Lifecycle(0)
    life.conceive(0.0)
    life.deliver(0.0)
    assert life.advance_to_age(1.0) == []
    assert life.stage is Stage.DELIVERY


@pytest.mark.parametrize("steps", [
    ["deliver"], ["mature"], ["die"],
    ["conceive", "mature"], ["conceive", "begin_infancy"], ["conceive", "conceive"],
    ["conceive", "deliver", "mature"],
    ["conceive", "deliver", "die", "die"],
    ["conceive", "deliver", "begin_infancy", "mature", "begin_infancy"],
])
def test_illegal_transitions_raise(steps: list[str]) -> None:
    life = Lifecycle(3)
    for step in steps[:-1]:
        getattr(life, step)(1.0)
    with pytest.raises(LifecycleError, match="robot 3: illegal transition"):
        getattr(life, steps[-1])(1.0)


def test_time_cannot_go_backwards() -> None:
    life = Lifecycle(1)
    life.conceive(5.0)
    with pytest.raises(LifecycleError, match="earlier"):
        life.deliver(4.0)


def test_dead_or_unborn_robots_do_not_age() -> None:
    life = Lifecycle(1)
    life.conceive(0.0)
    with pytest.raises(LifecycleError, match="only a living robot"):
        life.advance_to_age(20.0)


def test_timing_validation() -> None:
    with pytest.raises(ValueError, match="fertile_age"):
        LifecycleTiming(insertion=3.0, fertile_age=2.0)
    with pytest.raises(ValueError, match="insertion"):
        LifecycleTiming(insertion=-1.0)


@given(st.lists(st.sampled_from(list(Stage)), max_size=8))
def test_only_legal_sequences_are_accepted(targets: list[Stage]) -> None:
    """Every sequence of targets is accepted exactly when each step is in the table."""
    life = Lifecycle(0)
    movers = {Stage.CONCEPTION: life.conceive, Stage.DELIVERY: life.deliver,
              Stage.INFANCY: life.begin_infancy, Stage.MATURITY: life.mature,
              Stage.DEATH: life.die}
    current: Stage | None = None
    for target in targets:
        legal = target in LEGAL_TRANSITIONS[current]
        if legal:
            movers[target](0.0)
            current = target
        else:
            with pytest.raises(LifecycleError):
                movers[target](0.0)
        assert life.stage is current


@pytest.mark.parametrize(("inserting", "mature", "stage"), [
    (True, False, Stage.DELIVERY), (False, False, Stage.INFANCY), (False, True, Stage.MATURITY),
    (True, True, Stage.MATURITY)])
def test_a_robot_in_a_world_follows_the_worlds_clock(inserting: bool, mature: bool,
                                                     stage: Stage) -> None:
    """The world says where a robot stands; the transitions keep their exact stamps."""
    life = Lifecycle(3)
    life.conceive(30.0)
    life.deliver(30.0)
    made = life.advance_to(stage_of(inserting, mature))
    assert life.stage is stage
    stamps = {Stage.INFANCY: 33.0, Stage.MATURITY: 45.0}
    assert [(t.target, t.time) for t in made] == [(t.target, stamps[t.target]) for t in made]
    assert life.advance_to(stage_of(inserting, mature)) == []  # nothing is due twice
