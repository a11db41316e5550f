"""Example robots shipped with the package, each with a hand-made oscillator controller.

Every function returns a fresh, valid :class:`~revolve_env.body.robot.Robot`. Each active hinge
carries one oscillator output neuron (period about 1 s); the phase offsets make a gait:

* ``spider``: core and four legs (hip pitch hinge, brick, knee pitch hinge, brick) with phases
  tuned for a forward gait.
* ``gecko``: two front legs, a two-segment spine that bends sideways and two hind legs; the front
  legs push together, the spine carries a travelling wave and the hind legs alternate.
* ``snake``: a chain of hinges of alternating orientation (pitch, yaw, ...) behind the core with a
  brick as tail; each axis carries a travelling wave.
* ``sensor_crawler``: a light sensor in front, two pitch legs, a yaw tail whose foot carries a
  touch sensor; the tail's sigmoid output mixes a hidden oscillator with the light and touch inputs
  so the robot can steer (9 inputs: 6 IMU, 2 touch, 1 light).
* ``bar_walker``: parametric bar joints as legs on active hinges, and a passive hinge tail that
  drags a brick.

Core slots: 0 front (+x), 1 left (+y), 2 back (-x), 3 right (-y). Hinge orientation 0 turns about a
horizontal axis (pitch), 90 about the vertical (yaw) when attached to a side of the core.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from revolve_env.body.parts import PART_SPECS
from revolve_env.body.robot import Activation, Connection, Layer, Neuron, Node, PartType, Robot
from revolve_env.body.serialize import load
from revolve_env.body.validate import Limits, validate

__all__ = [
    "EXAMPLES",
    "bar_walker",
    "example",
    "gecko",
    "resolve_robot",
    "sensor_crawler",
    "snake",
    "spider",
]

CORE_COLOR = (0.95, 0.75, 0.15)
BRICK_COLOR = (0.20, 0.45, 0.85)
HINGE_COLOR = (0.85, 0.25, 0.20)
PASSIVE_COLOR = (0.60, 0.35, 0.75)
BAR_COLOR = (0.30, 0.70, 0.40)
SENSOR_COLOR = (0.15, 0.15, 0.15)

PERIOD = 1.0  # seconds; a RoboGen-sized servo comfortably follows +-45 deg at 1 Hz


def _core(children: dict[int, Node]) -> Node:
    """The core with its six IMU input neurons (ids ``imu_<name>``)."""
    inputs = tuple(
        Neuron(f"imu_{name}", Layer.INPUT, Activation.INPUT)
        for name in PART_SPECS[PartType.CORE].input_names
    )
    return Node(PartType.CORE, 0, (), CORE_COLOR, inputs, tuple(sorted(children.items())))


def _osc(nid: str, phase: float, amplitude: float = 1.0, layer: Layer = Layer.OUTPUT) -> Neuron:
    return Neuron(nid, layer, Activation.OSCILLATOR, period=PERIOD, phase_offset=phase % 1.0,
                  amplitude=amplitude)


def _hinge(nid: str, orientation: int, phase: float, child: Node | None = None,
           amplitude: float = 1.0) -> Node:
    """An active hinge driven by an oscillator output neuron ``nid``."""
    kids = ((1, child),) if child is not None else ()
    return Node(PartType.ACTIVE_HINGE, orientation, (), HINGE_COLOR,
                (_osc(nid, phase, amplitude),), kids)


def _brick(orientation: int = 0, children: dict[int, Node] | None = None) -> Node:
    return Node(PartType.BRICK, orientation, (), BRICK_COLOR, (),
                tuple(sorted((children or {}).items())))


def spider() -> Robot:
    """Core with four two-hinge legs (17 parts, 8 servos), walking about 1.6 m in 12 s."""
    # Hip and knee both pitch, so each leg can lift its foot and push the body. The phases
    # (fractions of the 1 s period; hip, knee per leg) were found by a short CMA-ES search on
    # this body in the project's world (12 s evaluation: f = 10.2, s = 1.63 m). Gaits with yaw
    # hips drag the flat legs over the ground and barely move this robot.
    phases = {"front": (0.287, 0.355), "left": (0.763, 0.531), "back": (0.091, 0.014),
              "right": (0.984, 0.410)}
    legs = {}
    for slot, name in ((0, "front"), (1, "left"), (2, "back"), (3, "right")):
        hip_phase, knee_phase = phases[name]
        knee = _hinge(f"{name}_knee", 0, knee_phase, _brick())
        legs[slot] = _hinge(f"{name}_hip", 0, hip_phase, _brick(0, {1: knee}))
    return Robot(_core(legs), (), "spider")


def gecko() -> Robot:
    """Front legs, a two-segment bending spine and hind legs (13 parts, 6 servos)."""
    hind = _brick(0, {
        2: _hinge("hind_left", 0, 0.25, _brick()),
        3: _hinge("hind_right", 0, 0.75, _brick()),
    })
    spine = _hinge("spine_front", 90, 0.5, _brick(0, {1: _hinge("spine_back", 90, 0.75, hind)}))
    body = _core({
        1: _hinge("front_left", 0, 0.5, _brick()),
        2: spine,
        3: _hinge("front_right", 0, 0.5, _brick()),
    })
    return Robot(body, (), "gecko")


def snake(n_hinges: int = 6) -> Robot:
    """A chain of ``n_hinges`` active hinges behind the core, alternating pitch and yaw.

    Args:
        n_hinges: Hinges in the chain, 1 to 10 (the output limit).
    """
    if not 1 <= n_hinges <= 10:
        raise ValueError(f"n_hinges must be in 1..10, got {n_hinges}")
    # Build from the tail forwards. Along each axis the wave travels tail-wards, a fifth of a
    # period per segment; the yaw wave lags the pitch wave by a quarter period (sidewinding).
    node: Node = _brick()
    for i in reversed(range(n_hinges)):
        pitch = i % 2 == 0
        k = i // 2
        phase = 0.2 * k if pitch else 0.2 * k + 0.25
        node = _hinge(f"{'pitch' if pitch else 'yaw'}_{k}", 0 if pitch else 90, phase, node,
                      amplitude=0.6 if pitch else 1.0)
    return Robot(_core({2: node}), (), "snake")


def sensor_crawler() -> Robot:
    """Light sensor in front, two pitch legs and a steering tail with a touch sensor underneath.

    The tail's output is a sigmoid of a hidden oscillator plus the light reading and the
    difference of the two touch readings, so light shifts the tail's swing (steering).
    """
    light = Node(PartType.LIGHT_SENSOR, 0, (), SENSOR_COLOR,
                 (Neuron("light", Layer.INPUT, Activation.INPUT),))
    touch = Node(PartType.TOUCH_SENSOR, 0, (), SENSOR_COLOR, (
        Neuron("touch_left", Layer.INPUT, Activation.INPUT),
        Neuron("touch_right", Layer.INPUT, Activation.INPUT),
    ))
    # The tail hinge's orientation 90 turns its child's frame so that the foot brick's slot 3
    # faces down: the touch sensor feels the ground.
    tail_foot = _brick(0, {3: touch})
    tail = Node(PartType.ACTIVE_HINGE, 90, (), HINGE_COLOR, (
        Neuron("tail", Layer.OUTPUT, Activation.SIGMOID, bias=1.5, gain=3.0),
        _osc("tail_rhythm", 0.0, layer=Layer.HIDDEN),
    ), ((1, tail_foot),))
    body = _core({
        0: light,
        1: _hinge("left_leg", 0, 0.5, _brick()),
        2: tail,
        3: _hinge("right_leg", 0, 0.75, _brick()),
    })
    connections = (
        Connection("tail_rhythm", "tail", 2.0),
        Connection("light", "tail", 1.0),
        Connection("touch_left", "tail", 0.5),
        Connection("touch_right", "tail", -0.5),
    )
    return Robot(body, connections, "sensor_crawler")


def bar_walker() -> Robot:
    """Legs made of parametric bars on active hinges, and a passive hinge dragging a brick.

    The side legs swing about vertical axes with bars tilted down to the ground; the front leg
    pitches up and down, unloading the side feet while they swing forward. The back carries a
    passive hinge with a brick that drags along as a tail.
    """
    def bar(length: float, tilt: float, rotation: float = 0.0) -> Node:
        return Node(PartType.PARAMETRIC_BAR, 0, (length, tilt, rotation), BAR_COLOR)

    tail = Node(PartType.PASSIVE_HINGE, 0, (), PASSIVE_COLOR, (), ((1, _brick()),))
    body = _core({
        0: _hinge("front_leg", 0, 0.75, bar(0.05, -30.0)),
        1: _hinge("left_leg", 90, 0.0, bar(0.05, -30.0)),
        2: tail,
        3: _hinge("right_leg", 90, 0.5, bar(0.05, -30.0)),
    })
    return Robot(body, (), "bar_walker")


EXAMPLES: dict[str, Callable[[], Robot]] = {
    "spider": spider,
    "gecko": gecko,
    "snake": snake,
    "sensor_crawler": sensor_crawler,
    "bar_walker": bar_walker,
}
"""Example robot builders by name."""


def example(name: str) -> Robot:
    """The example robot called ``name`` (one of :data:`EXAMPLES`)."""
    try:
        return EXAMPLES[name]()
    except KeyError:
        raise ValueError(
            f"unknown example robot {name!r}; known: {', '.join(EXAMPLES)}"
        ) from None


def resolve_robot(robot: Robot | str | os.PathLike[str],
                  limits: Limits | None = None) -> tuple[Robot, str]:
    """A robot given by value, example name or JSON file path, validated; and a short name.

    The one rule for ``robot=`` arguments and the command line's robot argument: a name of
    :data:`EXAMPLES` is that example unless a file of that name exists (a file wins); any other
    text or path is a robot JSON file (:func:`~revolve_env.body.serialize.load`).

    Args:
        robot: A :class:`~revolve_env.body.robot.Robot`, an example name (``"spider"``) or the
            path of a robot JSON file.
        limits: Validation limits (``None``: the defaults).

    Returns:
        ``(robot, name)``: the name is the example's name, the file's stem, or the robot's own.

    Raises:
        ValueError: one line: no such file and no such example (the examples named), or a robot
            that breaks a rule (:class:`~revolve_env.body.validate.RobotError`).
        TypeError: ``robot`` is none of the three.
        OSError: the file exists but cannot be read.
    """
    if isinstance(robot, Robot):
        validate(robot, limits)
        return robot, robot.name
    if not isinstance(robot, (str, os.PathLike)):
        raise TypeError("robot must be a Robot, an example name or a path to its JSON, got "
                        f"{type(robot).__name__}")
    path = Path(robot)
    if isinstance(robot, str) and robot in EXAMPLES and not path.exists():
        made = EXAMPLES[robot]()
        validate(made, limits)
        return made, robot
    if not path.is_file():
        raise ValueError(f"no such robot file: {path} (nor an example robot: "
                         f"{', '.join(EXAMPLES)})")
    return load(path, limits), path.stem
