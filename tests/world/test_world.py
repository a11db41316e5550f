"""The pybullet World: building, masses, removal, servos, sensors, determinism, blow-ups."""

from __future__ import annotations

import math

import numpy as np
import pybullet as pb
import pytest
from world_robots import _in, brick, core, every_part, hinge, lone_core, snake, spider

from revolve_env.body.geometry import assemble
from revolve_env.body.parts import PART_SPECS, SERVO
from revolve_env.body.robot import Layer, Node, PartType, Robot
from revolve_env.world import World, WorldConfig, build_model, compiled
from revolve_env.world.pybullet_backend import PybulletBackend, pybullet_link_order

PYBULLET = WorldConfig(engine="pybullet")
"""This file's engine (MuJoCo, the default, has its own: test_mujoco.py)."""


def test_every_part_builds_with_its_joints_and_mass() -> None:
    robot = every_part()
    with World(PYBULLET) as world:
        h = world.add_robot(robot)
        assert world.n_outputs(h) == 1  # one active hinge
        assert world.n_inputs(h) == 6 + 1 + 2  # IMU, light, touch (traversal order)
        model = build_model(robot)
        assert len(model.passive_links) == 1
        expected = sum(
            PART_SPECS[n.type].mass(n.params) for _, n in robot.walk()
        )
        assert world.total_mass(h) == pytest.approx(expected, rel=1e-9)
        assert world.total_mass(h) == pytest.approx(assemble(robot).mass, rel=1e-9)
        world.step(30)
        assert world.blow_up(h) is None


def test_inertia_is_positive_and_centre_of_mass_inside_the_boxes() -> None:
    model = build_model(spider())
    for link in model.links:
        assert np.all(link.inertia_diagonal > 0)
        assert np.linalg.det(link.inertia_axes) == pytest.approx(1.0)
        lo = (link.box_centers - link.box_half_extents.max(axis=1, keepdims=True)).min(axis=0)
        hi = (link.box_centers + link.box_half_extents.max(axis=1, keepdims=True)).max(axis=0)
        assert np.all(link.com >= lo) and np.all(link.com <= hi)
    assert model.mass == pytest.approx(assemble(spider()).mass)


def test_robot_is_dropped_from_drop_height_and_settles_on_the_ground() -> None:
    with World(PYBULLET) as world:
        h = world.add_robot(lone_core(), position=(0.5, -0.25), drop_height=0.1)
        half = 0.0465 / 2
        assert world.core_position(h) == pytest.approx([0.5, -0.25, 0.1 + half])
        world.step(60)
        assert world.core_position(h) == pytest.approx([0.5, -0.25, half], abs=2e-3)


def test_removal_leaves_no_body_and_handles_are_not_reused() -> None:
    with World(PYBULLET) as world:
        assert world.body_count() == 1  # the ground
        a = world.add_robot(spider())
        b = world.add_robot(snake(), position=(1.0, 0.0))
        world.step(5)
        world.remove_robot(a)
        assert world.body_count() == 2
        assert world.handles == (b,)
        world.step(5)  # the survivor keeps going
        c = world.add_robot(spider(), position=(-1.0, 0.0))
        assert c not in (a, b)
        with pytest.raises(KeyError, match="no robot"):
            world.core_position(a)
        world.remove_robot(b)
        world.remove_robot(c)
        assert world.body_count() == 1


def test_servo_reaches_target_within_speed_limit() -> None:
    with World(PYBULLET) as world:
        h = world.add_robot(spider())
        world.step(30)
        start = world.joint_angles(h)
        world.set_targets(h, np.full(8, 0.5))
        world.step(1)
        moved = np.abs(world.joint_angles(h) - start)
        # one control period at most at the servo's top speed (plus solver slack)
        assert np.all(moved <= SERVO.max_velocity * world.config.control_period * 1.05)
        world.step(60)
        np.testing.assert_allclose(world.joint_angles(h), math.radians(22.5), atol=math.radians(1))
        world.set_targets(h, np.full(8, -3.0))  # clipped to -1 = -45 degrees
        world.step(60)
        np.testing.assert_allclose(world.joint_angles(h), -math.radians(45), atol=math.radians(1))


def _touch_before_hinge() -> Robot:
    # A touch sensor below a passive hinge, then an active hinge: the model lists the touch
    # halves last, while pybullet numbers a multibody's links depth first (halves before hinge).
    touch = Node(PartType.TOUCH_SENSOR, neurons=_in("touch", 2))
    passive = Node(PartType.PASSIVE_HINGE, children=((1, brick(((1, touch),))),))
    return Robot(core(((0, passive), (1, hinge("drive", 0, brick())))))


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_the_servo_drives_its_own_hinge_whatever_the_link_order(engine: str) -> None:
    # Before PHYSICS_REVISIONS["pybullet"] 2 the pybullet servo drove a welded touch half here
    # and the hinge stayed at 0 (and every link past the halves had another link's inertia).
    robot = _touch_before_hinge()
    model = build_model(robot)
    assert [model.links[i].fixed for i in range(1, len(model.links))] == [False, False, True, True]
    with World(WorldConfig(engine=engine)) as world:
        h = world.add_robot(robot)
        world.step(30)
        world.set_targets(h, np.array([1.0]))
        world.step(60)
        np.testing.assert_allclose(world.joint_angles(h), [math.radians(45)],
                                   atol=math.radians(1))


def test_pybullet_links_carry_their_own_mass_and_inertia() -> None:
    robot = _touch_before_hinge()
    model = build_model(robot)
    order = pybullet_link_order(model)
    assert order.tolist() == [1, 3, 4, 2]  # depth first: the halves hang below link 1
    with World(PYBULLET) as world:
        world.add_robot(robot)
        backend = world.backend
        assert isinstance(backend, PybulletBackend)
        body, cid = backend.body_id(0), backend.client_id
        for k, i in enumerate(order.tolist()):
            mass, _, inertia = pb.getDynamicsInfo(body, k, physicsClientId=cid)[:3]
            assert mass == pytest.approx(model.links[i].mass)
            np.testing.assert_allclose(inertia, model.links[i].inertia_diagonal, rtol=1e-9)
            parent = pb.getJointInfo(body, k, physicsClientId=cid)[16]
            assert parent == (-1 if model.links[i].parent == 0
                              else order.tolist().index(model.links[i].parent))


def test_bad_targets_are_rejected() -> None:
    with World(PYBULLET) as world:
        h = world.add_robot(spider())
        with pytest.raises(ValueError, match="8 active hinges"):
            world.set_targets(h, np.zeros(3))


def _leg_with_touch() -> Robot:
    # A table: four bars tilted straight down from the core's faces, a touch sensor at each foot.
    def leg(i: int) -> Node:
        touch = Node(PartType.TOUCH_SENSOR, neurons=_in(f"touch{i}", 2))
        return Node(PartType.PARAMETRIC_BAR, params=(0.06, -90.0, 0.0), children=((1, touch),))

    return Robot(core(tuple((i, leg(i)) for i in range(4))))


def test_touch_sensor_fires_on_ground_contact_only() -> None:
    with World(PYBULLET) as world:
        h = world.add_robot(_leg_with_touch(), drop_height=0.2)
        world.step(1)
        assert world.read_sensors(h)[6:].tolist() == [0.0] * 8  # falling
        world.step(90)
        touch = world.read_sensors(h)[6:]
        assert touch.tolist() == [1.0] * 8  # standing on all four feet, both halves each


def test_imu_at_rest_reads_gravity_and_no_rotation() -> None:
    with World(PYBULLET) as world:
        h = world.add_robot(spider(), yaw=0.7)
        world.step(60)
        imu = world.read_sensors(h)[:6]
        np.testing.assert_allclose(imu[:3], [0, 0, 9.81], atol=0.05)
        np.testing.assert_allclose(imu[3:], 0.0, atol=0.05)
        world.step(1)
        # a falling robot feels no specific force
        g = world.add_robot(lone_core(), position=(2, 0), drop_height=1.0)
        world.step(3)
        np.testing.assert_allclose(world.read_sensors(g)[:3], 0.0, atol=0.05)


def test_light_sensor_sees_the_light_only_when_facing_it() -> None:
    light_index = 6  # after the IMU; the light sensor sits on the front leg (slot 0)
    with World(WorldConfig(engine="pybullet", light_position=(1.0, 0.0, 0.05))) as world:
        facing = world.add_robot(every_part())
        away = world.add_robot(every_part(), position=(0.0, 1.0), yaw=math.pi)
        world.step(1)
        a = world.read_sensors(facing)[light_index]
        b = world.read_sensors(away)[light_index]
        assert 0.0 < a <= 1.0
        assert b == 0.0
        near = world.add_robot(every_part(), position=(0.7, 0.0))
        world.step(1)
        assert world.read_sensors(near)[light_index] > a  # closer is brighter


def test_same_inputs_same_trajectory() -> None:
    def run() -> np.ndarray:
        with World(PYBULLET) as world:
            h = world.add_robot(spider(), yaw=0.3)
            out = []
            for i in range(120):
                t = i / 60
                world.set_targets(h, np.sin(2 * np.pi * t + np.arange(8)))
                world.step()
                out.append(np.concatenate([world.core_position(h), world.read_sensors(h)]))
            return np.array(out)

    np.testing.assert_array_equal(run(), run())


def test_two_worlds_are_independent() -> None:
    with World(PYBULLET) as a, World(PYBULLET) as b:
        ha = a.add_robot(lone_core(), drop_height=0.5)
        hb = b.add_robot(lone_core(), drop_height=0.5)
        a.step(20)
        assert b.core_position(hb)[2] == pytest.approx(0.5 + 0.0465 / 2)
        assert a.core_position(ha)[2] < 0.5


def test_robots_collide_with_each_other() -> None:
    with World(PYBULLET) as world:
        below = world.add_robot(lone_core())
        above = world.add_robot(lone_core(), drop_height=0.2)
        world.step(90)
        # resting on top of the other core, not sunk through it
        assert world.core_position(above)[2] == pytest.approx(0.0465 * 1.5, abs=5e-3)
        assert world.core_position(below)[2] == pytest.approx(0.0465 / 2, abs=5e-3)


def test_blow_up_is_reported_not_raised() -> None:
    with World(WorldConfig(engine="pybullet", max_linear_speed=1.0)) as world:
        h = world.add_robot(spider(), drop_height=2.0)
        calm = world.add_robot(spider(), position=(1.0, 0.0))
        world.step(60)  # falls faster than 1 m/s
        reason = world.blow_up(h)
        assert reason is not None and "core speed" in reason
        assert world.blow_up(calm) is None
        world.step(1)  # stepping on is still safe
        assert world.blow_up(h) == reason  # the first reason sticks


def test_closed_world_refuses_work_and_disconnects() -> None:
    world = World(PYBULLET)
    cid = world.backend.client_id  # type: ignore[attr-defined]
    world.close()
    assert not pb.isConnected(physicsClientId=cid)
    with pytest.raises(RuntimeError, match="closed"):
        world.add_robot(lone_core())
    world.close()  # idempotent


def test_config_is_validated() -> None:
    with pytest.raises(ValueError, match="whole multiple"):
        WorldConfig(timestep=1 / 240, control_period=1 / 100)
    with pytest.raises(ValueError, match="friction"):
        WorldConfig(friction=-1.0)
    # non-finite values get the same clear error, not an OverflowError from round()
    for period in (float("inf"), float("nan"), 1e-9):
        with pytest.raises(ValueError, match="whole multiple"):
            WorldConfig(control_period=period)
    with pytest.raises(ValueError, match="drop_height"):
        WorldConfig(drop_height=float("nan"))
    with pytest.raises(ValueError, match="light_position"):
        WorldConfig(light_position=(float("nan"), 0.0, 0.1))
    assert WorldConfig().substeps == 4


def test_inputs_follow_the_input_neuron_layout() -> None:
    for robot in (spider(), every_part(), _leg_with_touch()):
        assert build_model(robot).n_inputs == len(robot.neurons_of(Layer.INPUT))
        assert build_model(robot).n_outputs == len(robot.neurons_of(Layer.OUTPUT))


def test_reset_world_replays_exactly() -> None:
    def run(world: World) -> np.ndarray:
        h = world.add_robot(spider())
        out = []
        for i in range(60):
            world.set_targets(h, np.cos(3 * i / 60 + np.arange(8)))
            world.step()
            out.append(world.core_position(h))
        return np.array(out)

    with World(PYBULLET) as world:
        first = run(world)
        world.add_robot(snake(), position=(1, 1))  # leftovers must not matter
        world.step(10)
        world.reset()
        assert world.time == 0.0 and world.handles == () and world.body_count() == 1
        np.testing.assert_array_equal(run(world), first)


def test_non_finite_targets_mark_a_blow_up_instead_of_raising() -> None:
    """A diverged controller (NaN outputs) is reported like a physics blow-up, never a crash."""
    with World(PYBULLET) as world:
        h = world.add_robot(spider())
        calm = world.add_robot(spider(), position=(1.0, 0.0))
        world.set_targets(h, np.full(world.n_outputs(h), np.nan))
        world.set_targets(calm, np.zeros(world.n_outputs(calm)))
        world.step(2)
        reason = world.blow_up(h)
        assert reason is not None and "non-finite hinge targets" in reason
        assert world.blow_up(calm) is None
        assert np.all(np.isfinite(world.core_position(h)))


def test_imu_readings_saturate_at_full_scale_and_nan_passes(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The world saturates the core IMU at +-16 g and +-2000 deg/s (the sensor's full scale), so
    every env and evaluation feeds the brains the same bounded values; NaN stays visible."""
    from revolve_env.body.parts import IMU_ACCEL_RANGE, IMU_GYRO_RANGE

    # the NumPy rules (pybullet's compiled ones: tests/world/test_pybullet_rules.py)
    monkeypatch.setattr(compiled, "rules", lambda c: None)
    with World(PYBULLET) as world:
        h = world.add_robot(spider())
        huge = np.array([[1e6, -1e6, 3.0, 1e4, -1e4, np.nan]])
        monkeypatch.setattr(World, "_imus", lambda self: huge)
        imu = world.read_sensors(h)[:6]
    assert imu[:3].tolist() == [IMU_ACCEL_RANGE, -IMU_ACCEL_RANGE, 3.0]
    assert imu[3:5].tolist() == [IMU_GYRO_RANGE, -IMU_GYRO_RANGE] and np.isnan(imu[5])
