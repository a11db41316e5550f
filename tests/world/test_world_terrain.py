"""Terrains in the world: the same ground on both engines, placement on the highest ground under
a robot, isolated = batched and exact MuJoCo snapshots on a terrain, bad input refused."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import gymnasium
import numpy as np
import pytest
from world_robots import lone_core, spider

from revolve_env import evaluate, evaluate_many, example
from revolve_env.envs.population import PopulationEnv
from revolve_env.terrain import Crater, Flat, Rugged, TerrainError, make_terrain
from revolve_env.world import World, WorldConfig, build_model
from revolve_env.world.backend import SnapshotMismatchError

pytest.importorskip("mujoco", reason="the mujoco package is not installed")
import mujoco  # noqa: E402  (after the skip)

ENGINES = ["pybullet", "mujoco"]
BUMPY = Rugged(size=2.0, resolution=0.05, height=0.08, scale=0.08, seed=5)
"""Steep enough that a wrong triangle split or a turned grid shows by centimetres."""


def _ray_heights(config: WorldConfig, xy: np.ndarray) -> np.ndarray:
    """Heights of the ground under ``xy`` (n, 2) as the engine's own ray casts find them."""
    with World(config) as world:
        backend = world.backend
        if config.engine == "pybullet":
            from revolve_env.world.pybullet_backend import pb

            hits = pb.rayTestBatch([[x, y, 5.0] for x, y in xy], [[x, y, -5.0] for x, y in xy],
                                   physicsClientId=backend.client_id)  # type: ignore[attr-defined]
            return np.array([h[3][2] for h in hits])
        model, data = backend._model, backend._data  # type: ignore[attr-defined]
        mujoco.mj_forward(model, data)
        geom = np.zeros(1, np.int32)
        return np.array([5.0 - mujoco.mj_ray(model, data, np.array([x, y, 5.0]),
                                             np.array([0.0, 0.0, -1.0]), None, 1, -1, geom)
                         for x, y in xy])


@pytest.mark.parametrize("terrain", [BUMPY, make_terrain("crater"), make_terrain("bowl")],
                         ids=lambda t: t.name)
def test_both_engines_hold_the_terrain_s_own_ground(terrain: Rugged) -> None:
    """Ray casts on pybullet and MuJoCo meet h(x, y) (float32 heights in the engines)."""
    xy = np.random.default_rng(0).uniform(-0.48 * terrain.size, 0.48 * terrain.size, (300, 2))
    expected = terrain.height_at(xy[:, 0], xy[:, 1])
    for engine in ENGINES:
        found = _ray_heights(WorldConfig(engine=engine, terrain=terrain), xy)
        np.testing.assert_allclose(found, expected, atol=1e-6, err_msg=engine)


def test_a_box_dropped_on_the_bumps_rests_at_the_same_height_on_both_engines() -> None:
    """The physical check: a lone core (a box) dropped at a few points settles as high on each
    engine (within contact penetration), and on the ground, not the plane."""
    points = [(-0.5, 0.3), (0.0, 0.0), (0.4, -0.6)]
    rest = {}
    for engine in ENGINES:
        with World(WorldConfig(engine=engine, terrain=BUMPY)) as world:
            handles = [world.add_robot(lone_core(), p) for p in points]
            world.step(120)
            rest[engine] = world.core_positions()[:, 2].copy()
            assert all(world.blow_up(h) is None for h in handles)
    np.testing.assert_allclose(rest["pybullet"], rest["mujoco"], atol=2e-3)
    ground = np.array([BUMPY.height_at(x, y) for x, y in points])
    assert (rest["mujoco"] > ground).all() and (rest["mujoco"] - ground < 0.1).all()


@pytest.mark.parametrize("engine", ENGINES)
def test_a_robot_is_dropped_above_the_highest_ground_under_its_footprint(engine: str) -> None:
    config = WorldConfig(engine=engine, terrain=BUMPY, drop_height=0.01)
    robot = spider()
    with World(config) as world:
        h = world.add_robot(robot, (0.3, -0.2), yaw=0.4)
        model = build_model(robot)
        top = BUMPY.ground_under(0.3, -0.2, model.footprint_radius)
        assert world.core_position(h)[2] == pytest.approx(top + 0.01 - model.lowest_z, abs=1e-12)
        assert top > BUMPY.height_at(0.3, -0.2)  # not merely the ground under the core


def test_flat_is_the_default_and_changes_nothing() -> None:
    assert WorldConfig().terrain == Flat()
    robot = example("spider")
    a = evaluate(robot, seconds=2.0, insertion=0.5)
    b = evaluate(robot, seconds=2.0, insertion=0.5, terrain="flat")
    assert a.fitness == b.fitness
    np.testing.assert_array_equal(a.trajectory, b.trajectory)


@pytest.mark.parametrize("engine", ENGINES)
def test_batched_evaluations_on_a_terrain_are_each_robot_s_own(engine: str) -> None:
    robots = [example("spider"), example("gecko"), example("snake")]
    terrain = {"name": "rugged", "size": 4.0, "height": 0.03, "seed": 2}
    together = evaluate_many(robots, seconds=2.0, insertion=0.5, seeds=[1, 2, 3],
                             engine=engine, terrain=terrain)
    flat = evaluate_many(robots[:1], seconds=2.0, insertion=0.5, seeds=[1], engine=engine)
    for robot, seed, result in zip(robots, [1, 2, 3], together, strict=True):
        alone = evaluate(robot, seconds=2.0, insertion=0.5, seed=seed, engine=engine,
                         terrain=terrain)
        assert result.fitness == alone.fitness
        np.testing.assert_array_equal(result.trajectory, alone.trajectory)
    assert together[0].fitness != flat[0].fitness  # the terrain is really there


def test_a_restored_mujoco_world_on_a_terrain_steps_on_bit_for_bit() -> None:
    config = WorldConfig(engine="mujoco", terrain=BUMPY)
    rng = np.random.default_rng(3)

    def drive(world: World, periods: int, seed: int) -> np.ndarray:
        r = np.random.default_rng(seed)
        for _ in range(periods):
            world.set_all_targets(r.uniform(-1, 1, sum(world.n_outputs(h)
                                                       for h in world.handles)))
            world.step(1)
        return world.core_positions().copy()

    with World(config) as original, World(config) as twin:
        for p in rng.uniform(-0.6, 0.6, (3, 2)):
            original.add_robot(example("spider"), (float(p[0]), float(p[1])))
        drive(original, 50, 1)
        twin.restore(original.snapshot())
        np.testing.assert_array_equal(drive(original, 60, 2), drive(twin, 60, 2))
        snap = original.snapshot()
    with World(dataclasses.replace(config, terrain=Crater(size=2.0))) as other:
        with pytest.raises(SnapshotMismatchError, match="differs from the snapshot"):
            other.restore(snap)
        assert other.handles == ()


def test_an_env_s_newborns_land_on_the_ground_and_off_terrain_births_are_refused() -> None:
    terrain = Crater(size=3.0, height=0.1, radius=0.6, width=0.2)
    env = PopulationEnv(initial_robots=[example("spider"), example("gecko")], birth_radius=0.9,
                        engine="mujoco", terrain=terrain)
    try:
        env.reset(seed=0)
        assert env.config.terrain == terrain
        for status in env.statuses.values():
            x, y = status.birth_position
            assert status.position[2] > terrain.ground_under(x, y, 0.0)
        agents, state = list(env.agents), env.np_random.bit_generator.state
        with pytest.raises(TerrainError, match=r"add_robot \(robot_2\): a robot of footprint "
                           r"radius .* reaches past the edge of the crater terrain"):
            env.add_robot(example("snake"), position=(1.4, 0.0))
        assert env.agents == agents and env.np_random.bit_generator.state == state
        newborn = env.add_robot(example("snake"))  # placed by the rule, on the terrain
        x, y = env.status(newborn).birth_position
        assert env.status(newborn).position[2] > terrain.ground_under(x, y, 0.3)
    finally:
        env.close()
    with pytest.raises(TerrainError, match=r"the birth disc: birth_radius \(2 m\) reaches past "
                       r"the edge of the crater terrain \(size 3 m"):
        PopulationEnv(birth_radius=2.0, terrain=terrain)


def test_every_front_door_takes_a_terrain_and_refuses_a_bad_one() -> None:
    env = gymnasium.make("revolve_env/Locomotion-v0", robot=example("gecko"), terrain="bowl")
    try:
        assert env.unwrapped.config.terrain == make_terrain("bowl")  # type: ignore[attr-defined]
        env.reset(seed=0)
    finally:
        env.close()
    assert WorldConfig(terrain="crater").terrain == make_terrain("crater")  # type: ignore[arg-type]
    with pytest.raises(TerrainError, match="unknown terrain 'moon'"):
        evaluate(example("spider"), terrain="moon")
    with pytest.raises(TerrainError, match="unknown terrain 'moon'"):
        gymnasium.make("revolve_env/Locomotion-v0", robot=example("gecko"), terrain="moon")
    with pytest.raises(TerrainError, match="reaches past the edge of the rugged terrain"):
        evaluate(example("spider"), terrain={"name": "rugged", "size": 0.2, "resolution": 0.01})


def test_a_video_of_a_robot_on_a_terrain_moves_as_its_evaluation(tmp_path: Path) -> None:
    """``record_robot`` (``revolve show``) simulates on the terrain it is given."""
    from revolve_env.envs.recording import record_robot

    terrain = {"name": "crater", "height": 0.1, "radius": 0.3}
    video = record_robot(example("spider"), tmp_path / "s.gif", seconds=1.0, insertion=0.5,
                         fps=5.0, terrain=terrain)
    result = evaluate(example("spider"), seconds=1.0, insertion=0.5, terrain=terrain)
    flat = evaluate(example("spider"), seconds=1.0, insertion=0.5)
    assert video.fitness == pytest.approx(result.fitness, abs=1e-9)
    assert video.fitness != pytest.approx(flat.fitness, abs=1e-6)


def test_the_mjcf_of_a_world_on_a_terrain_compiles_to_the_very_model() -> None:
    """``World.to_mjcf`` writes the terrain's heightfield (rows in MJCF's order): the text
    compiles to the world's own model, bit for bit, and holds the terrain's heights."""
    import hashlib

    def digest(m: mujoco.MjModel) -> str:
        buffer = np.zeros(mujoco.mj_sizeModel(m), dtype=np.uint8)
        mujoco.mj_saveModel(m, None, buffer)
        return hashlib.sha256(buffer.tobytes()).hexdigest()

    with World(WorldConfig(engine="mujoco", terrain=BUMPY)) as world:
        world.add_robot(example("spider"), (0.3, 0.2))
        compiled = mujoco.MjModel.from_xml_string(world.to_mjcf())
        assert digest(compiled) == digest(world.backend._model)  # type: ignore[attr-defined]
    data = mujoco.MjData(compiled)
    mujoco.mj_forward(compiled, data)
    geom = np.zeros(1, np.int32)
    for x, y in [(0.31, -0.52), (-0.7, 0.44)]:
        found = 5.0 - mujoco.mj_ray(compiled, data, np.array([x, y, 5.0]),
                                    np.array([0.0, 0.0, -1.0]), None, 1, -1, geom)
        assert found == pytest.approx(float(BUMPY.height_at(x, y)), abs=1e-6)
