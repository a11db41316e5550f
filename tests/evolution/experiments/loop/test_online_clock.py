"""The online engine takes insertion and maturity from its world's clock (one clock)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from experiment_fakes import FakeWorld, fake_evaluate, small

from evolution import experiments
from evolution.evaluation import LocalEvaluator
from evolution.experiments import ExperimentConfig, RobotStatus, Store, preset


class NeverMature(FakeWorld):
    """A world whose clock says no robot ever comes of age (whatever its age in seconds)."""

    def advance_to(self, t: float) -> dict[int, RobotStatus]:
        return {k: s._replace(mature=False) for k, s in super().advance_to(t).items()}


def never_mature(config: ExperimentConfig, seed: int) -> Any:
    return NeverMature(config, seed)


def test_a_robot_matures_when_its_world_says_so(tmp_path: Path) -> None:
    config = small(preset("scenario3", runs=1, births=24, diversity_interval=0))
    serial = LocalEvaluator(workers=1, function=fake_evaluate)
    experiments.run(config, tmp_path / "a", evaluator=serial, world_factory=never_mature)
    with Store.open(tmp_path / "a" / "results.sqlite") as store:
        robots = store.robots(0)
        assert len(robots) == 24
        # No robot is fertile: every newborn after the first ones is random, for want of parents.
        assert all(r.parent_a is None for r in robots)
        assert {f.kind for f in store.failures(0)} >= {"no-parents"}
        assert not [t for t in store.transitions(0) if t.target.value == "maturity"]
        infancy = [t for t in store.transitions(0) if t.target.value == "infancy"]
        born = {r.robot_id: r.birth_time for r in robots}
        # stamped at birth + insertion
        assert infancy and all(t.time == (born[t.robot_id] or 0.0) + config.insertion
                               for t in infancy)
