"""An experiment's ground: ``[world] terrain`` (a name or a ``[world.terrain]`` table), stored
with the results in full, used by the offline evaluations and the online world, resumed exactly;
a flat run's stored config is as before; bad values refused in one line."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from experiment_fakes import Kill, kill_after, small, tiny_run
from experiment_fakes import dump_results as dump

from evolution import experiments
from evolution.evaluation import LocalEvaluator
from evolution.experiments import ConfigError, ExperimentConfig, load_config
from evolution.experiments.store.database import Store
from revolve_env.terrain import Crater, Flat, Rugged

pytest.importorskip("mujoco", reason="the mujoco package is not installed")

RUGGED = {"name": "rugged", "size": 10.0, "resolution": 0.05, "height": 0.03, "scale": 0.1,
          "seed": 4}


def tiny(name: str, terrain: Any, **changes: Any) -> ExperimentConfig:
    return small(tiny_run(name, births=8, world={"engine": "mujoco", "terrain": terrain},
                          **changes))


def test_world_terrain_is_a_name_or_a_table_kept_in_full(tmp_path: Path) -> None:
    toml = tmp_path / "c.toml"
    toml.write_text('preset = "quick"\n[world]\nengine = "mujoco"\n[world.terrain]\n'
                    'name = "rugged"\nheight = 0.03\nseed = 4\n')
    config = ExperimentConfig.from_toml(toml)
    assert config.world.terrain == RUGGED
    assert config.world.terrain_spec == Rugged(height=0.03, seed=4)
    assert config.to_dict()["world"] == {"engine": "mujoco", "terrain": RUGGED}
    assert ExperimentConfig.from_dict(config.to_dict()) == config
    assert load_config("quick", {"world": {"terrain": "crater"}}).world.terrain_spec == Crater()
    flat = load_config("quick", {"world": {"terrain": "flat"}})
    assert flat == load_config("quick") and flat.world.terrain_spec == Flat()
    assert "terrain" not in flat.to_dict()["world"]  # a flat run's stored config is as before


@pytest.mark.parametrize(("terrain", "changes", "message"), [
    ("lava", {}, r"world.terrain: unknown terrain 'lava': choose one of flat, rugged"),
    ({"name": "bowl", "depth": -1}, {}, r"world.terrain: bowl terrain: depth must be a positive"),
    ({"name": "bowl", "seed": 1}, {}, r"world.terrain: bowl terrain has no parameter 'seed'"),
    ({"name": "crater", "size": 3.0}, {"mode": "online", "birth_radius": 2.0},
     r"world.terrain: the birth disc: birth_radius \(2 m\) reaches past the edge of the crater"),
])
def test_a_bad_terrain_is_refused_in_one_line(terrain: Any, changes: dict[str, Any],
                                              message: str) -> None:
    with pytest.raises(ConfigError, match=message) as info:
        load_config("quick", {"world": {"terrain": terrain}, **changes})
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("name", ["scenario1", "scenario3"])
def test_a_run_on_a_terrain_stores_it_and_resumes_to_the_same_numbers(tmp_path: Path,
                                                                      name: str) -> None:
    """Offline (isolated evaluations) and online (one world, MuJoCo snapshots): the terrain
    reaches the physics (other numbers than on the plane) and a killed run resumes exactly."""
    serial = LocalEvaluator(1)
    experiments.run(tiny(name, RUGGED), tmp_path / "ref", evaluator=serial)
    experiments.run(tiny(name, "flat"), tmp_path / "flat", evaluator=serial)
    with Store.open(tmp_path / "ref" / "results.sqlite") as store:
        assert store.config["world"] == {"engine": "mujoco", "terrain": RUGGED}
    with pytest.raises(Kill):
        experiments.run(tiny(name, RUGGED), tmp_path / "killed", kill_after(3), evaluator=serial)
    experiments.resume(tmp_path / "killed", evaluator=serial)
    ref = dump(tmp_path / "ref" / "results.sqlite")
    assert dump(tmp_path / "killed" / "results.sqlite") == ref
    assert dump(tmp_path / "flat" / "results.sqlite") != ref


def test_infants_learn_on_the_run_s_terrain() -> None:
    """The Training Center of a run on a terrain evaluates candidates (CMA-ES) and trains and
    evaluates policies (SB3) on it."""
    for learning in ({"learner": "cma-es", "budget": 35.0, "popsize": 4},
                     {"learner": "sb3", "budget": 60.0}):
        center = load_config("quick", {"world": {"terrain": RUGGED},
                                       "learning": learning}).training_center()
        assert center is not None
        learner: Any = center.learner
        ground = learner.terrain if learning["learner"] == "sb3" else learner.evaluation.terrain
        assert ground == Rugged(height=0.03, seed=4)
    center = load_config("quick", {"learning": {"learner": "cma-es", "budget": 35.0,
                                                "popsize": 4}}).training_center()
    assert center is not None and center.learner.evaluation.terrain == Flat()  # type: ignore[attr-defined]
