"""Part geometry and slots against RoboGen's published part models."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from revolve_env.body.parts import PART_SPECS, SERVO, Box, PartGeometry, rotation_about
from revolve_env.body.robot import PartType

MM, G = 1e-3, 1e-3

# Masses straight from the RoboGen sources (grams): CoreComponentModel.cpp (CORE_MASS,
# BRICK_MASS), ActiveHingeModel.cpp (2 x MASS_SLOT 7 + MASS_FRAME 1.2 + MASS_SERVO 9),
# HingeModel.cpp (2 x MASS_SLOT 2 + 2 x MASS_FRAME 1), TouchSensorModel.cpp (3 boxes x 3),
# LightSensorModel.cpp (2).
SOURCE_MASS_G = {
    PartType.CORE: 55.4,
    PartType.BRICK: 14.9,
    PartType.ACTIVE_HINGE: 7 + 1.2 + 9 + 7,
    PartType.PASSIVE_HINGE: 2 + 1 + 1 + 2,
    PartType.TOUCH_SENSOR: 9.0,
    PartType.LIGHT_SENSOR: 2.0,
}
# Distance from the attachment face to the child slot (metres), recomputed from the RoboGen
# constants: slot plate 1.5 mm, 0.1 mm separations, rotation offsets measured from the joint.
SOURCE_LENGTH = {
    PartType.BRICK: 46.5 * MM,
    PartType.ACTIVE_HINGE: (1.5 + 0.1 + 14 + 20.5 + 0.1 + 1.5) * MM,
    PartType.PASSIVE_HINGE: (1.5 + 0.1 + 18.5 + 18.5 + 0.1 + 1.5) * MM,
}
SOURCE_JOINT_X = {
    PartType.ACTIVE_HINGE: (1.5 + 0.1 + 14) * MM,
    PartType.PASSIVE_HINGE: (1.5 + 0.1 + 18.5) * MM,
}


def _geometries() -> list[tuple[str, PartType, tuple[float, ...]]]:
    out = []
    for t, spec in PART_SPECS.items():
        if spec.params:
            lows = tuple(p.low for p in spec.params)
            highs = tuple(p.high for p in spec.params)
            for params in (spec.default_params(), lows, highs, (0.07, -45.0, 90.0)):
                out.append((f"{t.value}{params}", t, params))
        else:
            out.append((t.value, t, ()))
    return out


GEOMETRIES = _geometries()


def _on_face(box: Box, point: np.ndarray, normal: np.ndarray, tol: float = 1e-9) -> bool:
    """Whether ``point`` lies on a face of ``box`` whose outward normal is ``normal``."""
    local = box.rotation.T @ (point - box.center)
    n_local = box.rotation.T @ normal
    half = box.size / 2
    for k in range(3):
        for sign in (1.0, -1.0):
            face_normal = np.zeros(3)
            face_normal[k] = sign
            others = [i for i in range(3) if i != k]
            if (abs(local[k] - sign * half[k]) < tol
                    and all(abs(local[i]) <= half[i] + tol for i in others)
                    and np.allclose(n_local, face_normal, atol=1e-9)):
                return True
    return False


@pytest.mark.parametrize(("label", "part", "params"), GEOMETRIES, ids=[g[0] for g in GEOMETRIES])
def test_slots_lie_on_a_face_of_their_body_with_unit_outward_normals(
    label: str, part: PartType, params: tuple[float, ...]
) -> None:
    geom = PART_SPECS[part].geometry(params)
    assert set(geom.slots) == set(PART_SPECS[part].child_slots)
    for slot, s in geom.slots.items():
        assert np.linalg.norm(s.normal) == pytest.approx(1.0)
        assert np.linalg.norm(s.tangent) == pytest.approx(1.0)
        assert float(s.normal @ s.tangent) == pytest.approx(0.0, abs=1e-12)
        body_boxes = [b for b in geom.boxes if b.body == s.body]
        assert any(_on_face(b, s.position, s.normal) for b in body_boxes), f"slot {slot}"
        # Outward: a point just outside the slot is inside no box of the part.
        probe = s.position + 1e-4 * s.normal
        for b in geom.boxes:
            local = b.rotation.T @ (probe - b.center)
            assert np.any(np.abs(local) > b.size / 2), f"slot {slot} points into {b.name}"


@pytest.mark.parametrize(("label", "part", "params"), GEOMETRIES, ids=[g[0] for g in GEOMETRIES])
def test_parts_extend_from_their_attachment_face(
    label: str, part: PartType, params: tuple[float, ...]
) -> None:
    geom = PART_SPECS[part].geometry(params)
    corners = np.array([
        b.center + b.rotation @ (np.array(signs) * b.size / 2)
        for b in geom.boxes for signs in itertools.product((-1, 1), repeat=3)
    ])
    if part == PartType.CORE:
        assert np.allclose(corners.min(axis=0), -46.5 * MM / 2)
        assert np.allclose(corners.max(axis=0), 46.5 * MM / 2)
        return
    # Everything lies at x >= 0 and something touches the plane x = 0 (the attachment face).
    # Exception: a strongly tilted bar swings its far plate back past that plane (validation then
    # rejects it if it hits the parent), so for the bar only its first plate is checked.
    if part == PartType.PARAMETRIC_BAR:
        corners = corners[: 8 * 2]  # slot_a and the connection
    assert corners[:, 0].min() == pytest.approx(0.0, abs=1e-12)
    for b in geom.boxes:
        assert np.allclose(b.rotation @ b.rotation.T, np.eye(3))
        assert np.all(b.size > 0)


@pytest.mark.parametrize("part", list(SOURCE_MASS_G), ids=lambda t: t.value)
def test_masses_equal_robogen_numbers(part: PartType) -> None:
    assert PART_SPECS[part].mass() == pytest.approx(SOURCE_MASS_G[part] * G, rel=1e-12)


@settings(max_examples=30, deadline=None)
@given(length=st.floats(0.02, 0.10), tilt=st.floats(-90, 90), rotation=st.floats(0, 180))
def test_parametric_bar_mass_and_slot_follow_its_parameters(
    length: float, tilt: float, rotation: float
) -> None:
    spec = PART_SPECS[PartType.PARAMETRIC_BAR]
    # Two 1 g slot plates and 2 g per cm of connection (ParametricBrickModel.cpp).
    assert spec.mass((length, tilt, rotation)) == pytest.approx(2 * G + 2 * G * length / 0.01)
    geom = spec.geometry((length, tilt, rotation))
    slot = geom.slots[1]
    # Slot B sits beyond the connection: slot plate A, the bar, a separation and slot plate B,
    # turned upwards by the tilt about the pivot at the outer face of plate A.
    reach = length + 0.1 * MM + 1.5 * MM
    pivot = np.array([1.5 * MM, 0, 0])
    expected = pivot + reach * np.array([np.cos(np.radians(tilt)), 0, np.sin(np.radians(tilt))])
    assert np.allclose(slot.position, expected, atol=1e-12)
    conn = next(b for b in geom.boxes if b.name == "connection")
    assert conn.size[0] == pytest.approx(length)


@pytest.mark.parametrize("part", list(SOURCE_LENGTH), ids=lambda t: t.value)
def test_slot_distances_follow_robogen_dimensions(part: PartType) -> None:
    geom = PART_SPECS[part].geometry(())
    far = geom.slots[1]
    assert far.position[0] == pytest.approx(SOURCE_LENGTH[part], abs=1e-12)
    assert np.allclose(far.normal, [1, 0, 0])


def test_brick_slots_are_its_three_free_faces() -> None:
    geom = PART_SPECS[PartType.BRICK].geometry(())
    w = 46.5 * MM
    assert np.allclose(geom.slots[1].position, [w, 0, 0])
    assert np.allclose(geom.slots[2].position, [w / 2, w / 2, 0])
    assert np.allclose(geom.slots[3].position, [w / 2, -w / 2, 0])


def test_core_has_four_side_slots_and_six_imu_inputs() -> None:
    spec = PART_SPECS[PartType.CORE]
    geom = spec.geometry(())
    assert spec.n_inputs == 6 and spec.n_outputs == 0
    normals = {s: tuple(np.round(g.normal, 12)) for s, g in geom.slots.items()}
    assert normals == {0: (1, 0, 0), 1: (0, 1, 0), 2: (-1, 0, 0), 3: (0, -1, 0)}
    assert all(abs(g.normal[2]) < 1e-12 for g in geom.slots.values())  # no top/bottom slots


@pytest.mark.parametrize("part", [PartType.ACTIVE_HINGE, PartType.PASSIVE_HINGE],
                         ids=lambda t: t.value)
def test_hinges_have_one_joint_between_two_bodies(part: PartType) -> None:
    geom: PartGeometry = PART_SPECS[part].geometry(())
    assert geom.joint is not None
    assert geom.joint.active == (part == PartType.ACTIVE_HINGE)
    assert geom.joint.anchor[0] == pytest.approx(SOURCE_JOINT_X[part], abs=1e-12)
    assert np.linalg.norm(geom.joint.axis) == pytest.approx(1.0)
    # The joint axis is across the part, never along it (it would be a roll, not a hinge).
    assert abs(geom.joint.axis[0]) < 1e-12
    assert {b.body for b in geom.boxes} == {0, 1}
    assert geom.slots[1].body == 1
    # RoboGen: active hinge about the slot plate's y axis, passive hinge about its z axis.
    expected_axis = [0, 1, 0] if part == PartType.ACTIVE_HINGE else [0, 0, 1]
    assert np.allclose(geom.joint.axis, expected_axis)


def test_only_active_hinges_have_outputs_and_only_sensors_inputs() -> None:
    outputs = {t for t, s in PART_SPECS.items() if s.n_outputs}
    inputs = {t: s.n_inputs for t, s in PART_SPECS.items() if s.n_inputs}
    assert outputs == {PartType.ACTIVE_HINGE}
    assert inputs == {PartType.CORE: 6, PartType.TOUCH_SENSOR: 2, PartType.LIGHT_SENSOR: 1}


def test_servo_matches_robogen_servo_motor() -> None:
    # ServoMotor.cpp: 1.8 kg-cm maximum torque, 100 rpm, +-45 degrees.
    assert SERVO.max_torque == pytest.approx(1.8 * 9.81 / 100)
    assert SERVO.max_velocity == pytest.approx(100 / 60 * 2 * np.pi)
    assert SERVO.range_deg == 45.0


@settings(max_examples=30, deadline=None)
@given(axis=st.sampled_from(["x", "y", "z"]), deg=st.floats(-360, 360))
def test_rotation_about_is_a_proper_rotation(axis: str, deg: float) -> None:
    r = rotation_about(axis, deg)
    assert np.allclose(r @ r.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(r) == pytest.approx(1.0)
    e = {"x": 0, "y": 1, "z": 2}[axis]
    assert np.allclose(r[:, e], np.eye(3)[e])  # the axis is fixed
