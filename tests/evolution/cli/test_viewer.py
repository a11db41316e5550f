"""``revolve show`` says what it shows; ``revolve watch`` replays and records an online run."""

from __future__ import annotations

import json
import shutil
import sqlite3
from argparse import Namespace
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from evolution.cli import main
from evolution.cli.robots import stored_robot
from evolution.cli.viewer import _plan, fitness_reasons, replay_online
from evolution.evaluation import evaluation_seed
from evolution.experiments import DB_NAME, ExperimentConfig, ReplayError, Store
from evolution.experiments.loop.records import LearningRecord
from revolve_env.body.robot import Activation, Layer, Neuron, Node, PartType, Robot
from revolve_env.body.serialize import to_json
from revolve_env.conditions import EvaluationConditions
from revolve_env.envs.recording import record_robot
from revolve_env.envs.watch import PALETTE

TINY = ["--set", "evaluation_time=1", "--set", "insertion=0.5", "--set", "fertile_age=1",
        "--set", "diversity_interval=0", "--set", "evolution.initial_parts_mean=5",
        "--set", "evolution.max_parts=12", "--workers", "1"]


def _error(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    """Run ``argv``, expect exit status 2 and exactly one line on stderr; return it."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def _usage_error(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    """Run ``argv``, expect argparse's exit status 2 and one line on stderr; return it."""
    capsys.readouterr()
    with pytest.raises(SystemExit) as done:
        main(argv)
    assert done.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


@pytest.fixture(scope="module")
def offline(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("offline")
    assert main(["run", "quick", "--births", "4", "--seed", "1", "--set", "population_size=2",
                 "--set", "offspring_size=2", *TINY, "--out", str(out)]) == 0
    return out / "quick"


@pytest.fixture(scope="module")
def online(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("online")
    assert main(["run", "scenario3", "--runs", "1", "--births", "6", "--set", "population_size=4",
                 "--set", "min_alive=2", "--set", "max_alive=8", "--set",
                 "conception_interval=1", *TINY, "--name", "world", "--out", str(out)]) == 0
    return out / "world"


def _args(db: Path, robot_id: int | None = None, **changes: object) -> Namespace:
    args = dict(db=str(db), robot=None, run=0, robot_id=robot_id, best=robot_id is None,
                seconds=None, insertion=None, engine=None)
    args.update(changes)
    return Namespace(**args)


def test_show_of_an_offline_robot_reproduces_its_stored_fitness_exactly(
        offline: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    capsys.readouterr()
    assert main(["show", "--db", str(offline), "--best", "--out", str(tmp_path / "b.gif")]) == 0
    out = capsys.readouterr().out
    stored = stored_robot(_args(offline))
    rec = stored.record
    assert (f"robot {rec.robot_id} of run 0 of quick (born at birth {rec.robot_id}, "
            f"t = {rec.birth_time:.1f} s)") in out
    assert "isolated 1 s evaluation after 0.5 s settling, mujoco" in out  # quick's engine
    assert "(the same)" in out and "differ" not in out
    video = record_robot(stored.robot, tmp_path / "again.gif", seconds=1.0, insertion=0.5,
                         fps=5.0, seed=evaluation_seed(stored.run_seed, rec.robot_id),
                         conditions=stored.config.evaluation)
    # The same path: the env sums its sliding window incrementally, evaluate() in one pass, so
    # the two fitnesses may differ in the last bit only.
    assert video.fitness == pytest.approx(rec.fitness, rel=1e-12, abs=1e-15)


def test_show_says_why_another_timing_differs(
        offline: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    capsys.readouterr()
    assert main(["show", "--db", str(offline), "--robot", "1", "--seconds", "0.5",
                 "--out", str(tmp_path / "r.gif")]) == 0
    out = capsys.readouterr().out
    assert "robot 1 of run 0 of quick" in out
    assert "because re-simulated over 0.5 + 0.5 s, stored over 0.5 + 1 s" in out


def test_reasons_come_from_the_stored_records(offline: Path) -> None:
    stored = stored_robot(_args(offline, robot_id=0))
    assert fitness_reasons(_plan(_args(offline, robot_id=0))) == []
    noisy = replace(stored, config=stored.config.replace(
        evaluation=EvaluationConditions(sensor_noise=0.1)))
    policy = LearningRecord(0, 0.0, "darwinian", None, 1.0, 2.0, 3, 4.0, 0,
                            json.dumps({"file": "policies/run0_robot0.pkl", "digest": "x"}))
    plan = replace(_plan(_args(offline, robot_id=0)), stored=replace(noisy, learning=policy),
                   engine="pybullet")
    reasons = "; ".join(fitness_reasons(plan))
    assert "other conditions" in reasons and "sensor_noise=0.1" in reasons
    assert "learned policy (policies/run0_robot0.pkl)" in reasons
    assert "re-simulated on pybullet, stored from mujoco" in reasons


def _walker(db: Path) -> tuple[int, float]:
    """The id and birth time of the first stored robot with an active hinge (show needs one)."""
    with Store.open(db / DB_NAME) as store:
        for record in store.robots(0):
            if any(n.type == PartType.ACTIVE_HINGE for _, n in record.robot().walk()):
                assert record.birth_time is not None
                return record.robot_id, record.birth_time
    raise AssertionError("no robot with an active hinge")


def test_show_of_an_online_robot_names_the_shared_world(
        online: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    robot_id, born = _walker(online)
    capsys.readouterr()
    assert main(["show", "--db", str(online), "--robot", str(robot_id), "--out",
                 str(tmp_path / "o.gif")]) == 0
    out = capsys.readouterr().out
    assert (f"robot {robot_id} of run 0 of world (born at birth {robot_id}, "
            f"t = {born:.1f} s)") in out
    assert "sliding-window sample in the shared online world at t = " in out
    reasons = fitness_reasons(_plan(_args(online, robot_id)))
    assert "shared online world" in "; ".join(reasons)


def test_watch_records_an_online_world_with_ids_and_fitness(
        online: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    capsys.readouterr()
    out = tmp_path / "world.gif"
    assert main(["watch", str(online), "--record", str(out), "--seconds", "1.5",
                 "--fps", "10"]) == 0
    said = capsys.readouterr().out
    assert "births replayed (the stored robots)" in said
    with Image.open(out) as gif:
        assert gif.n_frames == 15  # 1.5 s at 10 frames a second
        durations = []
        for k in range(gif.n_frames):
            gif.seek(k)
            durations.append(gif.info["duration"])
        frame = np.asarray(gif.convert("RGB"))
    assert sum(durations) == 1500
    legend = frame[18:60, :60]
    # the legend: white panel with a swatch per living robot, black text
    assert (legend == 255).all(axis=2).mean() > 0.3 and (legend < 40).all(axis=2).any()
    # each robot tagged with its id on the picture, in a palette colour of its own
    # (a tag's box is about 25 x 17 pixels, a legend's swatch 7 x 7)
    picture = frame.reshape(-1, 3).astype(int)
    tagged = [c for c in PALETTE
              if (np.abs(picture - np.round(255 * np.array(c))) <= 2).all(axis=1).sum() > 150]
    assert len(tagged) >= 2


def test_watch_records_at_the_size_asked(
        online: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "small.gif"
    assert main(["watch", str(online), "--record", str(out), "--seconds", "0.5", "--fps", "4",
                 "--size", "200x150"]) == 0
    with Image.open(out) as gif:
        assert gif.size == (200, 150)
    assert "WIDTHxHEIGHT" in _usage_error(capsys, ["watch", str(online), "--record", str(out),
                                                   "--size", "200"])


def test_watch_with_more_seconds_than_the_run_stops_at_its_end(
        online: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with Store.open(online / DB_NAME) as store:
        births = store.runs()[0].births
    capsys.readouterr()
    assert main(["watch", str(online), "--record", str(tmp_path / "w.gif"), "--fps", "5"]) == 0
    assert f"{births} births replayed" in capsys.readouterr().out


def test_windows_need_a_display_and_name_record(
        online: Path, offline: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    for target in ("spider", str(online)):
        line = _error(capsys, ["watch", target])
        assert "no display" in line and "--record" in line
    line = _error(capsys, ["watch", str(offline)])
    assert "offline experiment" in line and "revolve show --db" in line
    line = _error(capsys, ["watch", "spider", "--engine", "mujoco"])  # MuJoCo's window too
    assert "no display" in line and "--record" in line


def test_watch_records_a_robot(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "spider.gif"
    assert main(["watch", "spider", "--record", str(out), "--seconds", "0.5", "--insertion",
                 "0", "--fps", "10"]) == 0
    assert "spider: fitness re-simulated alone" in capsys.readouterr().out
    with Image.open(out) as gif:
        assert gif.n_frames == 5


def test_show_films_with_the_camera_and_size_asked(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    frames = {}
    for camera in ("track", "top"):
        out = tmp_path / f"{camera}.gif"
        assert main(["show", "spider", "--seconds", "0.2", "--insertion", "0", "--fps", "5",
                     "--size", "160x120", "--camera", camera, "--out", str(out)]) == 0
        with Image.open(out) as gif:
            assert gif.size == (160, 120)
            frames[camera] = np.asarray(gif.convert("RGB"))
    assert not np.array_equal(frames["track"], frames["top"])
    line = _usage_error(capsys, ["show", "spider", "--camera", "nowhere"])
    assert "--camera" in line and "track" in line


def test_a_replay_that_does_not_repeat_the_stored_run_is_refused(
        online: Path, tmp_path: Path) -> None:
    folder = tmp_path / "world"
    shutil.copytree(online, folder)
    con = sqlite3.connect(folder / DB_NAME)
    con.execute("UPDATE fitness SET fitness = fitness + 0.5 WHERE rowid = "
                "(SELECT MIN(rowid) FROM fitness)")
    con.commit()
    con.close()
    with Store.open(folder / DB_NAME) as store:
        config = store.config
        with pytest.raises(ReplayError, match="other fitness"):
            replay_online(ExperimentConfig.from_dict(config), 0, store, 30,
                          lambda frame, t: None)


def test_show_refuses_a_robot_without_an_active_hinge_in_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A body nothing can move is the input's fault: one line, exit 2, no video written."""
    imu = tuple(Neuron(f"imu{k}", Layer.INPUT, Activation.INPUT) for k in range(6))
    still = Robot(Node(PartType.CORE, neurons=imu, children=((0, Node(PartType.BRICK)),)))
    path = tmp_path / "still.json"
    path.write_text(to_json(still), encoding="utf-8")
    line = _error(capsys, ["show", str(path), "--out", str(tmp_path / "still.gif")])
    assert "no active hinge" in line
    assert not (tmp_path / "still.gif").exists()


@pytest.mark.parametrize("target", ["no_such_folder", "results/no_such_run/", "a/b"])
def test_watch_of_a_missing_folder_says_the_folder_does_not_exist(
        target: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / target
    assert main(["watch", str(missing)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"revolve watch: error: no such folder: {missing}"), err
    assert "robot file:" not in err and len(err.splitlines()) == 1


def test_watch_of_a_missing_robot_file_still_names_the_robot_file(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["watch", str(tmp_path / "robot.json")]) == 2
    assert "no such robot file" in capsys.readouterr().err
