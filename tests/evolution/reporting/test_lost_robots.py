"""Robots lost to blow-ups are lost, not 0 m: stored without fitness, counted apart, and older
databases (which stored 0.0 for robots lost in the shared world) report and resume the same.

The runs use the fake shared world of ``experiment_fakes`` where the fastest robots blow up
after their first fitness samples (scenario 3's own rules, 80 births, two runs).
"""

from __future__ import annotations

import csv
import shutil
import sqlite3
from pathlib import Path

import pytest
from experiment_fakes import (
    Kill,
    dump_results,
    fake_evaluate,
    fake_world_with_late_blow_ups,
    kill_after,
    small,
)

from evolution.evaluation import LocalEvaluator
from evolution.experiments import preset, resume, run
from evolution.experiments.store.database import DB_NAME, Store
from evolution.reporting import find_experiments, load_included, report
from evolution.reporting.tables import write_tables

SERIAL = LocalEvaluator(workers=1, function=fake_evaluate)
CONFIG = small(preset("scenario3", births=80, runs=2, diversity_interval=20))


def _as_older_versions_wrote(db: Path) -> int:
    """Store 0.0 for every robot lost to a blow-up, as before lost robots had no fitness."""
    with sqlite3.connect(db) as con:
        changed = con.execute("UPDATE robots SET fitness = 0.0 "
                              "WHERE death_cause LIKE 'blow-up:%'").rowcount
    con.close()
    return changed


def _lost_fitness(db: Path) -> list[float | None]:
    with sqlite3.connect(db) as con:
        rows = con.execute("SELECT fitness FROM robots WHERE death_cause LIKE 'blow-up:%' "
                           "ORDER BY run_id, robot_id").fetchall()
    con.close()
    return [f for (f,) in rows]


def _csv(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def online(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("lost")
    run(CONFIG, root / "new" / "scenario3", evaluator=SERIAL,
        world_factory=fake_world_with_late_blow_ups)
    run(small(preset("baseline_b", births=80, runs=2, diversity_interval=20)),
        root / "new" / "baseline_b", evaluator=SERIAL)
    return root


def test_lost_robots_are_counted_apart_and_never_as_zero(online: Path) -> None:
    db = online / "new" / "scenario3" / DB_NAME
    lost = _lost_fitness(db)
    assert lost and set(lost) == {None}
    (experiment, _) = find_experiments(online / "new")
    with Store.open(db) as store:
        blown = {(r.run_id, f.robot_id) for r in store.runs()
                 for f in store.failures(r.run_id, "blow-up")}
    assert sum(r.lost_robots for r in experiment.runs) == len(blown) > 0
    # Lost after their first fitness samples: births like the others, not failed births.
    assert sum(r.failed_births.size for r in experiment.runs) == 0
    assert [r.births for r in experiment.runs] == [80, 80]
    with Store.open(db) as store:  # never in a population after they blew up
        for run_id, robot_id in blown:
            died = store.robot(run_id, robot_id).death_time
            assert all(robot_id not in dict(members) for _, t, members
                       in store.population_snapshots(run_id) if t >= died)
    result = report(online / "new", formats=("png",))
    row = next(r for r in _csv(result.tables[0]) if r["experiment"] == "scenario3")
    assert (row["lost_robots"], row["failed_births"]) == (str(len(blown)), "0")
    tests = [r for r in _csv(result.tables[1]) if r["experiment_a"] == "scenario3"]
    assert tests and all(r["lost_a"] == str(len(blown)) for r in tests)
    text = (result.out_dir / "summary.md").read_text()
    shown = f"| scenario3 | scenario3 | outside any study | online | 2 | 80 | 80 | {len(blown)} |"
    assert shown in text


def test_an_older_database_with_zeros_reports_the_same(online: Path, tmp_path: Path) -> None:
    old = tmp_path / "old"
    shutil.copytree(online / "new", old, ignore=shutil.ignore_patterns("report"))
    assert _as_older_versions_wrote(old / "scenario3" / DB_NAME) > 0
    assert set(_lost_fitness(old / "scenario3" / DB_NAME)) == {0.0}
    tables = []
    for folder, out in ((online / "new", tmp_path / "new_tables"), (old, tmp_path / "old")):
        out.mkdir(exist_ok=True)
        paths, _ = write_tables(load_included(folder), out)
        tables.append([_csv(p) for p in paths if p.suffix == ".csv"])
    assert tables[0] == tables[1]
    assert any(row["lost_robots"] != "0" for row in tables[1][0])


def test_an_older_online_run_resumes_to_the_same_numbers(tmp_path: Path) -> None:
    whole = tmp_path / "whole"
    run(CONFIG, whole, evaluator=SERIAL, world_factory=fake_world_with_late_blow_ups)
    killed = tmp_path / "killed"
    with pytest.raises(Kill):
        run(CONFIG, killed, kill_after(50), evaluator=SERIAL,
            world_factory=fake_world_with_late_blow_ups)
    before = _as_older_versions_wrote(killed / DB_NAME)
    assert before > 0  # some robots were lost before the kill, stored as older versions did
    resume(killed, evaluator=SERIAL, world_factory=fake_world_with_late_blow_ups)
    lost = _lost_fitness(killed / DB_NAME)
    assert lost.count(0.0) == before and set(lost) == {0.0, None}  # after: no fitness
    for db in (whole / DB_NAME, killed / DB_NAME):
        _as_older_versions_wrote(db)
    assert dump_results(killed / DB_NAME) == dump_results(whole / DB_NAME)
