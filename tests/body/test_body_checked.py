"""check(): a robot is validated and assembled once; its record serves its later checks and model.

Robots here are compared by identity: the memory is of robot objects."""

from __future__ import annotations

import importlib
from dataclasses import replace

import numpy as np
import pytest

from evolution.config import EvolutionConfig
from evolution.operators import reproduce
from evolution.random_robot import random_robot
from revolve_env.body import (
    Activation,
    Connection,
    Layer,
    Limits,
    Neuron,
    Node,
    PartType,
    Robot,
    RobotError,
    example,
)
from revolve_env.body.geometry import Assembly, assemble
from revolve_env.body.validate import REMEMBERED, assembly_of, check, validate
from revolve_env.world.model import build_model

# the module (the package's name ``validate`` is the function)
validation = importlib.import_module("revolve_env.body.validate")


def same_assembly(a: Assembly, b: Assembly) -> None:
    assert len(a.boxes) == len(b.boxes) and len(a.bodies) == len(b.bodies)
    for x, y in zip(a.boxes, b.boxes, strict=True):
        assert x.part == y.part and x.name == y.name and x.body == y.body
        for f in ("center", "rotation", "size"):
            assert np.array_equal(getattr(x, f), getattr(y, f))


@pytest.fixture
def counted(monkeypatch: pytest.MonkeyPatch) -> list[Robot]:
    """Every assembly validation makes (the robots assembled)."""
    calls: list[Robot] = []

    def counting(robot: Robot) -> Assembly:
        calls.append(robot)
        return assemble(robot)

    monkeypatch.setattr(validation, "assemble", counting)
    return calls


def fresh(name: str = "spider") -> Robot:
    """An example robot as a new object (equal robots are not the same object)."""
    robot = example(name)
    return replace(robot, name=robot.name + " ")


def test_the_record_holds_the_robot_its_limits_and_its_assembly(counted: list[Robot]) -> None:
    robot, limits = fresh(), Limits(max_parts=20)
    record = check(robot, limits)
    assert record.robot is robot and record.limits == limits
    same_assembly(record.assembly, assemble(robot))
    assert len(counted) == 1 and counted[0] is robot


def test_a_robot_is_assembled_once_for_every_later_check_and_its_model(
        counted: list[Robot]) -> None:
    robot = fresh()
    record = check(robot)
    validate(robot)
    assert check(robot) is record
    assert assembly_of(robot) is record.assembly
    build_model(robot)
    assert len(counted) == 1 and counted[0] is robot


def test_an_equal_robot_that_is_another_object_is_checked_itself(counted: list[Robot]) -> None:
    a, b = fresh(), fresh()
    assert a == b and a is not b
    validate(a)
    validate(b)
    assert len(counted) == 2 and counted[0] is a and counted[1] is b


def test_other_limits_are_checked_again_and_can_refuse(counted: list[Robot]) -> None:
    robot = fresh()
    validate(robot)
    with pytest.raises(RobotError, match="more than 3 parts"):
        validate(robot, Limits(max_parts=3))
    validate(robot)  # the loose limits still pass, without assembling it again
    assert len(counted) == 1 and counted[0] is robot


def test_an_invalid_robot_is_refused_every_time() -> None:
    robot = fresh()
    src, dst = robot.neurons_of(Layer.INPUT)[0].id, robot.neurons_of(Layer.OUTPUT)[0].id
    bad = replace(robot, connections=(Connection(src, dst, 9.0),))
    for _ in range(2):
        with pytest.raises(RobotError, match="outside"):
            validate(bad)
    assert validation._RECENT.find(bad) is None


def test_an_assembly_of_another_body_is_not_taken() -> None:
    """check(assembly=) takes it only for this very body: an overlap cannot hide behind it."""
    ring = _overlapping_ring()
    with pytest.raises(RobotError, match="not constructible"):
        check(ring, assembly=assemble(fresh()))


def _overlapping_ring() -> Robot:
    """Four bricks, each on the left face of the one before: the fourth lands on the core."""
    imu = tuple(Neuron(f"imu{k}", Layer.INPUT, Activation.INPUT) for k in range(6))
    body: Node | None = None
    for _ in range(4):
        body = Node(PartType.BRICK, children=((2, body),) if body is not None else ())
    assert body is not None
    return Robot(Node(PartType.CORE, neurons=imu, children=((0, body),)))


def test_the_memory_is_bounded(counted: list[Robot]) -> None:
    first = fresh()
    validate(first)
    others = [fresh("gecko") for _ in range(REMEMBERED)]
    for robot in others:
        validate(robot)
    assert len(validation._RECENT._records) == REMEMBERED
    validate(first)  # forgotten: assembled again
    assert sum(r is first for r in counted) == 2
    validate(others[-1])
    assert sum(r is others[-1] for r in counted) == 1


def test_a_child_of_reproduction_is_checked_once_on_its_way(counted: list[Robot]) -> None:
    """Its operators' last assembly is the final check's; its parents' and evaluation's checks
    and its model find the record."""
    config = EvolutionConfig()
    rng = np.random.default_rng(5)
    a, b = random_robot(rng, config), random_robot(rng, config)
    result = None
    while result is None or result.child is None:
        result = reproduce(a, b, rng, config)
    child = result.child
    counted.clear()
    validate(child, config.limits)
    validate(a, config.limits)
    build_model(child)
    assert counted == []
