"""Robot JSON: exact round trips, strict reading with errors that name the JSON path."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from strategies import robots

from revolve_env.body import (
    EXAMPLES,
    SCHEMA,
    SCHEMA_VERSION,
    Limits,
    Robot,
    RobotError,
    example,
    from_dict,
    from_json,
    load,
    save,
    to_dict,
    to_json,
)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(robots())
def test_json_round_trip_is_exact(robot: Robot) -> None:
    text = to_json(robot)
    back = from_json(text)
    assert back == robot
    assert hash(back) == hash(robot)
    assert to_json(back) == text  # the writer is deterministic
    assert from_json(to_json(robot, indent=None)) == robot
    assert from_json(to_json(robot)) == robot


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(robots(max_parts=4))
def test_floats_survive_bit_for_bit(robot: Robot) -> None:
    back = from_json(to_json(robot))
    for (_, a), (_, b) in zip(robot.walk(), back.walk(), strict=True):
        assert [p.hex() for p in a.params] == [p.hex() for p in b.params]
        assert [c.hex() for c in a.color] == [c.hex() for c in b.color]
        for na, nb in zip(a.neurons, b.neurons, strict=True):
            assert [getattr(na, k).hex() for k in ("bias", "gain", "period")] == \
                   [getattr(nb, k).hex() for k in ("bias", "gain", "period")]
    assert [c.weight.hex() for c in robot.connections] == [c.weight.hex() for c in back.connections]


@pytest.mark.parametrize("name", list(EXAMPLES))
def test_examples_round_trip_through_files(name: str, tmp_path: Path) -> None:
    robot = example(name)
    path = tmp_path / f"{name}.json"
    save(robot, path)
    assert load(path) == robot
    data = json.loads(path.read_text(encoding="utf-8"))
    assert data["schema"] == SCHEMA and data["version"] == SCHEMA_VERSION
    assert data["name"] == name


def test_optional_keys_take_documented_defaults() -> None:
    text = json.dumps({
        "schema": SCHEMA, "version": 1,
        "body": {"type": "core", "neurons": [
            {"id": f"i{k}", "layer": "input", "activation": "input"} for k in range(6)]},
    })
    robot = from_json(text)
    assert robot.name == "" and robot.connections == ()
    assert robot.body.orientation == 0 and robot.body.params == ()
    assert robot.body.color == (0.7, 0.7, 0.7)
    assert robot.body.neurons[0].gain == 1.0 and robot.body.neurons[0].period == 1.0


def test_integers_are_accepted_where_numbers_are_expected() -> None:
    data = to_dict(example("bar_walker"))
    data["connections"] = [{"src": "imu_gyro_z", "dst": "front_leg", "weight": 1}]
    robot = from_dict(data)
    assert robot.connections[0].weight == 1.0
    assert isinstance(robot.connections[0].weight, float)


Mutation = Callable[[dict[str, Any]], None]


def _set(path: str, value: object) -> Mutation:
    """Set the value at a dotted path such as ``body.children.2.type``."""
    def mutate(data: dict[str, Any]) -> None:
        *head, last = path.split(".")
        target: Any = data
        for key in head:
            target = target[int(key)] if isinstance(target, list) else target[key]
        if isinstance(target, list):
            target[int(last)] = value
        else:
            target[last] = value
    return mutate


def _drop(path: str) -> Mutation:
    def mutate(data: dict[str, Any]) -> None:
        *head, last = path.split(".")
        target: Any = data
        for key in head:
            target = target[int(key)] if isinstance(target, list) else target[key]
        del target[last]
    return mutate


# (mutation of the sensor_crawler's JSON, rule, text the message must contain)
MALFORMED: dict[str, tuple[Mutation, str, str]] = {
    "unknown part type": (_set("body.children.2.type", "wheel"), "json-unknown-value",
                          "body.children[2].type: unknown part type 'wheel'"),
    "missing type": (_drop("body.children.1.type"), "json-missing", "body.children[1].type"),
    "missing slot": (_drop("body.children.0.slot"), "json-missing", "body.children[0].slot"),
    "missing body": (_drop("body"), "json-missing", "body: missing"),
    "missing weight": (_drop("connections.0.weight"), "json-missing", "connections[0].weight"),
    "unknown key": (_set("body.children.1.colour", [0, 0, 0]), "json-unknown-key",
                    "body.children[1].colour: unknown key"),
    "slot on the root": (_set("body.slot", 0), "json-unknown-key", "body.slot"),
    "orientation as text": (_set("body.children.0.orientation", "90"), "json-type",
                            "body.children[0].orientation: expected an integer, got a string"),
    "orientation as float": (_set("body.children.0.orientation", 90.0), "json-type",
                             "body.children[0].orientation"),
    "slot as boolean": (_set("body.children.0.slot", True), "json-type",
                        "expected an integer, got a boolean"),
    "weight as boolean": (_set("connections.0.weight", True), "json-type",
                          "connections[0].weight: expected a number, got a boolean"),
    "bias as text": (_set("body.children.2.neurons.0.bias", "high"), "json-type",
                     "body.children[2].neurons[0].bias: expected a number"),
    "params not an array": (_set("body.children.0.params", 3), "json-type",
                            "body.children[0].params: expected an array"),
    "children not an array": (_set("body.children", {}), "json-type", "body.children"),
    "node not an object": (_set("body.children.1", 7), "json-type",
                           "body.children[1]: expected an object, got an integer"),
    "neuron id not a string": (_set("body.neurons.0.id", 3), "json-type", "body.neurons[0].id"),
    "unknown layer": (_set("body.neurons.0.layer", "middle"), "json-unknown-value",
                      "body.neurons[0].layer: unknown layer 'middle'"),
    "unknown activation": (_set("body.children.2.neurons.0.activation", "relu"),
                           "json-unknown-value", "unknown activation 'relu'"),
    "two colour values": (_set("body.color", [0.1, 0.2]), "json-value", "body.color"),
    "colour value null": (_set("body.color", [0.1, None, 0.2]), "json-type",
                          "body.color[1]: expected a number, got null"),
    "wrong schema": (_set("schema", "robogen"), "json-schema", "schema"),
    "newer version": (_set("version", SCHEMA_VERSION + 1), "json-version", "newer revolve-env"),
    "version zero": (_set("version", 0), "json-version", "unknown version 0"),
    "version as text": (_set("version", "1"), "json-type", "version"),
    "name not a string": (_set("name", 5), "json-type", "name"),
    "connections not an array": (_set("connections", {"a": 1}), "json-type", "connections"),
    # Well-formed JSON describing an invalid robot: validation names the rule.
    "slot out of range": (_set("body.children.0.slot", 7), "slot", "no child slot 7"),
    "weight out of range": (_set("connections.0.weight", 3.5), "connection-weight", "3.5"),
    "missing neuron": (_set("connections.0.src", "ghost"), "connection-ref", "'ghost'"),
}


@pytest.mark.parametrize("case", list(MALFORMED))
def test_malformed_json_names_the_problem(case: str) -> None:
    mutate, rule, fragment = MALFORMED[case]
    data = to_dict(example("sensor_crawler"))
    mutate(data)
    with pytest.raises(RobotError) as info:
        from_json(json.dumps(data))
    assert info.value.rule == rule, str(info.value)
    assert fragment in str(info.value)


def test_unknown_part_type_error_names_the_part_path() -> None:
    data = to_dict(example("sensor_crawler"))
    data["body"]["children"][2]["children"][0]["type"] = "wheel"
    with pytest.raises(RobotError) as info:
        from_json(json.dumps(data))
    assert info.value.path == (2, 1)
    assert "body.children[2].children[0].type" in str(info.value)


_CORE_DOC = '{"schema": "revolve-env/robot", "version": 1, "body": {"type": "core", '


@pytest.mark.parametrize(("text", "rule"), [
    ("{ not json", "json-syntax"),
    ("", "json-syntax"),
    ("[1, 2]", "json-type"),
    ("null", "json-type"),
    (_CORE_DOC + '"params": [NaN]}}', "json-number"),
    (_CORE_DOC + '"color": [Infinity, 0, 0]}}', "json-number"),
    (_CORE_DOC + '"color": [1e999, 0, 0]}}', "json-number"),
    (_CORE_DOC + '"color": [1' + "0" * 400 + ", 0, 0]}}", "json-number"),  # too large for a float
    (_CORE_DOC + '"orientation": 0, "orientation": 90}}', "json-duplicate-key"),  # not "last wins"
])
def test_non_json_and_non_finite_numbers_are_rejected(text: str, rule: str) -> None:
    with pytest.raises(RobotError) as info:
        from_json(text)
    assert info.value.rule == rule


def test_writing_a_nan_is_refused() -> None:
    robot = example("spider")
    bad = robot.replace_node((0,), replace(robot.node((0,)), color=(math.nan, 0.0, 0.0)))
    with pytest.raises(RobotError) as info:
        to_json(bad)
    assert info.value.rule == "json-number"


def test_writing_a_value_json_cannot_hold_is_a_robot_error() -> None:
    robot = example("spider")
    bad = replace(robot, body=replace(robot.body, orientation=np.int64(0)))
    with pytest.raises(RobotError) as info:
        to_json(bad)
    assert info.value.rule == "json-type"


def test_reading_validates_with_overridable_limits() -> None:
    text = to_json(example("spider"))
    with pytest.raises(RobotError) as info:
        from_json(text, Limits(max_parts=10))
    assert info.value.rule == "max-parts"
    assert from_json(text, Limits(max_parts=17)) == example("spider")
    assert from_json(text, Limits(max_outputs=8)) == example("spider")


def test_invalid_robot_is_refused_unless_check_is_off(tmp_path: Path) -> None:
    from test_body_validate import overlapping_ring

    robot = overlapping_ring()
    text = to_json(robot)  # writing does not validate
    with pytest.raises(RobotError) as info:
        from_json(text)
    assert info.value.rule == "overlap"
    assert from_json(text, check=False) == robot
    path = tmp_path / "ring.json"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(RobotError) as info:
        load(path)
    assert any(str(path) in note for note in getattr(info.value, "__notes__", []))
    assert load(path, check=False) == robot
