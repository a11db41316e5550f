"""The engine registry: one table, names and revisions read off it, capabilities that hold."""

from __future__ import annotations

import dataclasses
import importlib
import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

import revolve_env
from revolve_env.world import World, WorldConfig, engines
from revolve_env.world.backend import EngineUnavailableError

ROOT = Path(__file__).resolve().parents[2]
INSTALLED = [e.name for e in engines.TABLE if importlib.util.find_spec(e.package) is not None]


def test_names_and_revisions_are_read_off_the_one_table() -> None:
    names = [e.name for e in engines.TABLE]
    assert engines.ENGINES == revolve_env.ENGINES == tuple(names) == ("pybullet", "mujoco",
                                                                       "mujoco_warp")
    assert len(set(names)) == len(names)
    assert engines.PHYSICS_REVISIONS == revolve_env.PHYSICS_REVISIONS == {
        "pybullet": 2, "mujoco": 2, "mujoco_warp": 1}
    assert engines.capable("gui") == ("pybullet", "mujoco")
    assert engines.capable("exact_restore") == ("mujoco",)
    assert engines.capable("shared_world") == engines.capable("deterministic") == (
        "pybullet", "mujoco")


def test_every_record_names_a_backend_that_exists() -> None:
    for record in engines.TABLE:
        if record.name not in INSTALLED:
            continue
        assert hasattr(importlib.import_module(record.module), record.backend)
        if record.isolated is not None:
            module, _, cls = record.isolated.partition(":")
            assert hasattr(importlib.import_module(module), cls)


@pytest.mark.parametrize("name", INSTALLED)
def test_the_flags_are_what_the_backends_do(name: str) -> None:
    record = engines.engine(name)
    if record.shared_world:
        with World(WorldConfig(engine=name)) as world:
            assert world.exact_restore is record.exact_restore
            if not record.exact_restore:
                with pytest.raises(NotImplementedError):
                    world.snapshot()
    else:
        with pytest.raises(RuntimeError, match=f"the {name!r} engine steps isolated worlds only "
                                               r"\(its capability shared_world is False\)"):
            World(WorldConfig(engine=name))
    if not record.gui:
        with pytest.raises(RuntimeError, match=f"the {name!r} engine has no GUI window"):
            World(WorldConfig(engine=name), gui=True)
    with pytest.raises(RuntimeError, match="an isolated world has no GUI window"):
        World(WorldConfig(engine=name), gui=True, isolated=True)
    with World(WorldConfig(engine=name), isolated=True) as world:
        assert not world.exact_restore


def test_unknown_and_missing_engines_are_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    with pytest.raises(ValueError, match=r"^unknown physics engine 'ode': choose one of pybullet, "
                                         r"mujoco, mujoco_warp$"):
        engines.require_engine("ode")
    with pytest.raises(ValueError, match="unknown physics engine 'ode'"):
        engines.with_engine(WorldConfig(), "ode")
    missing = dataclasses.replace(engines.engine("mujoco"), package="no_such_engine",
                                  pip="no_such_engine")
    monkeypatch.setattr(engines, "TABLE", (engines.TABLE[0], missing))
    with pytest.raises(EngineUnavailableError) as error:
        engines.require_engine("mujoco")
    assert "\n" not in str(error.value)
    assert "pip install no_such_engine" in str(error.value)
    assert "revolve-env[mujoco]" in str(error.value)
    assert engines.require_engine("pybullet") is engines.TABLE[0]


def test_an_installed_package_that_does_not_import_is_one_line(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    broken = dataclasses.replace(engines.TABLE[0], module="revolve_env.world.no_such_backend")
    monkeypatch.setattr(engines, "TABLE", (broken, *engines.TABLE[1:]))
    with pytest.raises(EngineUnavailableError, match="'pybullet' does not import"):
        World(WorldConfig(engine="pybullet"))


def test_checking_an_engine_or_reading_a_config_imports_no_engine() -> None:
    """``require_engine`` finds the package without importing it: reading a stored config on
    MuJoCo must not load MuJoCo before an offscreen OpenGL backend is chosen for it."""
    code = (
        "import sys\n"
        "from revolve_env.world import WorldConfig, require_engine, with_engine\n"
        "from evolution.experiments import load_config\n"
        "for name in ('pybullet', 'mujoco'):\n"
        "    try:\n"
        "        require_engine(name)\n"
        "        with_engine(WorldConfig(), name)\n"
        "        load_config('scenario1', {'world': {'engine': name}})\n"
        "    except ImportError:\n"
        "        pass\n"
        "loaded = {m for m in ('pybullet', 'mujoco') if m in sys.modules}\n"
        "assert not loaded, loaded\n"
    )
    subprocess.run([sys.executable, "-c", code], cwd=ROOT, check=True, capture_output=True)
