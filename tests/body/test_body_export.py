"""URDF and SDF export, and the bill of materials."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pybullet
import pytest
from hypothesis import HealthCheck, given, settings
from strategies import robots
from test_body_validate import overlapping_ring

from revolve_env.body import (
    EXAMPLES,
    SERVO,
    Node,
    PartType,
    Robot,
    RobotError,
    assemble,
    bill_of_materials,
    example,
    to_sdf,
    to_urdf,
)
from revolve_env.body.export import PASSIVE_HINGE_LIMIT_DEG, link_inertia


@pytest.fixture
def client() -> Iterator[int]:
    cid = pybullet.connect(pybullet.DIRECT)
    try:
        yield cid
    finally:
        pybullet.disconnect(physicsClientId=cid)


def _load(robot: Robot, cid: int, tmp_path: Path) -> int:
    # A fresh file name each time: pybullet caches file contents by name.
    path = tmp_path / f"robot{len(list(tmp_path.iterdir()))}.urdf"
    path.write_text(to_urdf(robot), encoding="utf-8")
    return pybullet.loadURDF(str(path), physicsClientId=cid,
                             flags=pybullet.URDF_USE_INERTIA_FROM_FILE)


@pytest.mark.parametrize("name", list(EXAMPLES))
def test_urdf_structure_matches_the_assembly(name: str) -> None:
    robot = example(name)
    asm = assemble(robot)
    root = ET.fromstring(to_urdf(robot))
    assert root.tag == "robot" and root.get("name") == name
    links = root.findall("link")
    joints = root.findall("joint")
    assert len(links) == len(asm.bodies)
    assert len(joints) == len(asm.bodies) - 1
    assert sum(len(link.findall("collision")) for link in links) == len(asm.boxes)
    assert sum(len(link.findall("visual")) for link in links) == len(asm.boxes)
    mass = sum(float(link.find("inertial/mass").get("value")) for link in links)
    assert mass == pytest.approx(asm.mass, rel=1e-9)
    servo_range = math.radians(SERVO.range_deg)
    passive_range = math.radians(PASSIVE_HINGE_LIMIT_DEG)
    n_active = 0
    for joint in joints:
        assert joint.get("type") == "revolute"
        limit = joint.find("limit")
        effort = float(limit.get("effort"))
        expected = servo_range if effort > 0 else passive_range
        n_active += effort > 0
        assert float(limit.get("upper")) == pytest.approx(expected)
        assert float(limit.get("lower")) == pytest.approx(-expected)
        if effort > 0:
            assert effort == pytest.approx(SERVO.max_torque, rel=1e-9)
            assert float(limit.get("velocity")) == pytest.approx(SERVO.max_velocity, rel=1e-9)
        axis = np.array([float(x) for x in joint.find("axis").get("xyz").split()])
        assert np.linalg.norm(axis) == pytest.approx(1.0)
    assert n_active == len(asm.active_joints())


@pytest.mark.parametrize("name", list(EXAMPLES))
def test_urdf_loads_in_pybullet_with_the_assembly_mass_and_poses(
    name: str, client: int, tmp_path: Path
) -> None:
    robot = example(name)
    asm = assemble(robot)
    body = _load(robot, client, tmp_path)
    n = pybullet.getNumJoints(body, physicsClientId=client)
    assert n == len(asm.bodies) - 1
    masses = [pybullet.getDynamicsInfo(body, j, physicsClientId=client)[0] for j in range(-1, n)]
    assert sum(masses) == pytest.approx(asm.mass, rel=1e-9)
    # pybullet reports each link's centre of mass in the world; it must match the assembly.
    base_com = np.array(pybullet.getBasePositionAndOrientation(body, physicsClientId=client)[0])
    assert np.allclose(base_com, link_inertia(asm, 0)[1], atol=1e-9)
    for j in range(n):
        info = pybullet.getJointInfo(body, j, physicsClientId=client)
        link = info[12].decode()
        index = int(link.split("_")[0].removeprefix("link"))
        com = np.array(pybullet.getLinkState(body, j, physicsClientId=client)[0])
        assert np.allclose(com, link_inertia(asm, index)[1], atol=1e-9), link
        assert masses[j + 1] == pytest.approx(asm.body_mass(index), rel=1e-9)
        assert info[2] == pybullet.JOINT_REVOLUTE


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                 HealthCheck.function_scoped_fixture])
@given(robot=robots(max_parts=6))
def test_any_valid_robot_exports_and_loads(robot: Robot, client: int, tmp_path: Path) -> None:
    ET.fromstring(to_sdf(robot))
    body = _load(robot, client, tmp_path)
    n = pybullet.getNumJoints(body, physicsClientId=client)
    total = sum(pybullet.getDynamicsInfo(body, j, physicsClientId=client)[0]
                for j in range(-1, n))
    assert total == pytest.approx(assemble(robot).mass, rel=1e-9)


@pytest.mark.parametrize("name", list(EXAMPLES))
def test_sdf_is_a_gazebo_model_matching_the_assembly(name: str) -> None:
    robot = example(name)
    asm = assemble(robot)
    root = ET.fromstring(to_sdf(robot))
    assert root.tag == "sdf" and root.get("version") == "1.6"
    model = root.find("model")
    assert model is not None and model.get("name") == name
    links = model.findall("link")
    joints = model.findall("joint")
    assert len(links) == len(asm.bodies)
    assert len(joints) == len(asm.bodies) - 1
    names = {link.get("name") for link in links}
    for joint in joints:
        assert joint.get("type") == "revolute"
        assert joint.findtext("parent") in names and joint.findtext("child") in names
        assert joint.find("axis/limit/upper") is not None
    for link in links:
        assert len(link.findtext("pose").split()) == 6
        for tag in ("collision", "visual"):
            for el in link.findall(tag):
                assert len(el.findtext("geometry/box/size").split()) == 3
        for visual in link.findall("visual"):
            rgba = [float(x) for x in visual.findtext("material/diffuse").split()]
            assert len(rgba) == 4 and all(0 <= c <= 1 for c in rgba)
    mass = sum(float(link.findtext("inertial/mass")) for link in links)
    assert mass == pytest.approx(asm.mass, rel=1e-9)


def test_link_inertia_of_one_box_is_the_solid_box_formula() -> None:
    # The core alone: one 46.5 mm cube of 55.4 g, I = m (2 a^2) / 12 on each axis.
    robot = Robot(Node(PartType.CORE, neurons=example("spider").body.neurons))
    mass, com, inertia = link_inertia(assemble(robot), 0)
    a = 0.0465
    assert mass == pytest.approx(0.0554)
    assert np.allclose(com, 0.0)
    assert np.allclose(inertia, np.eye(3) * 0.0554 * 2 * a * a / 12)


def test_export_refuses_an_invalid_robot() -> None:
    for export in (to_urdf, to_sdf, bill_of_materials):
        with pytest.raises(RobotError) as info:
            export(overlapping_ring())
        assert info.value.rule == "overlap"


def test_bill_of_materials_of_the_spider() -> None:
    bom = bill_of_materials(example("spider"))
    assert bom.count(PartType.CORE) == 1
    assert bom.count(PartType.BRICK) == 8
    assert bom.count(PartType.ACTIVE_HINGE) == 8
    assert bom.count(PartType.TOUCH_SENSOR) == 0
    assert bom.servos == 8
    assert bom.n_parts == 17
    # 55.4 g core + 8 x 14.9 g bricks + 8 x 24.2 g hinges (RoboGen masses).
    assert bom.mass == pytest.approx((55.4 + 8 * 14.9 + 8 * 24.2) / 1000)
    d = bom.to_dict()
    assert d["parts"] == {"core": 1, "brick": 8, "active_hinge": 8}
    assert d["servos"] == 8
    text = bom.to_text()
    assert "active_hinge" in text and "servos: 8" in text and "368.2 g" in text


@pytest.mark.parametrize("name", list(EXAMPLES))
def test_bill_of_materials_counts_every_part(name: str) -> None:
    robot = example(name)
    bom = bill_of_materials(robot)
    types = [n.type for _, n in robot.walk()]
    assert bom.n_parts == robot.num_parts()
    for t in PartType:
        assert bom.count(t) == types.count(t)
    assert bom.servos == types.count(PartType.ACTIVE_HINGE)
    assert bom.mass == pytest.approx(assemble(robot).mass)
    bars = [n.params[0] for _, n in robot.walk() if n.type == PartType.PARAMETRIC_BAR]
    assert list(bom.bar_lengths) == bars
