"""``mode`` switches between offline and online evolution; ``engine`` names the physics engine.

The switch was called ``engine`` before: a config that still says so (a TOML file, a dict, an
override, ``--set engine=online``) is read as ``mode`` with a one-line warning, and a stored one
is renamed when its database is opened (tests/evolution/experiments/store/test_store.py).
"""

from __future__ import annotations

import logging
from pathlib import Path

import pytest
from experiment_fakes import fake_evaluate

from evolution.cli import main
from evolution.evaluation import LocalEvaluator
from evolution.experiments import ConfigError, ExperimentConfig, load_config, preset
from evolution.experiments.app import api
from evolution.experiments.store.database import DB_NAME, Store

OLD_NAME = "config key engine = 'online' is the old name of mode"


def _notes(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == "evolution.experiments.loop.config"]


def test_the_shipped_configs_name_their_mode() -> None:
    assert preset("scenario3").mode == "online" and preset("scenario1").mode == "offline"
    assert "mode" in ExperimentConfig().to_dict() and "engine" not in ExperimentConfig().to_dict()


def test_a_toml_file_with_the_old_key_is_read_with_one_warning(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    path = tmp_path / "old.toml"
    path.write_text('preset = "scenario1"\nname = "old"\nengine = "online"\n'
                    'population_size = 8\n[world]\nengine = "mujoco"\n')
    with caplog.at_level(logging.WARNING):
        config = load_config(path)
    assert (config.mode, config.world.engine) == ("online", "mujoco")
    assert len(_notes(caplog)) == 1 and _notes(caplog)[0].startswith(OLD_NAME)
    assert config == ExperimentConfig.from_dict({**config.to_dict()})  # the new name round-trips


def test_an_override_with_the_old_key_wins_over_the_file(
        caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.WARNING):
        assert load_config("scenario1", {"engine": "online", "population_size": 8}).mode == "online"
        assert preset("scenario3", engine="offline").mode == "offline"
        assert ExperimentConfig.from_dict({"preset": "scenario1", "engine": "online",
                                           "population_size": 8}).mode == "online"
    assert len(_notes(caplog)) == 3


@pytest.mark.parametrize(("data", "message"), [
    ({"engine": "mujoco"}, r"engine = 'mujoco' at the top level: the physics engine is set in "
                           r"the \[world\] table \(world.engine = 'mujoco'"),
    ({"engine": "online", "mode": "offline"}, "engine = 'online' .* disagrees with mode"),
    ({"engine": "hybrid"}, "mode must be one of 'offline', 'online', got 'hybrid'"),
])
def test_a_wrong_old_key_is_one_clear_error(data: dict[str, str], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        ExperimentConfig.from_dict(data)


def test_the_old_key_agreeing_with_mode_is_accepted() -> None:
    both = ExperimentConfig.from_dict({"engine": "online", "mode": "online",
                                       "population_size": 8})
    assert both.mode == "online"


def test_set_engine_on_the_command_line_runs_and_stores_mode(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    """``--set engine=offline`` (the old spelling) runs, prints one warning line saying to write
    ``mode``, and the results store the new name; ``--set engine=mujoco`` is one error line
    pointing at ``world.engine``."""
    monkeypatch.setattr(api, "make_evaluator",
                        lambda *a, **k: LocalEvaluator(workers=1, function=fake_evaluate))
    out = tmp_path / "results"
    assert main(["run", "scenario1", "--births", "6", "--set", "population_size=3",
                 "--set", "offspring_size=3", "--set", "engine=offline", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    warnings = [line for line in err.splitlines() if "old name of mode" in line]
    assert warnings == ["warning: config key engine = 'offline' is the old name of mode: write "
                        "mode = 'offline' (engine now names only the physics engine, "
                        "world.engine)"]
    with Store.open(out / "scenario1" / DB_NAME) as store:
        assert store.config["mode"] == "offline" and "engine" not in store.config
    assert main(["run", "scenario1", "--set", "engine=mujoco", "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "world.engine" in err[0] and "mode" in err[0]
