"""validate(): every rule rejects its kind of bad robot, naming the rule and the part."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import pytest
from hypothesis import given, settings
from strategies import robots

from revolve_env.body import (
    EXAMPLES,
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
    validate,
)

IMU = tuple(Neuron(f"imu{k}", Layer.INPUT, Activation.INPUT) for k in range(6))


def core(*children: tuple[int, Node], neurons: tuple[Neuron, ...] = IMU) -> Node:
    return Node(PartType.CORE, neurons=neurons, children=tuple(children))


def hinge(nid: str, *children: tuple[int, Node], orientation: int = 0) -> Node:
    return Node(PartType.ACTIVE_HINGE, orientation, (),
                neurons=(Neuron(nid, Layer.OUTPUT, Activation.OSCILLATOR),),
                children=tuple(children))


def brick(*children: tuple[int, Node]) -> Node:
    return Node(PartType.BRICK, children=tuple(children))


def touch(prefix: str) -> Node:
    return Node(PartType.TOUCH_SENSOR, neurons=(
        Neuron(f"{prefix}l", Layer.INPUT, Activation.INPUT),
        Neuron(f"{prefix}r", Layer.INPUT, Activation.INPUT),
    ))


def base() -> Robot:
    """A small valid robot: a hinge with a brick in front, a bar on the left."""
    bar = Node(PartType.PARAMETRIC_BAR, params=(0.05, 0.0, 0.0))
    return Robot(core((0, hinge("h0", (1, brick()))), (1, bar)),
                 (Connection("imu0", "h0", 0.5),))


def chain(n: int, make: Callable[[int, Node | None], Node]) -> Node | None:
    node: Node | None = None
    for i in reversed(range(n)):
        node = make(i, node)
    return node


def long_snake(n: int) -> Robot:
    body = chain(n, lambda i, c: hinge(f"h{i}", *(((1, c),) if c else ()),
                                       orientation=90 * (i % 2)))
    assert body is not None
    return Robot(core((2, body)))


def brick_line(n: int) -> Robot:
    body = chain(n, lambda i, c: brick(*(((1, c),) if c else ())))
    assert body is not None
    return Robot(core((0, body)))


def brick_ring(n: int) -> Robot:
    """A front brick, then ``n - 1`` bricks each on the previous one's left face."""
    body = chain(n, lambda i, c: brick(*(((2, c),) if c else ())))
    assert body is not None
    return Robot(core((0, body)))


def overlapping_ring() -> Robot:
    """Four bricks turning left around the core: the fourth lands on the core."""
    return brick_ring(4)


def _with_node(robot: Robot, path: tuple[int, ...], **changes: object) -> Robot:
    return robot.replace_node(path, replace(robot.node(path), **changes))


BAD: dict[str, tuple[Callable[[], Robot | object], str, tuple[int, ...] | None, Limits | None]] = {
    # name: (robot builder, rule, path named by the error or None, limits)
    "root is not a core": (lambda: Robot(brick()), "root-core", (), None),
    "core below the root": (lambda: _with_node(base(), (), children=((0, core()),)),
                            "core-not-root", (0,), None),
    "unknown slot": (lambda: Robot(core((7, brick()))), "slot", (), None),
    "slot of a sensor": (lambda: Robot(core((0, touch("t")))).replace_node(
        (0,), replace(touch("t"), children=((1, brick()),))), "slot", (0,), None),
    "duplicate slot": (lambda: Robot(core((0, brick()), (0, brick()))), "slot-duplicate", (), None),
    "children out of order": (lambda: Robot(core((1, brick()), (0, brick()))), "slot-order", (),
                              None),
    "param out of range": (lambda: _with_node(base(), (1,), params=(0.5, 0.0, 0.0)),
                           "param-range", (1,), None),
    "param NaN": (lambda: _with_node(base(), (1,), params=(float("nan"), 0.0, 0.0)),
                  "param-range", (1,), None),
    "wrong param count": (lambda: _with_node(base(), (0,), params=(1.0,)), "param-count", (0,),
                          None),
    "bad orientation": (lambda: _with_node(base(), (0, 1), orientation=45), "orientation",
                        (0, 1), None),
    # 90.0 == 90 and False == 0, but JSON would write what reading refuses
    "float orientation": (lambda: _with_node(base(), (0, 1), orientation=90.0), "orientation",
                          (0, 1), None),
    "boolean orientation": (lambda: _with_node(base(), (0, 1), orientation=False), "orientation",
                            (0, 1), None),
    "boolean slot": (lambda: Robot(core((True, brick()))), "children", (), None),
    "bad colour": (lambda: _with_node(base(), (0,), color=(1.5, 0.0, 0.0)), "color", (0,), None),
    "too few input neurons": (lambda: _with_node(base(), (), neurons=IMU[:5]), "input-neurons",
                              (), None),
    "input neuron on a brick": (lambda: _with_node(base(), (0, 1), neurons=(
        Neuron("x", Layer.INPUT, Activation.INPUT),)), "input-neurons", (0, 1), None),
    "hinge without output": (lambda: _with_node(base(), (0,), neurons=()), "output-neurons", (0,),
                             None),
    "two outputs on a hinge": (lambda: _with_node(base(), (0,), neurons=(
        Neuron("h0", Layer.OUTPUT, Activation.LINEAR),
        Neuron("h1", Layer.OUTPUT, Activation.LINEAR))), "output-neurons", (0,), None),
    "output with input activation": (lambda: _with_node(base(), (0,), neurons=(
        Neuron("h0", Layer.OUTPUT, Activation.INPUT),)), "neuron-activation", (0,), None),
    "neuron param out of range": (lambda: _with_node(base(), (0,), neurons=(
        Neuron("h0", Layer.OUTPUT, Activation.OSCILLATOR, period=10.0),)), "neuron-param", (0,),
        None),
    "unused neuron param NaN": (lambda: _with_node(base(), (0,), neurons=(
        Neuron("h0", Layer.OUTPUT, Activation.OSCILLATOR, bias=float("nan")),)), "neuron-param",
        (0,), None),
    "duplicate neuron id": (lambda: _with_node(base(), (0,), neurons=(
        Neuron("imu3", Layer.OUTPUT, Activation.OSCILLATOR),)), "neuron-id-duplicate", (0,), None),
    "empty neuron id": (lambda: _with_node(base(), (0,), neurons=(
        Neuron("", Layer.OUTPUT, Activation.OSCILLATOR),)), "neuron-id", (0,), None),
    "missing neuron reference": (lambda: replace(base(), connections=(
        Connection("imu0", "ghost", 1.0),)), "connection-ref", None, None),
    "connection into an input": (lambda: replace(base(), connections=(
        Connection("h0", "imu1", 1.0),)), "connection-into-input", None, None),
    "NaN weight": (lambda: replace(base(), connections=(
        Connection("imu0", "h0", float("nan")),)), "connection-weight", None, None),
    "weight out of range": (lambda: replace(base(), connections=(
        Connection("imu0", "h0", 2.5),)), "connection-weight", None, None),
    "duplicate connection": (lambda: replace(base(), connections=(
        Connection("imu0", "h0", 1.0), Connection("imu0", "h0", -1.0))),
        "connection-duplicate", None, None),
    "too many parts (default 30)": (lambda: brick_line(30), "max-parts", None, None),
    "too many parts (custom)": (base, "max-parts", None, Limits(max_parts=3)),
    "too many inputs": (lambda: Robot(core((0, touch("a")), (1, touch("b")), (3, touch("c")))),
                        "max-inputs", None, None),
    "too many outputs": (lambda: long_snake(11), "max-outputs", None, None),
    "too many hidden neurons": (lambda: _with_node(base(), (0, 1), neurons=tuple(
        Neuron(f"hid{k}", Layer.HIDDEN, Activation.SIGMOID) for k in range(11))),
        "max-hidden", None, None),
    "overlapping parts": (overlapping_ring, "overlap", (), None),
    "bar folded back into the core": (lambda: Robot(core((0, Node(
        PartType.PARAMETRIC_BAR, params=(0.02, 90.0, 0.0), children=((1, brick()),))))),
        "overlap", (), None),
    "not a robot": (lambda: "spider", "robot-type", None, None),
}


@pytest.mark.parametrize("case", list(BAD))
def test_validate_rejects_bad_robot_with_its_rule(case: str) -> None:
    build, rule, path, limits = BAD[case]
    with pytest.raises(RobotError) as info:
        validate(build(), limits)  # type: ignore[arg-type]
    assert info.value.rule == rule, str(info.value)
    assert info.value.path == path
    message = str(info.value)
    assert f"[{rule}]" in message
    if path is not None:
        where = "core" if not path else "core/" + "/".join(map(str, path))
        assert message.startswith(f"part at {where}:")


def test_limits_just_reached_are_accepted() -> None:
    validate(brick_line(29))  # 30 parts with the core
    validate(long_snake(10))  # 10 outputs
    validate(Robot(core((0, touch("a")), (1, touch("b")))))  # 10 inputs
    validate(base(), Limits(max_parts=4))


def test_ring_of_three_bricks_fits_but_four_close_onto_the_core() -> None:
    validate(brick_ring(3))
    with pytest.raises(RobotError, match="not constructible"):
        validate(overlapping_ring())


@pytest.mark.parametrize("name", list(EXAMPLES))
def test_every_example_is_valid(name: str) -> None:
    robot = example(name)
    validate(robot)
    validate(robot)
    assert robot == EXAMPLES[name]()  # builders are pure


def test_unknown_example_name_is_a_clear_error() -> None:
    with pytest.raises(ValueError, match="unknown example robot 'dog'.*spider"):
        example("dog")


def test_limits_reject_nonsense() -> None:
    with pytest.raises(ValueError, match="max_parts"):
        Limits(max_parts=0)
    with pytest.raises(ValueError, match="max_inputs"):
        Limits(max_inputs=-1)


@settings(max_examples=40, deadline=None)
@given(robots(max_parts=6))
def test_strategy_robots_are_valid_and_within_limits(robot: Robot) -> None:
    validate(robot)
    assert robot.num_parts() <= 6
    assert len(robot.neurons_of(Layer.INPUT)) <= Limits().max_inputs
