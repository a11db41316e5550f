"""The MuJoCo backend: the same model, rules and sensors as pybullet; exact births and deaths;
contained blow-ups; the ``engine=`` parameter everywhere."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from world_robots import every_part, lone_core, snake, spider

from revolve_env import evaluate, example, population_env
from revolve_env.body.parts import SERVO
from revolve_env.body.robot import Node, PartType, Robot
from revolve_env.world import World, WorldConfig, build_model, engines, require_engine
from revolve_env.world.backend import EngineUnavailableError

mujoco = pytest.importorskip("mujoco", reason="the 'mujoco' package is not installed: "
                                              "the MuJoCo backend cannot be tested")

MJ = WorldConfig(engine="mujoco")


def test_the_compiled_model_has_the_engine_neutral_masses_inertias_boxes_and_joints() -> None:
    robot = every_part()
    model = build_model(robot)
    with World(MJ) as world:
        h = world.add_robot(robot)
        m = world.backend._model  # type: ignore[attr-defined]
        ids = world.backend._robots[0].bodies  # type: ignore[attr-defined]
        for link, body in zip(model.links, ids, strict=True):
            assert m.body_mass[body] == pytest.approx(link.mass, rel=1e-12)
            np.testing.assert_allclose(m.body_ipos[body], link.com, atol=1e-12)
            np.testing.assert_allclose(np.sort(m.body_inertia[body]),
                                       np.sort(link.inertia_diagonal), rtol=1e-9)
            geoms = np.flatnonzero(m.geom_bodyid == body)
            np.testing.assert_allclose(m.geom_size[geoms], link.box_half_extents, atol=1e-12)
            np.testing.assert_allclose(m.geom_pos[geoms], link.box_centers, atol=1e-12)
        assert world.total_mass(h) == pytest.approx(model.mass, rel=1e-9)
        hinges = [j for j in range(m.njnt) if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
        assert len(hinges) == 2 and not m.jnt_limited[hinges].any()  # no limits, as in pybullet
        assert m.nu == world.n_outputs(h) == 1
        assert m.actuator_forcerange[0].tolist() == [-SERVO.max_torque, SERVO.max_torque]
        world.step(30)
        assert world.blow_up(h) is None


def test_robot_is_dropped_from_drop_height_and_settles_on_the_ground() -> None:
    with World(MJ) as world:
        h = world.add_robot(lone_core(), position=(0.5, -0.25), drop_height=0.1)
        half = 0.0465 / 2
        assert world.core_position(h) == pytest.approx([0.5, -0.25, 0.1 + half])
        world.step(60)
        assert world.core_position(h) == pytest.approx([0.5, -0.25, half], abs=2e-3)


def test_servo_follows_robogens_law_within_its_speed_limit() -> None:
    with World(MJ) as world:
        h = world.add_robot(spider())
        world.step(30)
        start = world.joint_angles(h)
        world.set_targets(h, np.full(8, 0.5))
        world.step(1)
        moved = np.abs(world.joint_angles(h) - start)
        assert np.all(moved <= SERVO.max_velocity * world.config.control_period * 1.05)
        world.step(60)
        np.testing.assert_allclose(world.joint_angles(h), math.radians(22.5), atol=math.radians(1))
        world.set_targets(h, np.full(8, -3.0))  # clipped to -1 = -45 degrees
        world.step(60)
        np.testing.assert_allclose(world.joint_angles(h), -math.radians(45), atol=math.radians(1))


def _table_with_touch_feet() -> Robot:
    def leg(i: int) -> Node:
        from world_robots import _in
        touch = Node(PartType.TOUCH_SENSOR, neurons=_in(f"touch{i}", 2))
        return Node(PartType.PARAMETRIC_BAR, params=(0.06, -90.0, 0.0), children=((1, touch),))

    from world_robots import core
    return Robot(core(tuple((i, leg(i)) for i in range(4))))


def test_touch_imu_and_light_sensors() -> None:
    with World(WorldConfig(engine="mujoco", light_position=(1.0, 0.0, 0.05))) as world:
        table = world.add_robot(_table_with_touch_feet(), position=(0.0, -1.0), drop_height=0.2)
        facing = world.add_robot(every_part())
        away = world.add_robot(every_part(), position=(0.0, 1.0), yaw=math.pi)
        world.step(1)
        assert world.read_sensors(table)[6:].tolist() == [0.0] * 8  # falling
        light = 6  # after the IMU
        a = world.read_sensors(facing)[light]
        assert 0.0 < a <= 1.0 and world.read_sensors(away)[light] == 0.0
        world.step(90)
        assert world.read_sensors(table)[6:].tolist() == [1.0] * 8  # on its four feet
        imu = world.read_sensors(facing)[:6]
        np.testing.assert_allclose(imu[:3], [0, 0, 9.81], atol=0.05)  # at rest: +g up
        np.testing.assert_allclose(imu[3:], 0.0, atol=0.05)
        falling = world.add_robot(lone_core(), position=(2, 0), drop_height=1.0)
        world.step(3)
        np.testing.assert_allclose(world.read_sensors(falling)[:3], 0.0, atol=0.05)  # free fall


def test_robots_collide_with_each_other_but_not_with_themselves() -> None:
    with World(MJ) as world:
        below = world.add_robot(lone_core())
        above = world.add_robot(lone_core(), drop_height=0.2)
        snake_h = world.add_robot(snake(), position=(1.0, 0.0))  # overlapping hinge boxes
        world.step(90)
        assert world.core_position(above)[2] == pytest.approx(0.0465 * 1.5, abs=5e-3)
        assert world.core_position(below)[2] == pytest.approx(0.0465 / 2, abs=5e-3)
        assert world.blow_up(snake_h) is None


def _drive(world: World, handles: list[int], i: int) -> None:
    for k, h in enumerate(handles):
        world.set_targets(h, np.sin(2 * np.pi * i / 60 + k + np.arange(world.n_outputs(h))))


def _run_survivors(birth: tuple[float, float] | None) -> np.ndarray:
    """Two robots walking side by side; optionally a birth at ``birth`` after 30 periods."""
    with World(MJ) as world:
        a = world.add_robot(spider(), yaw=0.3)
        b = world.add_robot(example("gecko"), position=(0.6, 0.0))
        out = []
        for i in range(90):
            if i == 30 and birth is not None:
                row = world.rows([b])[0]
                before = [world.core_position(a), world.states.core_vel[row].copy(),
                          world.states.core_angvel[row].copy(), world.joint_angles(a)]
                c = world.add_robot(every_part(), position=birth, yaw=1.0)
                row = world.rows([b])[0]
                after = [world.core_position(a), world.states.core_vel[row],
                         world.states.core_angvel[row], world.joint_angles(a)]
                # the birth itself keeps the state bit for bit
                for x, y in zip(before, after, strict=True):
                    np.testing.assert_array_equal(x, y)
            _drive(world, list(world.handles), i)
            world.step()
            out.append(np.concatenate([world.core_position(a), world.read_sensors(a),
                                       world.core_position(b), world.read_sensors(b)]))
            if i == 60 and birth is not None:
                world.remove_robot(c)
        return np.array(out)


def test_a_birth_and_death_elsewhere_leave_the_survivors_trajectories_unchanged() -> None:
    # The birth keeps the survivors' state bit for bit (checked in _run_survivors). After it,
    # MuJoCo's discrete integrator solves all robots as one system, so where the newborn is
    # moves them by 1e-13 m (the order of the collision pass), and its presence by 2e-7 m (the
    # solver's convergence over more bodies; see the backend doc): far below a micrometre.
    near = _run_survivors((0.0, 0.8))  # a few centimetres from the others' footprints
    far = _run_survivors((30.0, 30.0))
    np.testing.assert_allclose(near, far, rtol=0, atol=1e-9)
    np.testing.assert_allclose(near, _run_survivors(None), rtol=0, atol=1e-6)


def test_births_and_deaths_leave_nothing_in_the_scene() -> None:
    def sizes(world: World) -> tuple[int, ...]:
        spec, m = world.backend._spec, world.backend._model  # type: ignore[attr-defined]
        return (len(spec.bodies), len(spec.excludes), len(spec.actuators), len(spec.geoms),
                m.nbody, m.ngeom, m.njnt, m.nu, m.nexclude)

    with World(MJ) as world:
        keep = world.add_robot(spider())
        counts = sizes(world)
        for i in range(5):
            h = world.add_robot(every_part(), position=(1.0 + i, 0.0))
            world.step(2)
            world.remove_robot(h)
        world.step(1)  # deaths are compiled away when the world next steps
        assert sizes(world) == counts
        assert world.body_count() == 2 and world.handles == (keep,)


def test_same_inputs_same_trajectory_and_reset_replays() -> None:
    def run(world: World) -> np.ndarray:
        h = world.add_robot(spider(), yaw=0.3)
        out = []
        for i in range(60):
            _drive(world, [h], i)
            world.step()
            out.append(np.concatenate([world.core_position(h), world.read_sensors(h)]))
        return np.array(out)

    with World(MJ) as world:
        first = run(world)
        world.add_robot(snake(), position=(1, 1))
        world.step(5)
        world.reset()
        assert world.time == 0.0 and world.handles == () and world.body_count() == 1
        np.testing.assert_array_equal(run(world), first)


def test_a_diverging_robot_is_flagged_and_contained(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # MuJoCo logs its NaN warning to ./MUJOCO_LOG.TXT
    def run(poison: bool) -> tuple[np.ndarray, str | None]:
        with World(MJ) as world:
            calm = world.add_robot(spider(), position=(1.0, 0.0))
            bad = world.add_robot(spider())
            path = []
            for i in range(20):
                if i == 10 and poison:  # a hinge of the second robot
                    world.backend._data.qvel[14 + 6] = np.nan  # type: ignore[attr-defined]
                _drive(world, [calm], i)
                world.step()
                path.append(world.core_position(calm))
            assert np.all(np.isfinite(world.core_position(bad)))
            return np.array(path), world.blow_up(bad)

    clean, none = run(False)
    contained, reason = run(True)
    assert none is None
    assert reason is not None and "non-finite" in reason
    # the neighbour carries on as if nothing had happened (to the last bits: one solve)
    np.testing.assert_allclose(contained, clean, rtol=0, atol=1e-12)


def test_a_robot_mujoco_refuses_is_a_clear_error_and_changes_nothing(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import dataclasses

    import revolve_env.world.world as world_module

    model = build_model(snake())
    root = dataclasses.replace(model.links[0], box_half_extents=-model.links[0].box_half_extents)
    bad = dataclasses.replace(model, links=(root, *model.links[1:]))
    with World(MJ) as world:
        keep = world.add_robot(spider())
        world.step(3)
        before = world.core_position(keep)
        monkeypatch.setattr(world_module, "build_model", lambda robot: bad)
        with pytest.raises(ValueError, match="MuJoCo cannot build this robot: .*size"):
            world.add_robot(snake(), position=(1.0, 0.0))
        assert world.handles == (keep,) and world.body_count() == 2
        np.testing.assert_array_equal(world.core_position(keep), before)
        world.step(3)
        assert world.blow_up(keep) is None


def test_the_walkers_walk_on_their_own_brains() -> None:
    for name in ("spider", "gecko"):
        result = evaluate(example(name), engine="mujoco")
        assert result.blow_up is None
        s = float(np.linalg.norm(result.trajectory[-1, :2] - result.trajectory[0, :2]))
        assert s > 0.5, f"{name} moved {s:.2f} m straight in 12 s"


def test_every_example_evaluates_without_blow_up() -> None:
    for name in ("snake", "sensor_crawler", "bar_walker"):
        result = evaluate(example(name), engine="mujoco", seconds=4.0, insertion=1.0)
        assert result.blow_up is None and np.isfinite(result.fitness)


def test_engine_keyword_everywhere() -> None:
    robot = example("spider")
    a = evaluate(robot, engine="mujoco", seconds=1.0, insertion=0.5)
    b = evaluate(robot, config=WorldConfig(engine="mujoco"), seconds=1.0, insertion=0.5)
    assert a.fitness == b.fitness
    assert a.fitness == evaluate(robot, seconds=1.0, insertion=0.5).fitness  # the default
    assert a.fitness != evaluate(robot, engine="pybullet", seconds=1.0, insertion=0.5).fitness

    env = gym.make("revolve_env/Locomotion-v0", robot=robot, engine="mujoco", controller="brain",
                   evaluation_time=0.5, insertion_time=0.1)
    env.reset(seed=0)
    assert env.unwrapped._world.engine == "mujoco"  # type: ignore[attr-defined]
    env.step(env.action_space.sample())
    env.close()

    pop = population_env(engine="mujoco", initial_robots=[spider(), snake()], max_births=4)
    pop.reset(seed=0)
    assert pop.world.engine == "mujoco"
    pop.step({})
    born = pop.add_robot(every_part())
    pop.step({})
    pop.remove_robot(born)
    _, _, terminations, _, _ = pop.step({})
    assert terminations[born] and len(pop.agents) == 2
    pop.close()


def test_unknown_engine_and_missing_package_are_one_clear_error(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    with pytest.raises(ValueError, match="unknown physics engine 'bullet': choose one of"):
        World(WorldConfig(engine="bullet"))
    with pytest.raises(ValueError, match="unknown physics engine"):
        evaluate(example("spider"), engine="ode")
    with pytest.raises(ValueError, match="unknown physics engine"):
        gym.make("revolve_env/Locomotion-v0", robot=example("spider"), engine="ode")
    monkeypatch.setattr(engines, "TABLE", tuple(
        dataclasses.replace(e, package="no_such_mujoco", pip="no_such_mujoco")
        if e.name == "mujoco" else e for e in engines.TABLE))
    with pytest.raises(EngineUnavailableError, match="pip install no_such_mujoco"):
        require_engine("mujoco")
    with pytest.raises(EngineUnavailableError):
        population_env(engine="mujoco")


def test_render_gives_a_picture_or_says_why_not() -> None:
    with World(MJ) as world:
        world.add_robot(spider())
        try:
            image = world.render(64, 48)
        except RuntimeError as e:  # no OpenGL context here (MUJOCO_GL=egl or osmesa needed)
            assert "MuJoCo cannot render here" in str(e)
        else:
            assert image.shape == (48, 64, 3) and image.dtype == np.uint8 and image.std() > 0


def test_locomotion_env_conformance_on_mujoco() -> None:
    from gymnasium.utils.env_checker import check_env

    from revolve_env import LOCOMOTION_ID
    from revolve_env.envs.checks import check_determinism

    kwargs: dict[str, Any] = {"robot": example("gecko"), "engine": "mujoco", "evaluation_time": 0.5,
              "insertion_time": 0.1}
    env = gym.make(LOCOMOTION_ID, **kwargs)
    check_env(env.unwrapped, skip_render_check=True)  # rendering needs an OpenGL context
    env.close()
    check_determinism(LOCOMOTION_ID, **kwargs)


@pytest.mark.slow
def test_memory_stays_flat_over_3000_births() -> None:
    """The issue's bound: RSS after 3,000 births within 50 MB of RSS after 300 (about 1 min)."""
    import resource

    def rss_mb() -> float:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * resource.getpagesize() / 2**20

    robots = [spider(), snake(), every_part(), example("gecko")]
    marks: dict[int, float] = {}
    with World(MJ) as world:
        alive: list[int] = []
        for birth in range(1, 3001):
            alive.append(world.add_robot(robots[birth % 4], position=(2.0 * (birth % 10), 0.0)))
            if len(alive) > 10:
                world.remove_robot(alive.pop(0))
            world.step(6)
            if birth in (300, 3000):
                marks[birth] = rss_mb()
    assert marks[3000] - marks[300] < 50.0, marks
