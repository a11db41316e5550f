"""``revolve study``: help with defaults, the study and its report end to end, Ctrl-C then the
same command, settings refused on one line.

Runs use the fast physics stand-ins (``make_evaluator`` and the default online world are
patched); the test marked slow runs the real physics.
"""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest
from experiment_fakes import CtrlCEvaluator, dump_results, fake_evaluate, fake_world

from evolution.cli import main
from evolution.cli.options import parse_set
from evolution.evaluation import LocalEvaluator
from evolution.experiments.app import study as study_module
from evolution.experiments.app.world_size import rule_bounds
from evolution.experiments.loop import evolve as loop
from evolution.experiments.loop.config import load_config
from evolution.experiments.loop.registry import PAPER_SCENARIOS
from evolution.experiments.store.database import DB_NAME, Store

TINY = ["--set", "population_size=4", "--set", "offspring_size=4", "--set", "insertion=0.5",
        "--set", "evaluation_time=1", "--set", "fertile_age=1.5", "--set",
        "conception_interval=1", "--set", "min_alive=2", "--set", "diversity_interval=4",
        "--set", "evolution.max_parts=12", "--set", "evolution.initial_parts_mean=5",
        "--set", "evolution.initial_parts_sd=2"]


@pytest.fixture
def fake_physics(monkeypatch: pytest.MonkeyPatch) -> None:
    """Studies started by the CLI evaluate robots and live online with the fast stand-ins."""
    monkeypatch.setattr(study_module, "make_evaluator",
                        lambda *a, **k: LocalEvaluator(workers=1, function=fake_evaluate))
    monkeypatch.setattr(loop, "default_world", fake_world)


def test_help_shows_every_default(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["study", "--help"])
    assert exit_info.value.code == 0
    out = " ".join(capsys.readouterr().out.split())
    assert out.startswith("usage: revolve study")
    for text in ("--out DIR the study's folder (default: results/study)",
                 "runs per experiment (default: 3)", "(default: 60)", "(default: 0)",
                 "(default: local)", "default: scenario1 scenario2 scenario3 baseline_a "
                 "baseline_b"):
        assert text in out, text
    with pytest.raises(SystemExit):
        main(["--help"])
    assert "study" in capsys.readouterr().out


def test_study_then_report(fake_physics: None, tmp_path: Path,
                           capsys: pytest.CaptureFixture[str],
                           caplog: pytest.LogCaptureFixture) -> None:
    out = tmp_path / "study"
    # The calibration runs the real physics (MuJoCo: a fraction of a second), the runs the fakes.
    argv = ["study", "--out", str(out), "--runs", "2", "--births", "16", *TINY, "--set",
            "world.engine=mujoco"]
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert f"study in {out}: 5 experiment(s), 10 unfinished run(s)" in captured.out
    # The estimate comes before the runs, one line per experiment.
    assert captured.out.index("estimated time:") < captured.out.index("scenario1 run 0: ")
    assert captured.out.count("ms CPU per birth") == 5
    # The progress display labels each run with its experiment.
    assert "scenario3 run 0: finished, 16 births" in caplog.text
    assert "all runs: 160/160 births (100%), 10/10 runs finished" in caplog.text
    for name in PAPER_SCENARIOS:
        assert f"{name} run 1: finished, 16 births" in captured.out
        with Store.open(out / name / DB_NAME) as store:
            assert [(r.status, r.births) for r in store.runs()] == [("finished", 16)] * 2
    assert f"report of 5 experiment(s) in {out / 'report'}:" in captured.out
    for stem in ("fitness_over_births", "final_fitness", "diversity_over_births",
                 "final_diversity"):
        assert f"{out / 'report' / stem}.png" in captured.out
        assert (out / "report" / f"{stem}.png").read_bytes()[:4] == b"\x89PNG"
    assert (out / "report" / "summary.csv").is_file()

    assert main(argv) == 0
    again = capsys.readouterr().out
    assert "every run had finished already" in again and "estimated time" not in again


def test_ctrl_c_names_the_command_that_continues(monkeypatch: pytest.MonkeyPatch,
                                                 tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(loop, "default_world", fake_world)
    monkeypatch.setattr(study_module, "make_evaluator", lambda *a, **k: CtrlCEvaluator(4 + 4 + 2))
    out = tmp_path / "study"
    argv = ["study", "--out", str(out), "--runs", "2", "--births", "16", "--seed", "5", *TINY,
            "--only", "scenario1", "scenario3", "--no-estimate"]
    assert main(argv) == 130
    err = capsys.readouterr().err
    assert "Traceback" not in err
    again = err.split("continue with: ")[1].strip()
    assert shlex.split(again) == ["revolve", *argv]
    with Store.open(out / "scenario3" / DB_NAME) as store:  # online first: finished
        assert {r.status for r in store.runs()} == {"finished"}
    with Store.open(out / "scenario1" / DB_NAME) as store:
        assert store.checkpoint(0).births == 8  # two generations committed
        assert store.runs()[0].status == "interrupted"
    monkeypatch.setattr(study_module, "make_evaluator",
                        lambda *a, **k: LocalEvaluator(workers=1, function=fake_evaluate))
    assert main(shlex.split(again)[1:]) == 0
    out_text = capsys.readouterr().out
    # the shipped configs' engine, MuJoCo
    assert "scenario1: 2 run(s) x 16 births (offline, mujoco): 2 run(s) to do" in out_text
    assert "scenario3: 2 run(s) x 16 births (online, mujoco): finished" in out_text
    assert "estimated time" not in out_text  # --no-estimate: no calibration


def test_estimate_only_prints_the_estimate_and_writes_nothing(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "study"
    assert main(["study", "--out", str(out), "--runs", "30", "--births", "3000", "--workers",
                 "2", *TINY, "--set", "world.engine=mujoco", "--estimate-only"]) == 0
    assert not out.exists()
    lines = capsys.readouterr().out.splitlines()
    start = lines.index("estimated time:")
    per_experiment = lines[start + 1:start + 6]
    for name, line in zip(PAPER_SCENARIOS, per_experiment, strict=True):
        assert line.startswith(f"  {name}: ") and "30 run(s), 90000 births" in line, line
    # offline: 30 x 3000 evaluations of 0.5 + 1 s, the robot-seconds each experiment simulates
    assert ("90000 births, 1.35e+05 robot-s (37.5 robot-h) (offline, mujoco: 1.5 s per birth)"
            in per_experiment[0])
    # online: the robots alive measured at the run's start (min_alive 2 here), not assumed,
    # growing over the 3000 births toward the survivor rule's ceiling, and the line says so
    words = per_experiment[2].split("(online, mujoco: ")[1]
    mean = float(words.split(" robots alive on average (")[0])
    measured = float(words.split(" robots alive on average (")[1].split(" measured at")[0])
    ceiling = rule_bounds(load_config("scenario3", parse_set(TINY[1::2])))[1]
    assert 2 <= measured < mean < ceiling <= 30
    assert (f"growing after 600 births toward the survivor rule's {ceiling:.1f} as a measured "
            "run's grew) x 1 s per birth)") in words
    hours = [float(line.split(": ")[-1].split(" CPU-h")[0]) for line in per_experiment]
    # each experiment's projected hours on the 2 workers: when its last run is done
    ends = [float(line.split("its last run done after ")[1].split("(")[1].removesuffix(" h)"))
            for line in per_experiment]
    assert all(end > 0 for end in ends)
    total = lines[start + 6]
    assert total.startswith("  total ") and "on 2 worker(s)" in total
    assert float(total.split("), ")[1].split()[0]) == pytest.approx(sum(hours), abs=0.03)
    assert lines[start + 7].startswith("  (an estimate: it assumes a run's later robots cost")
    # offline: measured on the run's own children, reproduction and selection included
    assert "children of the run's first generations x 1.5 s, " in per_experiment[0]
    assert "ms of each birth its reproduction and selection" in per_experiment[0]


@pytest.mark.parametrize("argv, message", [
    (["--births", "20"], "holds a study with other settings (births: 16 stored, 20 now)"),
    (["--set", "evolution.max_parts=13"], "--set evolution.max_parts: 12 stored, 13 now"),
    (["--set", "runs=4"], "runs is a setting of the study, not an override"),
    (["--only", "scenario7"], "unknown scenario 'scenario7'"),
    (["--ray-address", "auto"], "--ray-address needs --evaluator ray"),
])
def test_bad_settings_are_one_line(fake_physics: None, tmp_path: Path,
                                   capsys: pytest.CaptureFixture[str], argv: list[str],
                                   message: str) -> None:
    out = tmp_path / "study"
    base = ["study", "--out", str(out), "--runs", "1", "--births", "16", *TINY, "--no-estimate"]
    assert main([*base, "--only", "baseline_b"]) == 0
    capsys.readouterr()
    assert main([*base, *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("revolve study: error: ") and message in err


@pytest.mark.slow
def test_study_with_real_physics(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "study"
    assert main(["study", "--out", str(out), "--runs", "2", "--births", "16", "--workers", "2",
                 *TINY]) == 0
    assert "report of 5 experiment(s)" in capsys.readouterr().out
    for name in PAPER_SCENARIOS:
        with Store.open(out / name / DB_NAME) as store:
            assert [(r.status, r.births) for r in store.runs()] == [("finished", 16)] * 2
    assert (out / "report" / "fitness_over_births.png").stat().st_size > 0


@pytest.mark.slow
def test_study_on_ray_gives_the_local_databases(tmp_path: Path) -> None:
    pytest.importorskip("ray")
    common = ["--runs", "2", "--births", "16", "--workers", "2", *TINY]
    assert main(["study", "--out", str(tmp_path / "ray"), "--evaluator", "ray", *common]) == 0
    assert main(["study", "--out", str(tmp_path / "local"), *common]) == 0
    tables = ("robots", "fitness", "transitions", "population", "diversity", "failures")
    for name in PAPER_SCENARIOS:
        assert (dump_results(tmp_path / "ray" / name / DB_NAME, tables)
                == dump_results(tmp_path / "local" / name / DB_NAME, tables)), name


def test_tensorboard_logs_each_run_under_its_experiment_and_quiet_lists_no_files(
        fake_physics: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("tensorboard", reason="TensorBoard logging needs the tensorboard package")
    pytest.importorskip("torch", reason="TensorBoard logging writes with torch's SummaryWriter")
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    out, tb = tmp_path / "study", tmp_path / "tb"
    assert main(["study", "--out", str(out), "--runs", "2", "--births", "12", *TINY, "--only",
                 "scenario1", "scenario3", "--no-estimate", "--tensorboard", str(tb), "-q"]) == 0
    assert sorted(p.relative_to(tb).as_posix() for p in tb.glob("*/*")) == [
        "scenario1/run0", "scenario1/run1", "scenario3/run0", "scenario3/run1"]
    acc = EventAccumulator(str(tb / "scenario1" / "run1"))
    acc.Reload()
    steps = [e.step for e in acc.Scalars("population/size")]
    assert steps == [4, 8, 12]  # each commit point once: the finished event is not written again
    printed = capsys.readouterr().out
    assert "open in a browser: " in printed and ".png" not in printed and ".csv" not in printed


def test_tensorboard_beside_a_file_is_refused_before_any_work(
        fake_physics: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "tb").write_text("a file, not a folder")
    out = tmp_path / "study"
    assert main(["study", "--out", str(out), "--only", "scenario1", "--no-estimate",
                 "--tensorboard", str(tmp_path / "tb"), *TINY]) == 2
    err = capsys.readouterr().err
    assert "--tensorboard" in err and "is a file" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()
