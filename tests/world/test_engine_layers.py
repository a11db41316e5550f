"""Each physics engine is imported by its own backend modules and nowhere else."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
OWNERS = {
    "pybullet": ["revolve_env/world/pybullet_backend.py"],
    # one module imports MuJoCo, once its OpenGL backend is chosen (issue 31); the backend, the
    # scene it compiles, the batched scenes, the ground and the frames take it from there
    "mujoco": ["revolve_env/world/mujoco_gl.py"],
    # MuJoCo Warp and Warp itself: its isolated scenes (the warp extra)
    "mujoco_warp": ["revolve_env/world/warp_scenes.py"],
    "warp": ["revolve_env/world/warp_scenes.py"],
}
MUJOCO_USERS = ["revolve_env/world/compiled.py", "revolve_env/world/mujoco_backend.py",
                "revolve_env/world/mujoco_batch.py", "revolve_env/world/mujoco_scene.py",
                "revolve_env/world/mujoco_scenes.py", "revolve_env/world/mujoco_terrain.py",
                "revolve_env/world/mujoco_view.py", "revolve_env/world/warp_scenes.py"]


def _imported(path: Path) -> set[str]:
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    return names


@pytest.mark.parametrize("engine", sorted(OWNERS))
def test_only_its_backend_imports_an_engine(engine: str) -> None:
    importers = sorted(
        str(p.relative_to(ROOT)) for package in ("revolve_env", "evolution")
        for p in (ROOT / package).rglob("*.py") if engine in _imported(p)
    )
    assert importers == OWNERS[engine]


def test_mujoco_is_taken_only_from_the_module_that_chooses_its_opengl_backend() -> None:
    users = sorted(
        str(p.relative_to(ROOT)) for package in ("revolve_env", "evolution")
        for p in (ROOT / package).rglob("*.py") if "revolve_env.world.mujoco_gl" in {
            node.module for node in ast.walk(ast.parse(p.read_text(encoding="utf-8")))
            if isinstance(node, ast.ImportFrom)})
    assert users == MUJOCO_USERS


def test_a_world_loads_only_the_engine_it_uses() -> None:
    code = (
        "import sys\n"
        "from revolve_env.world import World, WorldConfig\n"
        "loaded = {m for m in ('pybullet', 'mujoco', 'warp', 'mujoco_warp') if m in sys.modules}\n"
        "assert not loaded, loaded\n"
        "World(WorldConfig(engine='pybullet')).close()\n"
        "assert 'pybullet' in sys.modules and 'mujoco' not in sys.modules\n"
        "assert 'warp' not in sys.modules and 'mujoco_warp' not in sys.modules\n"
    )
    subprocess.run([sys.executable, "-c", code], cwd=ROOT, check=True, capture_output=True)
