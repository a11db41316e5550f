"""``evolution.study``: the paper's five experiments in one folder, resumable, on one evaluator.

The runs use the fast physics stand-ins of ``experiment_fakes`` and tiny settings (4 robots,
16 births, 0.5 + 1 s evaluations), so every test takes a second or two.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

import pytest
from experiment_fakes import Kill, dump_results, fake_evaluate, fake_world

from evolution import experiments
from evolution.evaluation import LocalEvaluator
from evolution.experiments import ConfigError, ProgressEvent, StoreError, load_config
from evolution.experiments.app.study import STUDY_FILE, study
from evolution.experiments.loop.registry import PAPER_SCENARIOS
from evolution.experiments.store.database import DB_NAME, Store
from evolution.reporting import report

TINY: dict[str, Any] = {
    "population_size": 4, "offspring_size": 4, "insertion": 0.5, "evaluation_time": 1.0,
    "fertile_age": 1.5, "conception_interval": 1.0, "min_alive": 2, "diversity_interval": 4,
    "evolution": {"initial_parts_mean": 5.0, "initial_parts_sd": 2.0, "max_parts": 12},
}
SERIAL = LocalEvaluator(workers=1, function=fake_evaluate)


def _study(out: Path, **kw: Any) -> experiments.study.StudySummary:
    settings: dict[str, Any] = {"runs": 2, "births": 16, "overrides": TINY, "seed": 3,
                                "evaluator": SERIAL, "world_factory": fake_world}
    settings.update(kw)
    return study(out, **settings)


def _dumps(out: Path, names: tuple[str, ...] = PAPER_SCENARIOS) -> dict[str, Any]:
    return {name: dump_results(out / name / DB_NAME) for name in names}


def _kill(experiment: str, births: int) -> Any:
    """A progress callback that stops the study at ``experiment``'s commit point at ``births``."""
    def progress(name: str, event: ProgressEvent) -> None:
        if name == experiment and event.births >= births and not event.replaying:
            raise Kill(f"killed {name} at {event.births} births")
    return progress


def test_the_study_writes_every_experiment_as_run_would(tmp_path: Path) -> None:
    out = tmp_path / "study"
    events: list[tuple[str, int]] = []
    summary = _study(out, progress=lambda name, e: events.append((name, e.run_id)))
    assert sorted(p.name for p in out.iterdir()) == sorted([*PAPER_SCENARIOS, STUDY_FILE])
    assert [e.out_dir.name for e in summary.experiments] == list(PAPER_SCENARIOS)
    assert json.loads((out / STUDY_FILE).read_text()) == {
        "runs": 2, "births": 16, "seed": 3, "overrides": TINY,
        "experiments": list(PAPER_SCENARIOS)}
    for name in PAPER_SCENARIOS:
        with Store.open(out / name / DB_NAME) as store:
            assert [(r.status, r.births) for r in store.runs()] == [("finished", 16)] * 2
            assert store.config["name"] == name and store.config["seed"] == 3
        assert {(name, 0), (name, 1)} <= set(events)
    # Online runs go first: they are the longest.
    assert events[0][0] == "scenario3"
    # Each experiment holds what `revolve run NAME --runs 2 --births 16 --seed 3 --set ...` makes.
    config = load_config("scenario2", {**TINY, "runs": 2, "births": 16, "seed": 3})
    experiments.run(config, tmp_path / "alone", evaluator=SERIAL)
    assert dump_results(tmp_path / "alone" / DB_NAME) == dump_results(out / "scenario2" / DB_NAME)

    drawn = report(out, formats=("png",))
    assert drawn.out_dir == out / "report"
    assert all(path.stat().st_size > 0 for path in drawn.figures)
    with open(out / "report" / "summary.csv", newline="") as f:
        assert {row["experiment"] for row in csv.DictReader(f)} == set(PAPER_SCENARIOS)


def test_two_workers_run_the_runs_of_every_experiment_to_the_same_databases(
        tmp_path: Path) -> None:
    _study(tmp_path / "serial")
    events: list[str] = []
    with LocalEvaluator(workers=2, function=fake_evaluate) as pool:
        _study(tmp_path / "pool", evaluator=pool, progress=lambda name, e: events.append(name))
    assert _dumps(tmp_path / "pool") == _dumps(tmp_path / "serial")
    assert set(events) == set(PAPER_SCENARIOS)  # forwarded from the workers, tagged


def test_a_killed_study_continues_to_the_uninterrupted_databases(tmp_path: Path) -> None:
    reference = _dumps(_study(tmp_path / "ref").out_dir)
    out = tmp_path / "killed"
    with pytest.raises(Kill):
        _study(out, progress=_kill("scenario2", 9))
    with Store.open(out / "scenario2" / DB_NAME) as store:
        assert {r.status for r in store.runs()} == {"interrupted", "pending"}
    with Store.open(out / "baseline_b" / DB_NAME) as store:
        assert {r.status for r in store.runs()} == {"pending"}
    finished = _dumps(out, ("scenario1", "scenario3"))
    with pytest.raises(Kill):
        _study(out, progress=_kill("baseline_a", 12))
    seen: set[str] = set()
    _study(out, progress=lambda name, e: seen.add(name))
    assert seen == {"baseline_a", "baseline_b"}  # finished experiments are left alone
    assert _dumps(out, ("scenario1", "scenario3")) == finished
    assert _dumps(out) == reference


def test_other_settings_are_refused_before_anything_is_written(tmp_path: Path) -> None:
    out = tmp_path / "study"
    _study(out, experiments=("scenario1", "baseline_a"))
    before = (_dumps(out, ("scenario1", "baseline_a")), (out / STUDY_FILE).read_text())
    with pytest.raises(StoreError, match=r"other settings \(births: 16 stored, 20 now\)"):
        _study(out, births=20)
    with pytest.raises(StoreError, match=r"--set evolution.max_parts: 12 stored, 13 now"):
        _study(out, overrides={**TINY, "evolution": {**TINY["evolution"], "max_parts": 13}})
    with pytest.raises(StoreError, match=r"--set world.engine: not set stored, 'mujoco' now"):
        _study(out, overrides={**TINY, "world": {"engine": "mujoco"}})
    assert (_dumps(out, ("scenario1", "baseline_a")), (out / STUDY_FILE).read_text()) == before
    assert not (out / "scenario2").exists()

    # An experiment folder written by `revolve run` with other settings: named, nothing written.
    other = tmp_path / "other"
    config = load_config("scenario3", {**TINY, "runs": 2, "births": 20, "seed": 3})
    experiments.run(config, other / "scenario3", evaluator=SERIAL, world_factory=fake_world)
    with pytest.raises(StoreError, match=r"scenario3 holds results of 'scenario3' with other "
                                         r"settings \(births: 20 stored vs 16"):
        _study(other)
    assert sorted(p.name for p in other.iterdir()) == ["scenario3"]


def test_a_later_call_adds_experiments_and_may_change_how_runs_execute(tmp_path: Path) -> None:
    out = tmp_path / "study"
    _study(out, experiments=("scenario1",))
    with LocalEvaluator(workers=2, function=fake_evaluate) as pool:
        summary = _study(out, evaluator=pool)
    assert [len(e.runs) for e in summary.experiments] == [0, 2, 2, 2, 2]
    assert json.loads((out / STUDY_FILE).read_text())["experiments"] == list(PAPER_SCENARIOS)
    assert _dumps(out) == _dumps(_study(tmp_path / "ref").out_dir)


@pytest.mark.parametrize("kw, message", [
    ({"overrides": {"runs": 5}}, "runs is a setting of the study, not an override"),
    ({"overrides": {"name": "x"}}, "each experiment keeps its own name"),
    ({"overrides": {"evaluator": "ray"}}, "evaluator is a setting of the study"),
    ({"experiments": ("scenario1", "scenario1")}, "'scenario1' is given twice"),
    ({"experiments": ("scenario9",)}, "unknown scenario 'scenario9'"),
    ({"experiments": ()}, "one or more experiments"),
    ({"births": 3}, r"scenario1: births \(3\) must be >= population_size \(4\)"),
    ({"overrides": {**TINY, "evaluation_time": -1}}, "scenario1: evaluation_time must be > 0"),
])
def test_bad_settings_are_one_line_config_errors(tmp_path: Path, kw: dict[str, Any],
                                                 message: str) -> None:
    with pytest.raises(ConfigError, match=message) as error:
        _study(tmp_path / "study", **kw)
    assert "\n" not in str(error.value)
    assert not (tmp_path / "study").exists()


def test_the_facade_serves_study() -> None:
    import evolution

    assert evolution.study is study
