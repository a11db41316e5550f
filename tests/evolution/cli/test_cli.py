"""The ``revolve`` command line: help, bad input (one line, exit 2, nothing overwritten),
run -> report end to end, resume after Ctrl-C, export, show, shipped configs (the progress
display: test_progress.py).

Experiments run on the fast physics stand-ins of ``experiment_fakes`` (``make_evaluator`` is
patched); the tests marked slow use the real physics.
"""

from __future__ import annotations

import csv
import json
import os
import sqlite3
import threading
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from experiment_fakes import CtrlCEvaluator, dump_results, fake_evaluate

from evolution.cli import build_parser, main
from evolution.evaluation import LocalEvaluator, evaluate_task
from evolution.experiments import (
    ConfigError,
    ExperimentConfig,
    preset,
    shipped_configs,
)
from evolution.experiments import load_config as resolve_config
from evolution.experiments.app import api
from evolution.experiments.store.database import DB_NAME, Store

SUBCOMMANDS = ("run", "resume", "report", "show", "export", "demo")
SMALL = ["--set", "evolution.initial_parts_mean=5", "--set", "evolution.initial_parts_sd=2",
         "--set", "evolution.max_parts=12"]


@pytest.fixture
def fake_physics(monkeypatch: pytest.MonkeyPatch) -> None:
    """Experiments started by the CLI evaluate robots with the fast stand-in."""
    monkeypatch.setattr(api, "make_evaluator",
                        lambda *a, **k: LocalEvaluator(workers=1, function=fake_evaluate))


def _error(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    """Run ``argv``, expect exit status 2 and exactly one line on stderr; return it."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


# -- help ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("command", SUBCOMMANDS)
def test_every_subcommand_has_help(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main([command, "--help"])
    assert exit_info.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith(f"usage: revolve {command}")
    expected = {"run": "--births", "resume": "DIR", "report": "tests_per_run.csv",
                "show": "--robot", "export": "--format", "demo": "--births"}[command]
    assert expected in out


def test_top_level_help_lists_the_subcommands(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    assert all(c in out for c in SUBCOMMANDS)


def test_console_script_points_at_main() -> None:
    import tomllib

    pyproject = tomllib.loads((Path(__file__).parents[3] / "pyproject.toml").read_text())
    assert pyproject["project"]["scripts"]["revolve"] == "evolution.cli:main"


# -- shipped configs ----------------------------------------------------------------------------


def test_shipped_configs_are_the_papers_five_experiments_quick_and_two_with_learning() -> None:
    configs = shipped_configs()
    assert set(configs) == {"scenario1", "scenario2", "scenario3", "baseline_a", "baseline_b",
                            "quick", "scenario1_learning", "scenario3_learning"}
    for name, path in configs.items():
        config = ExperimentConfig.from_toml(path)
        assert config.name == name
        if name.endswith("_learning"):
            # Scenario 1 or 3 exactly, plus a learning table.
            scenario = name.removesuffix("_learning")
            assert config.replace(name=scenario, learning=None) == preset(scenario)
            assert config.learning is not None and config.learning["learner"] == "cma-es"
            continue
        runs = 1 if name == "quick" else 30  # the paper repeats every experiment 30 times
        assert config == preset(name, runs=runs), name
        assert config.learning is None


def test_resolve_config_from_name_path_and_overrides(tmp_path: Path) -> None:
    config = resolve_config("scenario2", {"births": 45, "evolution": {"max_parts": 20}})
    assert (config.offspring_size, config.births, config.evolution.max_parts) == (1, 45, 20)
    assert config.evolution.p_swap_subtree == preset("scenario2", runs=1).evolution.p_swap_subtree
    path = tmp_path / "mine.toml"
    path.write_text('preset = "scenario3"\nname = "mine"\nbirths = 40\n')
    config = resolve_config(str(path))
    assert (config.mode, config.name, config.births) == ("online", "mine", 40)
    with pytest.raises(ConfigError, match="unknown scenario 'scenario4'"):
        resolve_config("scenario4")
    with pytest.raises(ConfigError, match="no such config file"):
        resolve_config(str(tmp_path / "missing.toml"))


# -- bad input ----------------------------------------------------------------------------------


def test_unknown_scenario(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    line = _error(capsys, ["run", "scenario9", "--out", str(tmp_path)])
    assert "unknown scenario 'scenario9'" in line and "scenario1" in line
    assert list(tmp_path.iterdir()) == []


def test_unknown_config_key(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    line = _error(capsys, ["run", "quick", "--set", "populaton_size=4", "--out", str(tmp_path)])
    assert "populaton_size" in line
    path = tmp_path / "bad.toml"
    path.write_text('name = "x"\n[evolution]\nmax_partz = 3\n')
    line = _error(capsys, ["run", str(path), "--out", str(tmp_path)])
    assert "max_partz" in line and "bad.toml" in line


def test_out_of_range_values(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    assert "births (5) must be >= population_size (15)" in _error(
        capsys, ["run", "quick", "--births", "5", "--out", str(tmp_path)])
    assert "death_threshold" in _error(
        capsys, ["run", "scenario3", "--set", "death_threshold=-1", "--out", str(tmp_path)])
    assert "evolution" in _error(
        capsys, ["run", "quick", "--set", "evolution.p_swap_subtree=2", "--out", str(tmp_path)])
    # argparse's own range checks also exit with 2.
    with pytest.raises(SystemExit) as exit_info:
        main(["run", "quick", "--runs", "0"])
    assert exit_info.value.code == 2
    assert "must be >= 1" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_existing_results_are_never_overwritten(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    with Store.create(tmp_path / "quick" / DB_NAME, preset("quick", runs=1).to_dict(), 0):
        pass
    other = tmp_path / "other" / "quick"
    with Store.create(other / DB_NAME, preset("scenario2", runs=1).to_dict(), 0):
        pass
    before = [(p, p.read_bytes()) for p in sorted(tmp_path.rglob("*")) if p.is_file()]
    assert "resume" in _error(capsys, ["run", "quick", "--out", str(tmp_path)])
    line = _error(capsys, ["run", "quick", "--out", str(tmp_path / "other")])
    assert "experiment 'scenario2' with other settings" in line and "name:" in line
    after = [(p, p.read_bytes()) for p in sorted(tmp_path.rglob("*")) if p.is_file()]
    assert after == before


def test_existing_results_of_the_same_experiment_point_to_resume(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    with Store.create(tmp_path / "quick" / DB_NAME, preset("quick", runs=1).to_dict(), 0):
        pass
    line = _error(capsys, ["run", "quick", "--out", str(tmp_path)])
    assert "already holds results of this experiment" in line
    assert f"revolve resume {tmp_path / 'quick'}" in line


def test_missing_directories(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    for command in ("resume", "report"):
        line = _error(capsys, [command, str(tmp_path / "nothing")])
        assert "no such results directory" in line
        line = _error(capsys, [command, str(tmp_path)])
        assert "no results database" in line


def test_corrupt_and_newer_databases(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    corrupt = tmp_path / "corrupt"
    corrupt.mkdir()
    (corrupt / DB_NAME).write_bytes(b"\x00garbage" * 512)
    for command in ("resume", "report"):
        assert "corrupt" in _error(capsys, [command, str(corrupt)])
    newer = tmp_path / "newer"
    with Store.create(newer / DB_NAME, preset("quick", runs=1).to_dict(), 0):
        pass
    con = sqlite3.connect(newer / DB_NAME)
    con.execute("UPDATE meta SET value = '99' WHERE key = 'schema_version'")
    con.commit()
    con.close()
    for command in ("resume", "report"):
        assert "schema version 99, newer" in _error(capsys, [command, str(newer)])
    assert "corrupt" in _error(capsys, ["show", "--db", str(corrupt), "--best"])
    incomplete = tmp_path / "incomplete"
    with Store.create(incomplete / DB_NAME, preset("quick", runs=1).to_dict(), 0):
        pass
    con = sqlite3.connect(incomplete / DB_NAME)
    con.execute("DROP TABLE robots")
    con.commit()
    con.close()
    for command in ("resume", "report"):
        assert "table(s) robots missing" in _error(capsys, [command, str(incomplete)])


def test_bad_robot_inputs(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    assert "no such robot file" in _error(capsys, ["export", str(tmp_path / "r.json"),
                                                   "--format", "urdf"])
    bad = tmp_path / "bad.json"
    bad.write_text('{"schema": "revolve-robot", "version": 1, "body": 3}')
    assert "bad.json" in _error(capsys, ["export", str(bad), "--format", "sdf"])
    assert "give a robot" in _error(capsys, ["export", "--format", "bom"])


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_a_robot_file_that_is_not_a_regular_file_is_one_line_not_a_hang(
        capsys: pytest.CaptureFixture[str], tmp_path: Path,
        monkeypatch: pytest.MonkeyPatch) -> None:
    fifo = tmp_path / "robot.json"
    os.mkfifo(fifo)
    # Were the FIFO opened to be read, it would wait for a writer: this one comes after a minute,
    # so that a regression fails (on its message) instead of hanging the suite.
    rescue = threading.Timer(60, lambda: os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK)))
    rescue.start()
    try:
        for argv in (["export", str(fifo), "--format", "bom"],
                     ["show", str(fifo), "--out", str(tmp_path / "x.gif")]):
            assert _error(capsys, argv).endswith(f"the robot file {fifo} is a FIFO, not a "
                                                 "regular file")
    finally:
        rescue.cancel()
    assert "is a folder, not a regular file" in _error(capsys, ["export", str(tmp_path),
                                                                "--format", "bom"])
    (tmp_path / "spider").mkdir()  # a file wins over the example of its name, whatever it is
    monkeypatch.chdir(tmp_path)
    assert _error(capsys, ["export", "spider", "--format", "bom"]).endswith(
        "the robot file spider is a folder, not a regular file")


# -- end to end ---------------------------------------------------------------------------------


def test_run_then_report(fake_physics: None, tmp_path: Path,
                         capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "results"
    for name in ("scenario1", "baseline_a"):
        assert main(["run", name, "--runs", "2", "--births", "18", "--seed", "3",
                     "--set", "population_size=6", "--set", "offspring_size=6",
                     "--out", str(out), *SMALL]) == 0
    captured = capsys.readouterr()
    assert "run 1: finished, 18 births" in captured.out
    assert "all runs: 36/36 births (100%), 2/2 runs finished" in captured.err  # progress log
    with Store.open(out / "scenario1" / DB_NAME) as store:
        assert store.config["seed"] == 3 and store.config["evolution"]["max_parts"] == 12
        assert [(r.status, r.births) for r in store.runs()] == [("finished", 18)] * 2

    assert main(["report", str(out), "--formats", "png", "--brain-aware"]) == 0
    report_dir = out / "report"
    for stem in ("fitness_over_births", "final_fitness", "diversity_over_births",
                 "final_diversity"):
        assert (report_dir / f"{stem}.png").read_bytes()[:4] == b"\x89PNG"
        assert not (report_dir / f"{stem}.pdf").exists()
    with open(report_dir / "summary.csv", newline="") as f:
        summary = list(csv.DictReader(f))
    assert [r["experiment"] for r in summary] == ["scenario1", "baseline_a"]
    assert all(r["runs"] == "2" and r["finished_runs"] == "2" for r in summary)
    with open(report_dir / "tests_per_run.csv", newline="") as f:
        tests = list(csv.DictReader(f))
    assert {r["sample"] for r in tests} == {"run_mean_fitness", "run_best_fitness",
                                            "run_diversity", "run_brain_diversity"}
    assert {r["births"] for r in tests} == {"18"}
    assert len(tests) == 4
    assert all(0.0 <= float(r["p_value"]) <= 1.0 for r in tests)
    assert (report_dir / "summary.md").is_file()
    assert (report_dir / "index.html").is_file()
    listed = capsys.readouterr().out
    assert f"open in a browser: {report_dir / 'index.html'}" in listed
    assert str(report_dir / "summary.csv") in listed  # every file written is listed...
    for quiet in (["-q", "report", str(out)], ["report", str(out), "-q"]):
        assert main([*quiet, "--formats", "png", "--out", str(tmp_path / "quiet")]) == 0
        # ... but --quiet (before or after the command) prints where the page is, no files.
        assert capsys.readouterr().out == (
            f"open in a browser: {tmp_path / 'quiet' / 'index.html'}\n"), quiet


def test_ctrl_c_then_resume(monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
                            capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(api, "make_evaluator", lambda *a, **k: CtrlCEvaluator(15 + 15 + 4))
    argv = ["run", "scenario1", "--runs", "1", "--births", "45", "--out", str(tmp_path), *SMALL]
    assert main(argv) == 130
    err = capsys.readouterr().err
    assert f"revolve resume {tmp_path / 'scenario1'}" in err and "Traceback" not in err
    db = tmp_path / "scenario1" / DB_NAME
    with Store.open(db) as store:
        assert store.checkpoint(0).births == 30  # two whole generations were committed
    monkeypatch.setattr(api, "make_evaluator",
                        lambda *a, **k: LocalEvaluator(workers=1, function=fake_evaluate))
    assert main(["resume", str(tmp_path)]) == 0
    with Store.open(db) as store:
        assert [(r.status, r.births) for r in store.runs()] == [("finished", 45)]
    assert main(["resume", str(tmp_path)]) == 0
    assert "nothing to resume" in capsys.readouterr().out


# -- robots -------------------------------------------------------------------------------------


def test_export_formats(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from revolve_env.body.examples import spider
    from revolve_env.body.serialize import save

    path = tmp_path / "spider.json"
    save(spider(), path)
    assert main(["export", str(path), "--format", "urdf"]) == 0
    urdf = ET.fromstring(capsys.readouterr().out)
    assert urdf.tag == "robot"
    assert len(urdf.findall("joint[@type='revolute']")) == 8
    assert main(["export", "spider", "--format", "sdf", "--out", str(tmp_path / "s.sdf")]) == 0
    assert ET.parse(tmp_path / "s.sdf").getroot().tag == "sdf"
    assert main(["export", str(path), "--format", "bom"]) == 0
    assert "servos: 8" in capsys.readouterr().out
    assert main(["export", "spider", "--format", "bom-json"]) == 0
    bom = json.loads(capsys.readouterr().out)
    assert bom["servos"] == 8 and bom["parts"]["core"] == 1


def test_export_mjcf_is_the_model_evaluate_steps(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    mujoco = pytest.importorskip("mujoco", reason="the mujoco package is not installed")
    from revolve_env.body.examples import spider
    from revolve_env.body.serialize import save
    from revolve_env.world import World, WorldConfig

    path = tmp_path / "spider.json"
    save(spider(), path)
    assert main(["export", str(path), "--format", "mjcf", "--out", str(tmp_path / "s.xml")]) == 0
    assert "wrote" in capsys.readouterr().out
    assert main(["export", "spider", "--format", "mjcf"]) == 0
    text = capsys.readouterr().out
    assert (tmp_path / "s.xml").read_text() == text
    model = mujoco.MjModel.from_xml_string(text)
    assert model.nu == 8 and model.nbody == 10  # the world, the core and 8 hinged bodies
    with World(WorldConfig(engine="mujoco")) as world:  # where evaluate() starts it
        world.add_robot(spider(), position=(0.0, 0.0), yaw=0.0)
        assert text == world.to_mjcf()


def test_export_a_robot_of_a_results_database(fake_physics: None, tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "scenario1", "--runs", "1", "--births", "30", "--out", str(tmp_path),
                 *SMALL]) == 0
    db_dir = tmp_path / "scenario1"
    capsys.readouterr()
    assert main(["export", "--db", str(db_dir), "--robot", "17", "--format", "bom-json"]) == 0
    bom = json.loads(capsys.readouterr().out)
    with Store.open(db_dir / DB_NAME) as store:
        robot = store.robot(0, 17).robot()
        best_id = max((f, rid) for rid, f in store.final_population(0))[1]
        best = store.robot(0, best_id).robot()
    assert bom["parts"]["core"] == 1 and sum(bom["parts"].values()) == len(list(robot.walk()))
    assert main(["export", "--db", str(db_dir), "--best", "--format", "bom-json"]) == 0
    assert sum(json.loads(capsys.readouterr().out)["parts"].values()) == len(list(best.walk()))
    assert "no robot 99" in _error(capsys, ["export", "--db", str(db_dir), "--robot", "99",
                                            "--format", "urdf"])
    assert "no run 5" in _error(capsys, ["export", "--db", str(db_dir), "--run", "5", "--best",
                                         "--format", "urdf"])
    assert "--robot ID or --best" in _error(capsys, ["export", "--db", str(db_dir),
                                                     "--format", "urdf"])


def test_show_writes_a_gif_of_the_robot_walking(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    from PIL import Image

    out = tmp_path / "spider.gif"
    assert main(["show", "spider", "--seconds", "0.5", "--insertion", "0.25", "--fps", "8",
                 "--out", str(out)]) == 0
    assert "fitness" in capsys.readouterr().out
    with Image.open(out) as gif:
        # 0.75 s at 8 frames per second: a frame every 8 control periods of 1/60 s (45 steps).
        assert gif.n_frames == 6
        assert gif.size == (480, 360)
        first = gif.convert("RGB").tobytes()
        gif.seek(gif.n_frames - 1)
        assert gif.convert("RGB").tobytes() != first  # the robot moved (and the clock ran)


def test_parser_defaults() -> None:
    args = build_parser().parse_args(["run", "quick"])
    assert args.out == "results" and args.runs is None and args.births is None


# -- real physics -------------------------------------------------------------------------------


@pytest.mark.slow
def test_demo_with_real_physics(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["demo", "--births", "6", "--population", "3", "--seconds", "2",
                 "--workers", "1", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "example spider: fitness" in out and "best fitness after 6 births" in out
    with Store.open(tmp_path / "demo" / DB_NAME) as store:
        assert store.runs()[0].births == 6


@pytest.mark.slow
def test_run_and_report_with_real_physics(tmp_path: Path) -> None:
    argv = ["--births", "8", "--runs", "2", "--workers", "2", "--out", str(tmp_path),
            "--set", "population_size=4", "--set", "offspring_size=4",
            "--set", "evaluation_time=2", "--set", "fertile_age=5", *SMALL]
    assert main(["run", "scenario1", *argv]) == 0
    assert main(["run", "baseline_b", *argv]) == 0
    assert main(["report", str(tmp_path), "--formats", "png"]) == 0
    with open(tmp_path / "report" / "tests_per_run.csv", newline="") as f:
        assert all(0 <= float(r["p_value"]) <= 1 for r in csv.DictReader(f))


# -- infancy learning ---------------------------------------------------------------------------

# A tiny offline experiment with a [learning] table, on the real physics: 2 robots + 2 children,
# each learning by random search (its inborn controller and one candidate: 2 x (0.25 + 0.5) s)
# before its own 0.5 + 1 s evaluation. A few seconds in all.
TINY_LEARNING = """\
preset = "scenario1"
name = "tiny_learning"
runs = 1
population_size = 2
offspring_size = 2
births = 4
insertion = 0.5
evaluation_time = 1.0
fertile_age = 1.5
diversity_interval = 2
workers = 1
seed = 5

[evolution]
initial_parts_mean = 6.0
initial_parts_sd = 2.0
max_parts = 10

[learning]
learner = "random-search"
budget = 1.5
inheritance = "lamarckian"
sigma = 0.3
popsize = 2
insertion = 0.25
seconds = 0.5
"""
LEARNING_TABLES = ("robots", "fitness", "transitions", "population", "failures", "learning")


def _tiny_learning(tmp_path: Path, text: str = TINY_LEARNING) -> Path:
    path = tmp_path / "tiny_learning.toml"
    path.write_text(text)
    return path



def test_learning_config_runs_stores_its_table_and_is_reported(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "results"
    assert main(["run", str(_tiny_learning(tmp_path)), "--out", str(out)]) == 0
    assert ("infancy learning: random-search, 1.5 s per infant, lamarckian"
            in capsys.readouterr().out)
    with Store.open(out / "tiny_learning" / DB_NAME) as store:
        table = store.config["learning"]
        assert table == {"learner": "random-search", "budget": 1.5, "inheritance": "lamarckian",
                         "sigma": 0.3, "popsize": 2, "insertion": 0.25, "seconds": 0.5}
        records = store.learning(0)
        failed = store.failures(0, "learner")
        # Every infant went to the Training Center: a learning record, or a recorded failure
        # (a robot without learnable parameters).
        assert sorted([r.robot_id for r in records] + [f.robot_id for f in failed]) == [0, 1, 2, 3]
        assert records
        for r in records:
            assert (r.evaluations, r.sim_seconds, r.inheritance) == (2, 1.5, "lamarckian")
            assert r.inborn_fitness is not None and r.learned_fitness is not None
            assert r.learned_fitness >= r.inborn_fitness  # the best evaluated, inborn included
    assert main(["report", str(out), "--formats", "png"]) == 0
    assert (out / "report" / "learning_gain.png").read_bytes()[:4] == b"\x89PNG"
    with open(out / "report" / "summary.csv", newline="") as f:
        (row,) = list(csv.DictReader(f))
    assert row["learning"] == "random-search lamarckian"
    assert int(row["infants_learned"]) == len(records)
    assert int(row["learner_failures"]) == len(failed)
    inborn = [r.inborn_fitness for r in records]
    learned = [r.learned_fitness for r in records]
    assert float(row["inborn_fitness_mean"]) == pytest.approx(sum(inborn) / len(inborn), rel=1e-5)
    assert float(row["learned_fitness_mean"]) == pytest.approx(
        sum(learned) / len(learned), rel=1e-5)
    assert "learned_fitness_mean" in (out / "report" / "summary.md").read_text()


def test_bad_learning_tables(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    bad = _tiny_learning(tmp_path, TINY_LEARNING.replace("popsize = 2", "popsiz = 2"))
    line = _error(capsys, ["run", str(bad), "--out", str(tmp_path / "out")])
    assert "popsiz" in line and "tiny_learning.toml" in line and "known: budget" in line
    line = _error(capsys, ["run", "scenario1_learning", "--set", "learning.sigmaa=0.1",
                           "--out", str(tmp_path / "out")])
    assert "unknown learning key(s) for cma-es: sigmaa" in line
    assert "learning.learner must be one of" in _error(
        capsys, ["run", "scenario3_learning", "--set", "learning.learner='hill-climb'",
                 "--out", str(tmp_path / "out")])
    assert "budget" in _error(
        capsys, ["run", "scenario1_learning", "--set", "learning.budget=-1",
                 "--out", str(tmp_path / "out")])
    assert "has no [learning] table" in _error(
        capsys, ["run", "scenario1", "--set", "learning.budget=10", "--out", str(tmp_path / "out")])
    # A budget too small for one learning step (SB3: two evaluations and one PPO rollout) is
    # refused up front, in one line.
    sb3 = _tiny_learning(tmp_path, TINY_LEARNING.split("[learning]")[0]
                         + '[learning]\nlearner = "sb3"\nbudget = 2.0\n')
    assert "too small for one learning step of SB3Learner" in _error(
        capsys, ["run", str(sb3), "--out", str(tmp_path / "out")])
    assert not (tmp_path / "out").exists()


def test_learning_overrides_merge_into_the_shipped_table() -> None:
    config = resolve_config("scenario1_learning", {"learning": {"budget": 35.0}})
    assert config.learning is not None
    assert config.learning["budget"] == 35.0 and config.learning["learner"] == "cma-es"
    assert config.learning["popsize"] == 4  # the rest of the shipped table is kept
    assert config.training_center().budget == 35.0
    config = resolve_config("scenario1", {"learning": {"learner": "random-search", "budget": 14.0}})
    assert config.training_center().learner.batch_size == 8


def test_run_help_names_the_learning_configs(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "scenario1_learning" in out and "scenario3_learning" in out and "[learning]" in out


def test_learning_run_ctrl_c_then_resume_rebuilds_the_learner(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    config = _tiny_learning(tmp_path)
    assert main(["run", str(config), "--out", str(tmp_path / "reference")]) == 0
    reference = dump_results(tmp_path / "reference" / "tiny_learning" / DB_NAME, LEARNING_TABLES)

    real = api.make_evaluator
    monkeypatch.setattr(api, "make_evaluator",
                        lambda *a, **k: CtrlCEvaluator(2 + 1, evaluate_task))
    assert main(["run", str(config), "--out", str(tmp_path / "killed")]) == 130
    killed = tmp_path / "killed" / "tiny_learning"
    with Store.open(killed / DB_NAME) as store:
        assert store.checkpoint(0).births == 2  # the initial population was committed
        assert {r.robot_id for r in store.learning(0)} <= {0, 1}
    monkeypatch.setattr(api, "make_evaluator", real)
    # `revolve resume` takes nothing but the folder: the learner comes from the stored table.
    assert main(["resume", str(killed)]) == 0
    resumed = dump_results(killed / DB_NAME, LEARNING_TABLES)
    assert {r[1] for r in resumed["learning"]} | {r[1] for r in resumed["failures"]} >= {2, 3}
    assert resumed == reference


def test_internal_errors_show_their_traceback_and_say_it_is_a_bug(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    from evolution import experiments
    from evolution.experiments import ReplayError

    def broken(*args: object, **kwargs: object) -> None:
        raise KeyError("an internal slip")

    monkeypatch.setattr(experiments, "run", broken)  # what revolve run calls
    assert main(["run", "quick", "--births", "15", "--out", str(tmp_path)]) == 1
    err = capsys.readouterr().err
    assert "Traceback" in err and "KeyError" in err and "this is a bug" in err

    def replay(*args: object, **kwargs: object) -> None:
        raise ReplayError("replay made a different robot 3")

    monkeypatch.setattr(experiments, "run", replay)
    assert main(["run", "quick", "--births", "15", "--out", str(tmp_path / "b")]) == 1
    err = capsys.readouterr().err
    assert "Traceback" in err and "ReplayError" in err and "this is a bug" in err
    # Bad input stays one line.
    assert main(["run", "scenario4"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_report_refuses_an_empty_format_list(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                             ) -> None:
    assert main(["report", str(tmp_path), "--formats", ","]) == 2
    assert "--formats" in capsys.readouterr().err
