"""Export a robot for other simulators and for building it: URDF, SDF, bill of materials, JSON.

Run from the repository root: ``python examples/export_robot.py [OUT_DIR]`` (default: a temporary
folder, deleted at the end). From the command line: ``revolve export spider --format urdf``.
"""

import sys
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import revolve_env
from revolve_env.body import bill_of_materials, to_sdf, to_urdf

robot = revolve_env.example("spider")  # or revolve_env.load("my_robot.json")


def export(robot: revolve_env.Robot, out: Path, name: str) -> None:
    out.mkdir(parents=True, exist_ok=True)
    # Every rigid body is a link and every hinge a revolute joint; masses and inertias are the
    # ones the physics engines use. The robot is validated first (RobotError if impossible).
    (out / f"{name}.urdf").write_text(to_urdf(robot), encoding="utf-8")
    (out / f"{name}.sdf").write_text(to_sdf(robot), encoding="utf-8")
    revolve_env.save(robot, out / f"{name}.json")  # the robot itself, body and brain

    urdf = ET.parse(out / f"{name}.urdf").getroot()
    joints = urdf.findall("joint")
    revolute = [j for j in joints if j.get("type") == "revolute"]
    print(f"URDF: {len(urdf.findall('link'))} links, {len(joints)} joints "
          f"({len(revolute)} revolute)")
    sdf = ET.parse(out / f"{name}.sdf").getroot()
    print(f"SDF: {len(sdf.findall('.//link'))} links, {len(sdf.findall('.//joint'))} joints")

    # What to print and buy to build it.
    bom = bill_of_materials(robot)
    print(bom.to_text())
    print(f"{bom.n_parts} parts, {bom.servos} servos, {bom.mass * 1000:.1f} g")

    again = revolve_env.load(out / f"{name}.json")
    print(f"JSON round trip gives the same robot: {again == robot}")
    print(f"written to {out}: {', '.join(sorted(p.name for p in out.iterdir()))}")


if len(sys.argv) > 1:
    export(robot, Path(sys.argv[1]), "spider")
else:
    with tempfile.TemporaryDirectory() as tmp:
        export(robot, Path(tmp), "spider")
