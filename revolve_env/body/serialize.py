r"""Robot descriptions as JSON: a documented, versioned schema with exact round trips.

The schema (``"schema": "revolve-env/robot"``, ``"version": 1``) is described in
``docs/robot-json-schema.md``. In short::

    {"schema": "revolve-env/robot", "version": 1, "name": "spider",
     "body": {"type": "core", "orientation": 0, "params": [], "color": [r, g, b],
              "neurons": [{"id": ..., "layer": ..., "activation": ..., "bias": ..., ...}],
              "children": [{"slot": 0, "type": "active_hinge", ...}, ...]},
     "connections": [{"src": "a", "dst": "b", "weight": 0.5}, ...]}

Floats are written with Python's shortest round-trip representation, so
``from_json(to_json(r)) == r`` holds exactly. Reading is strict: unknown or repeated keys, wrong
types, unknown part types, NaN or infinite numbers and unknown schema versions are errors naming
the JSON path of the problem (e.g. ``body.children[2].type``; a repeated key is named by key), and
the result is validated (limits included) before it is returned. Every error raised here is a
:class:`~revolve_env.body.validate.RobotError`.

Hostile or damaged input gets the same one-line :class:`~revolve_env.body.validate.RobotError`,
never a traceback from deeper down: a document larger than :data:`MAX_JSON_BYTES` (rule
``json-size``), nested deeper than :data:`MAX_JSON_DEPTH` (``json-depth``; the standard parser and
any recursive reader would raise ``RecursionError`` at about 1,000 levels), bytes or a file that
are not UTF-8 (``json-encoding``), and text that UTF-8 cannot hold, such as a name or id with a
lone surrogate (``"\ud800"`` escapes; rule ``json-text``), refused on reading so that a robot once
loaded can always be saved.
"""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Mapping
from dataclasses import fields
from itertools import accumulate
from typing import Any, TypeVar

from revolve_env.body.files import FileTooLargeError, NotARegularFileError, read_text
from revolve_env.body.robot import (
    Activation,
    Connection,
    Layer,
    Neuron,
    Node,
    PartType,
    Path,
    Robot,
)
from revolve_env.body.validate import Limits, RobotError, validate

__all__ = [
    "MAX_JSON_BYTES",
    "MAX_JSON_DEPTH",
    "SCHEMA",
    "SCHEMA_VERSION",
    "NotARegularFileError",
    "from_dict",
    "from_json",
    "load",
    "save",
    "to_dict",
    "to_json",
]

SCHEMA = "revolve-env/robot"
"""Value of the top-level ``"schema"`` key."""

SCHEMA_VERSION = 1
"""Version written by this code; files with a higher version are refused."""

MAX_JSON_BYTES = 8 * 1024 * 1024
"""Largest robot document read, in bytes of UTF-8 (characters for a ``str``). A 30-part robot
with a full brain takes some 30 KB, so this refuses only damaged or hostile files, before they
are parsed."""

MAX_JSON_DEPTH = 200
"""Deepest nesting of arrays and objects read or written. Each part below the core adds two
levels (its parent's ``children`` array and its own object), so this allows a chain of 98 parts,
three times the default ``Limits.max_parts``. The bound is what the rest of the library can take:
the parser, the reader, and the robot's own (recursive) equality and hashing would reach Python's
recursion limit at a chain of some 190 parts."""

_NEURON_FLOATS = ("bias", "gain", "period", "phase_offset", "amplitude")
_NEURON_DEFAULTS = {f.name: f.default for f in fields(Neuron) if f.name in _NEURON_FLOATS}
_TOP_KEYS = {"schema": True, "version": True, "name": False, "body": True, "connections": False}
_NODE_KEYS = {"type": True, "orientation": False, "params": False, "color": False, "neurons": False,
              "children": False}
_CHILD_KEYS = {**_NODE_KEYS, "slot": True}
_NEURON_KEYS = {"id": True, "layer": True, "activation": True, **{k: False for k in _NEURON_FLOATS}}
_CONNECTION_KEYS = {"src": True, "dst": True, "weight": True}
_DEFAULT_COLOR = Node(PartType.CORE).color

_E = TypeVar("_E", PartType, Layer, Activation)


# --- writing -----------------------------------------------------------------------------------
def _node_to_dict(node: Node, slot: int | None) -> dict[str, Any]:
    d: dict[str, Any] = {} if slot is None else {"slot": slot}
    d["type"] = PartType(node.type).value
    d["orientation"] = node.orientation
    d["params"] = [float(p) for p in node.params]
    d["color"] = [float(c) for c in node.color]
    d["neurons"] = [
        {
            "id": nr.id,
            "layer": Layer(nr.layer).value,
            "activation": Activation(nr.activation).value,
            **{k: float(getattr(nr, k)) for k in _NEURON_FLOATS},
        }
        for nr in node.neurons
    ]
    d["children"] = [_node_to_dict(child, s) for s, child in node.children]
    return d


def to_dict(robot: Robot) -> dict[str, Any]:
    """The robot as plain JSON-compatible data (the schema's top-level object)."""
    return {
        "schema": SCHEMA,
        "version": SCHEMA_VERSION,
        "name": robot.name,
        "body": _node_to_dict(robot.body, None),
        "connections": [
            {"src": c.src, "dst": c.dst, "weight": float(c.weight)} for c in robot.connections
        ],
    }


def to_json(robot: Robot, *, indent: int | None = 1) -> str:
    """The robot as a JSON document (schema ``revolve-env/robot`` version 1).

    Args:
        robot: The robot. It is not validated, but every number must be finite.
        indent: Passed to :func:`json.dumps`; None gives a single line.

    Raises:
        RobotError: if a number is NaN or infinite (JSON cannot hold it), a string holds text
            that UTF-8 cannot encode (a lone surrogate), or the parts are nested deeper than
            :data:`MAX_JSON_DEPTH` allows.
    """
    depth = _tree_depth(robot.body)
    if 2 * depth + 3 > MAX_JSON_DEPTH:  # the document's depth; to_dict and dumps recurse
        raise RobotError(f"parts nested {depth} deep, deeper than {MAX_JSON_DEPTH} levels of "
                         "JSON allow", rule="json-depth")
    try:
        text = json.dumps(to_dict(robot), indent=indent, allow_nan=False, ensure_ascii=False)
    except ValueError as exc:
        raise RobotError(f"cannot be written as JSON: {exc}", rule="json-number") from exc
    except TypeError as exc:  # e.g. a NumPy integer where the schema holds a plain int
        raise RobotError(f"cannot be written as JSON: {exc}", rule="json-type") from exc
    bad = _first_unencodable(text)
    if bad is not None:
        raise RobotError(f"cannot be written as UTF-8 JSON: {bad}", rule="json-text")
    return text


def save(robot: Robot, path: str | os.PathLike[str]) -> None:
    """Write the robot's JSON to ``path`` (UTF-8).

    The document is made before the file is opened, so a robot that cannot be written (see
    :func:`to_json`) leaves an existing file untouched.

    Raises:
        RobotError: as :func:`to_json`.
    """
    data = (to_json(robot) + "\n").encode("utf-8")
    with open(path, "wb") as f:
        f.write(data)


def _tree_depth(body: Node) -> int:
    """Parts on the longest path below the core (0 for a lone core), without recursion."""
    deepest = 0
    stack = [(body, 0)]
    while stack:
        node, depth = stack.pop()
        deepest = max(deepest, depth)
        stack.extend((child, depth + 1) for _, child in node.children)
    return deepest


_SURROGATE = re.compile("[\ud800-\udfff]")


def _first_unencodable(text: str) -> str | None:
    """Where ``text`` holds a lone surrogate (UTF-8 cannot encode it), or None if it has none."""
    if text.isascii():
        return None
    m = _SURROGATE.search(text)
    if m is None:
        return None
    return f"lone surrogate {m.group()!a} at character {m.start()}"


# --- reading -----------------------------------------------------------------------------------
class _Reader:
    """Strict reader of the schema's data that names the JSON path of any problem."""

    def fail(self, where: str, message: str, rule: str, path: Path | None = None) -> RobotError:
        return RobotError(f"{where}: {message}", path=path, rule=rule)

    def obj(self, value: object, where: str, keys: Mapping[str, bool],
            path: Path | None = None) -> Mapping[str, Any]:
        if not isinstance(value, dict):
            raise self.fail(where, f"expected an object, got {_kind(value)}", "json-type", path)
        for key in value:
            if key not in keys:
                allowed = ", ".join(sorted(keys))
                raise self.fail(f"{where}.{key}", f"unknown key (allowed: {allowed})",
                                "json-unknown-key", path)
        for key, required in keys.items():
            if required and key not in value:
                raise self.fail(f"{where}.{key}", "missing", "json-missing", path)
        return value

    def list(self, value: object, where: str, path: Path | None = None) -> list[Any]:
        if not isinstance(value, list):
            raise self.fail(where, f"expected an array, got {_kind(value)}", "json-type", path)
        return value

    def number(self, value: object, where: str, path: Path | None = None) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.fail(where, f"expected a number, got {_kind(value)}", "json-type", path)
        try:
            result = float(value)
        except OverflowError:  # an integer literal too large for a float
            result = math.inf
        if not math.isfinite(result):
            raise self.fail(where, f"{value!r} is not a finite number", "json-number", path)
        return result

    def integer(self, value: object, where: str, path: Path | None = None) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(where, f"expected an integer, got {_kind(value)}", "json-type", path)
        return value

    def string(self, value: object, where: str, path: Path | None = None) -> str:
        if not isinstance(value, str):
            raise self.fail(where, f"expected a string, got {_kind(value)}", "json-type", path)
        bad = _first_unencodable(value)
        if bad is not None:  # accepted here, it would make save() fail later
            raise self.fail(where, f"text that UTF-8 cannot hold ({bad})", "json-text", path)
        return value

    def enum(self, enum: type[_E], value: object, where: str, path: Path | None) -> _E:
        text = self.string(value, where, path)
        try:
            return enum(text)
        except ValueError:
            allowed = ", ".join(e.value for e in enum)
            what = {PartType: "part type", Layer: "layer", Activation: "activation"}[enum]
            raise self.fail(where, f"unknown {what} {text!r} (known: {allowed})",
                            "json-unknown-value", path) from None

    def node(self, value: object, where: str, path: Path) -> Node:
        # from_dict takes parsed data that no depth check has seen, so recursion stops here
        # first: at the depth to_json would write (2 levels a part), named briefly (not by the
        # full JSON path, which would be hundreds of "children[0]" long).
        if 2 * len(path) + 3 > MAX_JSON_DEPTH:
            raise self.fail("body", f"parts nested {len(path)} deep, deeper than "
                            f"{MAX_JSON_DEPTH} levels of JSON allow", "json-depth")
        d = self.obj(value, where, _CHILD_KEYS if path else _NODE_KEYS, path)
        part = self.enum(PartType, d["type"], f"{where}.type", path)
        orientation = self.integer(d.get("orientation", 0), f"{where}.orientation", path)
        params = tuple(
            self.number(p, f"{where}.params[{i}]", path)
            for i, p in enumerate(self.list(d.get("params", []), f"{where}.params", path))
        )
        color_list = self.list(d.get("color", list(_DEFAULT_COLOR)), f"{where}.color", path)
        if len(color_list) != 3:
            raise self.fail(f"{where}.color",
                            f"expected 3 numbers (r, g, b), got {len(color_list)}",
                            "json-value", path)
        r, g, b = (self.number(c, f"{where}.color[{i}]", path) for i, c in enumerate(color_list))
        neurons = tuple(
            self.neuron(n, f"{where}.neurons[{i}]", path)
            for i, n in enumerate(self.list(d.get("neurons", []), f"{where}.neurons", path))
        )
        children: list[tuple[int, Node]] = []
        for i, c in enumerate(self.list(d.get("children", []), f"{where}.children", path)):
            cw = f"{where}.children[{i}]"
            cd = self.obj(c, cw, _CHILD_KEYS, path)
            slot = self.integer(cd["slot"], f"{cw}.slot", path)
            children.append((slot, self.node(cd, cw, (*path, slot))))
        return Node(part, orientation, params, (r, g, b), neurons, tuple(children))

    def neuron(self, value: object, where: str, path: Path) -> Neuron:
        d = self.obj(value, where, _NEURON_KEYS, path)
        values = {k: self.number(d.get(k, _NEURON_DEFAULTS[k]), f"{where}.{k}", path)
                  for k in _NEURON_FLOATS}
        return Neuron(
            id=self.string(d["id"], f"{where}.id", path),
            layer=self.enum(Layer, d["layer"], f"{where}.layer", path),
            activation=self.enum(Activation, d["activation"], f"{where}.activation", path),
            **values,
        )

    def connection(self, value: object, where: str) -> Connection:
        d = self.obj(value, where, _CONNECTION_KEYS)
        return Connection(
            self.string(d["src"], f"{where}.src"),
            self.string(d["dst"], f"{where}.dst"),
            self.number(d["weight"], f"{where}.weight"),
        )

    def robot(self, value: object) -> Robot:
        d = self.obj(value, "(top level)", _TOP_KEYS)
        if d["schema"] != SCHEMA:
            raise self.fail("schema", f"expected {SCHEMA!r}, got {d['schema']!r}", "json-schema")
        version = self.integer(d["version"], "version")
        if version > SCHEMA_VERSION:
            raise self.fail("version", f"version {version} was written by a newer revolve-env; "
                            f"this one reads versions up to {SCHEMA_VERSION}", "json-version")
        if version < 1:
            raise self.fail("version", f"unknown version {version}", "json-version")
        name = self.string(d.get("name", ""), "name")
        body = self.node(d["body"], "body", ())
        connections = tuple(
            self.connection(c, f"connections[{i}]")
            for i, c in enumerate(self.list(d.get("connections", []), "connections"))
        )
        return Robot(body, connections, name)


def _kind(value: object) -> str:
    if value is None:
        return "null"
    return {bool: "a boolean", int: "an integer", float: "a number", str: "a string",
            list: "an array", dict: "an object"}.get(type(value), type(value).__name__)


def from_dict(data: object, limits: Limits | None = None, *, check: bool = True) -> Robot:
    """Build a robot from the schema's top-level object (already parsed JSON).

    Args:
        data: The parsed JSON document.
        limits: Limits used by validation (default :class:`Limits`).
        check: Validate the result (default). Set False only to inspect a robot known to be bad.

    Raises:
        RobotError: naming the JSON path (and the part, if any) of the first problem.
    """
    robot = _Reader().robot(data)
    if check:
        validate(robot, limits)
    return robot


class _StrictJSONError(ValueError):
    """JSON that the standard parser accepts but the schema does not; carries the rule."""

    def __init__(self, message: str, rule: str) -> None:
        super().__init__(message)
        self.rule = rule


def _reject_constant(name: str) -> float:
    raise _StrictJSONError(
        f"{name} is not a finite number; robot JSON holds only finite numbers", "json-number"
    )


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """An object's keys, refusing a repeated key (the standard parser keeps the last silently)."""
    d: dict[str, Any] = {}
    for key, value in pairs:
        if key in d:
            raise _StrictJSONError(f"key {key!r} appears twice in one object", "json-duplicate-key")
        d[key] = value
    return d


_STRING = re.compile(r'"(?:[^"\\]|\\.)*"', re.DOTALL)
_NOT_BRACKET = re.compile(r"[^\[\]{}]+")
_NESTING = {"[": 1, "{": 1, "]": -1, "}": -1}


def _nesting_depth(text: str) -> int:
    """Deepest nesting of arrays and objects in ``text`` (strings skipped), without recursion.

    Unbalanced or malformed text gives some number; the parser reports the syntax error after.
    """
    brackets = _NOT_BRACKET.sub("", _STRING.sub("", text))
    return max(accumulate(map(_NESTING.__getitem__, brackets)), default=0)


def _decode(text: str | bytes) -> str:
    """Return ``text`` as ``str``.

    Bytes are decoded as JSON allows (UTF-8, or UTF-16/32 by their byte pattern), strictly.
    """
    if isinstance(text, str):
        return text
    if len(text) > MAX_JSON_BYTES:
        raise RobotError(f"document of {len(text)} bytes is larger than the {MAX_JSON_BYTES} "
                         "bytes a robot can take", rule="json-size")
    try:
        return bytes(text).decode(json.detect_encoding(text))
    except UnicodeDecodeError as exc:
        raise _encoding_error(exc) from None


def _encoding_error(exc: UnicodeDecodeError) -> RobotError:
    """The one-line error of bytes that do not decode, naming the first bad byte."""
    return RobotError(f"not UTF-8 text: byte {exc.object[exc.start]:#04x} at offset {exc.start} "
                      f"cannot be decoded ({exc.reason})", rule="json-encoding")


def from_json(text: str | bytes, limits: Limits | None = None, *, check: bool = True) -> Robot:
    """Parse and validate a robot written by :func:`to_json` (or by hand, following the schema).

    Args:
        text: The JSON document (``bytes`` are decoded as UTF-8, or UTF-16/32 as JSON allows).
        limits: Limits used by validation (default :class:`Limits`).
        check: Validate the result (default).

    Raises:
        RobotError: for malformed JSON (rule ``json-syntax``), a document that does not follow the
            schema (rules ``json-*``, naming the JSON path), one too large (``json-size``) or too
            deeply nested (``json-depth``), bytes that do not decode (``json-encoding``), text
            that UTF-8 cannot hold (``json-text``) or an invalid robot (validation rules).
    """
    text = _decode(text)
    if len(text) > MAX_JSON_BYTES:
        raise RobotError(f"document of {len(text)} characters is larger than the "
                         f"{MAX_JSON_BYTES} a robot can take", rule="json-size")
    depth = _nesting_depth(text)
    if depth > MAX_JSON_DEPTH:
        raise RobotError(f"arrays and objects nested {depth} levels deep (at most "
                         f"{MAX_JSON_DEPTH})", rule="json-depth")
    try:
        data = json.loads(text, parse_constant=_reject_constant, object_pairs_hook=_unique_keys)
    except _StrictJSONError as exc:
        raise RobotError(str(exc), rule=exc.rule) from exc
    except (ValueError, TypeError) as exc:
        raise RobotError(f"not valid JSON: {exc}", rule="json-syntax") from exc
    return from_dict(data, limits, check=check)


def load(
    path: str | os.PathLike[str], limits: Limits | None = None, *, check: bool = True
) -> Robot:
    """Read a robot from a UTF-8 JSON file (see :func:`from_json`).

    Raises:
        RobotError: as :func:`from_json`, with the file name in a note (``__notes__``); also
            for a file that is not UTF-8 (rule ``json-encoding``) or larger than
            :data:`MAX_JSON_BYTES` (``json-size``, refused before it is read).
        NotARegularFileError: a folder, FIFO, socket or device (an ``OSError``; a FIFO is
            refused, never waited on: :func:`revolve_env.body.files.read_bounded`'s rule).
        OSError: the file cannot be read.
    """
    name = os.fspath(path)
    try:
        try:
            text = read_text(path, MAX_JSON_BYTES)
        except FileTooLargeError:
            raise RobotError(f"file is larger than the {MAX_JSON_BYTES} bytes a robot can take",
                             rule="json-size") from None
        except UnicodeDecodeError as exc:
            raise _encoding_error(exc) from None
        return from_json(text, limits, check=check)
    except RobotError as exc:
        # A note, not the message: `revolve show/export` put the file at the start of their
        # one-line error themselves.
        exc.add_note(f"while reading {name}")
        raise
