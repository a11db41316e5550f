"""Robot JSON under hostile or damaged input: one-line RobotErrors, never a deeper traceback.

Covers deep nesting (through ``from_json``, ``from_dict``, ``load`` and ``to_json``), files and
bytes that are not UTF-8, lone surrogates in names and ids, wrong types and huge sizes, and a
hypothesis fuzz test that damages a valid document in those ways and asserts that only
:class:`RobotError` escapes (and that whatever is accepted can be saved again).
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from revolve_env.body import (
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
from revolve_env.body.robot import Connection, Node, PartType
from revolve_env.body.serialize import MAX_JSON_BYTES, MAX_JSON_DEPTH

DOC = to_dict(example("sensor_crawler"))  # has connections, neurons and children


def _one_line(exc: BaseException) -> str:
    text = str(exc)
    assert text and "\n" not in text
    return text


def _names_file(exc: BaseException, path: Path) -> bool:
    """The file is in a note, which ``revolve show/export`` print before the one-line message."""
    return any(str(path) in note for note in getattr(exc, "__notes__", []))


def _chain_text(depth: int) -> str:
    """A core with ``depth`` bricks in a chain below it, as JSON built without recursion."""
    head = '{"schema": "revolve-env/robot", "version": 1, "body": {"type": "core"'
    return (head + ', "children": [{"slot": 0, "type": "brick"' * depth
            + "}]" * depth + "}}")


def _chain(depth: int) -> Robot:
    node = Node(PartType.BRICK)
    for _ in range(depth - 1):
        node = Node(PartType.BRICK, children=((0, node),))
    return Robot(Node(PartType.CORE, children=((0, node),)))


# --- depth ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("depth", [900, 5_000, 100_000])
def test_deeply_nested_arrays_are_refused_without_recursion_error(depth: int) -> None:
    text = json.dumps(DOC)[:-1] + ', "extra": ' + "[" * depth + "]" * depth + "}"
    with pytest.raises(RobotError) as info:
        from_json(text)
    assert info.value.rule == "json-depth" and f"nested {depth + 1} levels" in _one_line(info.value)


@pytest.mark.parametrize("depth", [150, 1_000])
def test_deeply_nested_bodies_are_refused_through_json_load_and_dict(depth: int,
                                                                      tmp_path: Path) -> None:
    text = _chain_text(depth)
    with pytest.raises(RobotError) as info:
        from_json(text)
    assert info.value.rule == "json-depth"
    path = tmp_path / "deep.json"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(RobotError) as info:
        load(path)
    assert info.value.rule == "json-depth" and _names_file(info.value, path)
    # Parsed data handed to from_dict never went through the text check.
    data: dict[str, Any] = {"type": "brick"}
    for _ in range(depth - 1):
        data = {"type": "brick", "children": [{**data, "slot": 0}]}
    doc = {"schema": "revolve-env/robot", "version": 1,
           "body": {"type": "core", "children": [{**data, "slot": 0}]}}
    with pytest.raises(RobotError) as info:
        from_dict(doc)
    assert info.value.rule == "json-depth" and len(_one_line(info.value)) < 200


def test_a_body_too_deep_for_json_is_refused_by_to_json_and_save(tmp_path: Path) -> None:
    path = tmp_path / "old.json"
    path.write_text("keep me", encoding="utf-8")
    with pytest.raises(RobotError) as info:
        save(_chain(MAX_JSON_DEPTH), path)
    assert info.value.rule == "json-depth"
    assert path.read_text(encoding="utf-8") == "keep me"


def test_the_deepest_allowed_chain_round_trips() -> None:
    depth = (MAX_JSON_DEPTH - 3) // 2  # to_json writes 2 depth + 3 levels for such a chain
    robot = _chain(depth)
    assert depth == 98
    assert from_json(to_json(robot), check=False) == robot
    assert hash(from_json(to_json(robot, indent=None), check=False)) == hash(robot)
    with pytest.raises(RobotError) as info:
        to_json(_chain(depth + 1))
    assert info.value.rule == "json-depth"


# --- encodings -----------------------------------------------------------------------------------
@pytest.mark.parametrize("raw", [
    b'{"name": "\xff"}',
    "{\"name\": \"caf\u00e9\"}".encode("latin-1"),
    b"\xc3\x28",
    b'{"schema": "revolve-env/robot", "name": "\xed\xa0\x80"}',  # a surrogate coded as UTF-8
])
def test_files_and_bytes_that_are_not_utf8_are_refused(raw: bytes, tmp_path: Path) -> None:
    with pytest.raises(RobotError) as info:
        from_json(raw)
    assert info.value.rule == "json-encoding" and "not UTF-8" in _one_line(info.value)
    path = tmp_path / "latin.json"
    path.write_bytes(raw)
    with pytest.raises(RobotError) as info:
        load(path)
    assert info.value.rule == "json-encoding"
    assert _names_file(info.value, path) and "offset" in _one_line(info.value)


def test_utf16_bytes_are_read_as_json_allows() -> None:
    text = to_json(example("gecko"))
    assert from_json(text.encode("utf-16")) == example("gecko")


# --- lone surrogates -----------------------------------------------------------------------------
@pytest.mark.parametrize(("edit", "where"), [
    (lambda d: d.update(name="spi\ud800der"), "name"),
    (lambda d: d["body"]["neurons"][0].update(id="\udfff"), "body.neurons[0].id"),
    (lambda d: d["connections"][0].update(src="a\udc80"), "connections[0].src"),
])
def test_lone_surrogates_are_refused_on_reading(edit: Any, where: str) -> None:
    doc = json.loads(json.dumps(DOC))
    edit(doc)
    for text in (json.dumps(doc), json.dumps(doc, ensure_ascii=False)):
        with pytest.raises(RobotError) as info:
            from_json(text)
        assert info.value.rule == "json-text" and f"{where}: " in _one_line(info.value)


def test_a_name_with_a_lone_surrogate_is_refused_at_construction() -> None:
    with pytest.raises(RobotError) as info:
        replace(example("spider"), name="x\ud800")
    assert info.value.rule == "json-text" and "\\ud800" in _one_line(info.value)
    assert replace(example("spider"), name="caf\u00e9 \U0001f577").name.endswith("\U0001f577")


def test_saving_an_id_with_a_lone_surrogate_fails_cleanly_and_keeps_the_file(
    tmp_path: Path,
) -> None:
    path = tmp_path / "spider.json"
    save(example("spider"), path)
    before = path.read_bytes()
    bad = replace(example("spider"), connections=(Connection("\ud800", "b", 1.0),))
    with pytest.raises(RobotError) as info:
        save(bad, path)
    assert info.value.rule == "json-text"
    assert path.read_bytes() == before


# --- sizes and types -----------------------------------------------------------------------------
def test_huge_files_are_refused_before_they_are_read(tmp_path: Path) -> None:
    path = tmp_path / "huge.json"
    with open(path, "wb") as f:
        f.truncate(4 * MAX_JSON_BYTES)  # sparse: costs no disk
    with pytest.raises(RobotError) as info:
        load(path)
    assert info.value.rule == "json-size" and _names_file(info.value, path)
    with pytest.raises(RobotError) as info:
        from_json(" " * (MAX_JSON_BYTES + 1))
    assert info.value.rule == "json-size"


@pytest.mark.parametrize(("edit", "rule"), [
    (lambda d: d.update(version=10**5000), "json-syntax"),  # too many digits to parse
    (lambda d: d["body"].update(orientation=10**300), None),
    (lambda d: d["body"].update(params=[1e300] * 10_000), None),
    (lambda d: d["body"]["children"][0].update(slot=-(10**40)), None),
    (lambda d: d["connections"].extend(d["connections"] * 2_000), None),
    (lambda d: d.update(name="x" * 1_000_000), None),
    (lambda d: d["body"]["neurons"].extend([{"id": str(i), "layer": "hidden",
                                             "activation": "linear"} for i in range(5_000)]), None),
])
def test_huge_values_and_counts_give_one_line_errors(edit: Any, rule: str | None) -> None:
    doc = json.loads(json.dumps(DOC))
    edit(doc)
    text = json.dumps(doc) if rule != "json-syntax" else json.dumps(DOC).replace(
        '"version": 1', '"version": 1' + "0" * 5000)
    try:
        from_json(text)
    except RobotError as exc:
        _one_line(exc)
        assert rule is None or exc.rule == rule
    else:  # a long name is fine: it is valid and can be written back
        assert rule is None
        to_json(from_json(text))


@pytest.mark.parametrize("value", [None, True, 1, 1.5, "x", [], {}, [[1]], {"a": {}}])
@pytest.mark.parametrize("key", ["name", "version", "body", "connections", "schema"])
def test_wrong_types_at_the_top_level_are_named(key: str, value: object) -> None:
    doc = dict(DOC)
    doc[key] = value
    try:
        robot = from_json(json.dumps(doc))
    except RobotError as exc:
        assert key in _one_line(exc) or exc.rule.startswith(("json-", "max-"))
    else:
        to_json(robot)


# --- fuzzing -------------------------------------------------------------------------------------
_TEXT = st.text(st.characters(codec=None, min_codepoint=0, max_codepoint=0x10FFFF), max_size=12)
_LEAVES = st.one_of(
    st.none(), st.booleans(), st.integers(-(10**30), 10**30), st.integers(-2, 300),
    st.floats(allow_nan=False, allow_infinity=False), st.floats(-5, 5), _TEXT,
    st.sampled_from(["core", "brick", "active_hinge", "input", "hidden", "output", "linear",
                     "sigmoid", "oscillator", "revolve-env/robot", "\ud800", "\udfff"]),
)
_VALUES = st.recursive(
    _LEAVES,
    lambda inner: st.one_of(st.lists(inner, max_size=4),
                            st.dictionaries(st.sampled_from(
                                ["type", "slot", "id", "children", "neurons", "src", "x", "\ud801"]
                            ), inner, max_size=4)),
    max_leaves=12,
)


def _locations(doc: Any) -> list[tuple[Any, Any]]:
    """Every (container, key) pair inside ``doc``, found without recursion."""
    found: list[tuple[Any, Any]] = []
    stack = [doc]
    while stack:
        c = stack.pop()
        keys = list(c) if isinstance(c, dict) else range(len(c)) if isinstance(c, list) else []
        for k in keys:
            found.append((c, k))
            stack.append(c[k])
    return found


@st.composite
def damaged_documents(draw: st.DrawFn) -> bytes:
    """A valid robot document with a few values replaced, deep nesting added, and/or coded in
    another encoding or cut short."""
    doc = json.loads(json.dumps(DOC))
    for _ in range(draw(st.integers(0, 3))):
        container, key = draw(st.sampled_from(_locations(doc)))
        if draw(st.booleans()):
            container[key] = draw(_VALUES)
        elif isinstance(container, dict):
            del container[key]
    text = json.dumps(doc, ensure_ascii=draw(st.booleans()))
    if draw(st.booleans()):
        depth = draw(st.sampled_from([1, 10, 199, 200, 201, 950, 3_000]))
        text = text[:-1] + ', "x": ' + "[" * depth + "]" * depth + "}"
    if draw(st.booleans()):
        text = text[: draw(st.integers(0, len(text)))]
    codec = draw(st.sampled_from(["utf-8", "utf-16", "utf-32", "latin-1", "cp1252", "raw"]))
    if codec == "raw":
        raw = text.encode("utf-8", "surrogatepass")
        at = draw(st.integers(0, len(raw)))
        return raw[:at] + draw(st.binary(max_size=6)) + raw[at:]
    return text.encode(codec, "surrogatepass" if codec.startswith("utf") else "replace")


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(damaged_documents())
def test_only_robot_errors_escape_and_accepted_robots_can_be_saved(raw: bytes) -> None:
    for doc in (raw, raw.decode("utf-8", "replace")):
        try:
            robot = from_json(doc)
        except RobotError as exc:
            _one_line(exc)
        else:
            to_json(robot)  # whatever is accepted can be written back


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(raw=damaged_documents())
def test_only_robot_errors_escape_from_load(raw: bytes,
                                            tmp_path_factory: pytest.TempPathFactory) -> None:
    path = tmp_path_factory.mktemp("fuzz") / "robot.json"
    path.write_bytes(raw)
    try:
        robot = load(path)
    except RobotError as exc:
        _one_line(exc)
        assert _names_file(exc, path)
    else:
        save(robot, path)
        assert load(path) == robot
