"""Hand-built test robots (independent of the example robots shipped with the package)."""

from __future__ import annotations

from revolve_env.body.robot import Activation, Layer, Neuron, Node, PartType, Robot

T = PartType


def _in(prefix: str, n: int) -> tuple[Neuron, ...]:
    return tuple(Neuron(f"{prefix}_in{i}", Layer.INPUT, Activation.INPUT) for i in range(n))


def _out(name: str) -> tuple[Neuron, ...]:
    return (Neuron(f"{name}_out", Layer.OUTPUT, Activation.LINEAR),)


def core(children: tuple[tuple[int, Node], ...] = ()) -> Node:
    return Node(T.CORE, neurons=_in("core", 6), children=children, color=(0.9, 0.8, 0.1))


def hinge(name: str, orientation: int = 0, child: Node | None = None) -> Node:
    return Node(T.ACTIVE_HINGE, orientation=orientation, neurons=_out(name),
                children=((1, child),) if child is not None else (), color=(0.8, 0.2, 0.2))


def brick(children: tuple[tuple[int, Node], ...] = ()) -> Node:
    return Node(T.BRICK, children=children, color=(0.2, 0.4, 0.9))


def lone_core() -> Robot:
    return Robot(core(), name="core")


def spider() -> Robot:
    """Core with four two-joint legs (8 active hinges, 17 parts)."""
    legs = tuple(
        (s, hinge(f"l{s}a", 90, brick(((1, hinge(f"l{s}b", 0, brick())),)))) for s in range(4)
    )
    return Robot(core(legs), name="spider")


def every_part() -> Robot:
    """One of every part type: bar, passive hinge, touch and light sensors, hinge, brick."""
    touch = Node(T.TOUCH_SENSOR, orientation=90, neurons=_in("touch", 2), color=(0.1, 0.8, 0.1))
    light = Node(T.LIGHT_SENSOR, neurons=_in("light", 1), color=(1.0, 1.0, 1.0))
    bar = Node(T.PARAMETRIC_BAR, params=(0.05, 0.0, 0.0), children=((1, brick()),))
    passive = Node(T.PASSIVE_HINGE, children=((1, brick()),))
    return Robot(core((
        (0, hinge("front", 0, brick(((1, light),)))),
        (1, bar),
        (2, passive),
        (3, brick(((1, touch),))),
    )), name="every_part")


def snake(n: int = 6) -> Robot:
    """A chain of ``n`` hinge+brick segments (2n + 1 parts)."""
    node: Node | None = None
    for i in reversed(range(n)):
        node = hinge(f"s{i}", 90 * (i % 2), brick(((1, node),) if node is not None else ()))
    assert node is not None
    return Robot(core(((0, node),)), name="snake")
