"""Fuzzing experiment configs and ``--set`` values: only the documented errors escape.

``load_config(name, overrides)`` documents :class:`ConfigError` for every bad override; the
``revolve`` command line adds :class:`CliError` for a malformed ``--set``. Whatever the keys
and values (known or unknown keys, nested tables, booleans, huge or non-finite numbers, dates,
lists, tables, text), nothing else may escape, and what is accepted is a valid config.
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import fields
from pathlib import Path
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from evolution.cli.commands import CliError, _parse_set
from evolution.config import EvolutionConfig
from evolution.experiments import ConfigError, ExperimentConfig, load_config

# REVOLVE_FUZZ_EXAMPLES=3000 searches harder (a few minutes); the default keeps the run short.
SETTINGS = settings(max_examples=int(os.environ.get("REVOLVE_FUZZ_EXAMPLES", "150")), deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])
CONFIGS = ("quick", "scenario3", "scenario1_learning")
TOP = sorted(f.name for f in fields(ExperimentConfig) if f.name not in ("evolution", "learning"))
EVOLUTION = sorted(f.name for f in fields(EvolutionConfig))
LEARNING = ["learner", "budget", "inheritance", "insertion", "seconds", "sigma", "popsize",
            "workers", "algorithm", "policy", "algorithm_kwargs", "n_envs"]

EDGES = [True, False, None, 0, -1, 1, 2, 2**31, 2**63, 10**400, -(10**400), 0.0, -0.0, 0.5,
         1e-320, 1e308, -1e308, float("inf"), float("-inf"), float("nan"), "", "1", "inf", [],
         {}, [1], {"a": 1}]

scalars = st.one_of(
    st.sampled_from(EDGES),
    st.booleans(),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.integers(min_value=-3, max_value=40),
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(min_value=-1.0, max_value=100.0),
    st.text(max_size=12),
    st.sampled_from(["offline", "online", "fitness", "random", "local", "ray", "cma-es",
                     "random-search", "sb3", "lamarckian", "darwinian", ""]),
    st.dates(),
    st.datetimes(),
    st.times(),
)
values: st.SearchStrategy[Any] = st.recursive(
    scalars, lambda inner: st.one_of(st.lists(inner, max_size=3),
                                     st.dictionaries(st.text(max_size=6), inner, max_size=3)),
    max_leaves=6)
PATHS = (TOP + ["unknown_key", "evolution", "learning"] + [f"evolution.{k}" for k in EVOLUTION]
         + [f"learning.{k}" for k in LEARNING] + ["evolution.bogus", "learning.bogus"])


@st.composite
def overrides(draw: st.DrawFn) -> dict[str, Any]:
    """Some config keys (top-level, ``evolution.KEY``, ``learning.KEY``) set to odd values."""
    data: dict[str, Any] = {}
    for path in draw(st.lists(st.sampled_from(PATHS), max_size=5, unique=True)):
        value = draw(st.one_of(st.sampled_from(EDGES), values))
        table, _, key = path.partition(".")
        if key:
            if not isinstance(data.get(table, {}), dict):
                continue
            data.setdefault(table, {})[key] = value
        elif path not in data:
            data[path] = value
    return data


def _check(config: ExperimentConfig) -> None:
    """An accepted config is a valid one: it survives its own round trip."""
    assert ExperimentConfig.from_dict(config.to_dict()) == config


@SETTINGS
@given(name=st.sampled_from(CONFIGS), changes=overrides())
def test_load_config_raises_only_config_error(name: str, changes: dict[str, Any]) -> None:
    try:
        config = load_config(name, changes)
    except ConfigError:
        return
    _check(config)


toml_values = st.one_of(
    st.sampled_from(["true", "false", "1e309", "-inf", "nan", "0", "-1", "3.5", "1979-05-27",
                     "07:32:00", "1979-05-27T07:32:00Z", "[1, 2]", "{a = 1}", "'x'", '"y"',
                     "99999999999999999999", "0x10", "1_000", "", "inf", "1e400", "-0.0",
                     "9223372036854775807", "1e-320", "'1'"]),
    st.text(max_size=10),
)
keys = st.one_of(st.sampled_from(TOP + [f"evolution.{k}" for k in EVOLUTION]
                                 + [f"learning.{k}" for k in LEARNING]
                                 + ["evolution", "learning", "a.b.c", "", "=", "x y"]),
                 st.text(max_size=8))


@SETTINGS
@given(name=st.sampled_from(CONFIGS),
       items=st.lists(st.tuples(keys, st.sampled_from(["=", "", " = "]), toml_values),
                      max_size=4))
def test_set_values_raise_only_cli_or_config_errors(name: str,
                                                    items: list[tuple[str, str, str]]) -> None:
    try:
        config = load_config(name, _parse_set([k + sep + v for k, sep, v in items]))
    except (CliError, ConfigError):
        return
    _check(config)


def test_booleans_are_not_numbers() -> None:
    for key in ("max_sim_time", "births", "insertion", "evaluation_time", "seed"):
        try:
            load_config("quick", _parse_set([f"{key}=true"]))
        except ConfigError as error:
            assert key in str(error)
        else:
            raise AssertionError(f"{key}=true was accepted")


@SETTINGS
@given(top=st.lists(st.tuples(st.sampled_from([*TOP, "preset", "bogus"]), toml_values),
                    max_size=5),
       tables=st.lists(st.tuples(st.sampled_from(["evolution", "learning", "other"]),
                                 st.sampled_from([*EVOLUTION, *LEARNING]), toml_values),
                       max_size=5),
       noise=st.binary(max_size=8))
def test_config_files_raise_only_config_error(top: list[tuple[str, str]],
                                              tables: list[tuple[str, str, str]],
                                              noise: bytes) -> None:
    lines = [f"{key} = {value}" for key, value in top]
    lines += [f"[{table}]\n{key} = {value}" for table, key, value in tables]
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "fuzz.toml"
        path.write_bytes("\n".join(lines).encode("utf-8", "surrogatepass") + noise)
        try:
            config = load_config(path)
        except ConfigError:
            return
    _check(config)
