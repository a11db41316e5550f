"""Layering: the pure packages (``revolve_env.body``, ``evolution``) never import pybullet.

Two checks: a static one over every module's import statements (direct imports, including ones
inside functions), and a dynamic one that imports every module of ``revolve_env.body`` in a fresh
interpreter and looks for pybullet in ``sys.modules`` (catching indirect imports too).
"""

from __future__ import annotations

import ast
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PURE_PACKAGES = ("revolve_env/body", "evolution")
FORBIDDEN = ("pybullet", "pybullet_data", "pybullet_utils", "revolve_env.world")


def _imports(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.append((node.lineno, node.module))
            # ``from revolve_env import world`` names the world package too.
            found += [(node.lineno, f"{node.module}.{alias.name}") for alias in node.names]
    return found


def _modules() -> list[Path]:
    return sorted(p for pkg in PURE_PACKAGES for p in (ROOT / pkg).rglob("*.py"))


def test_the_pure_packages_exist() -> None:
    assert (ROOT / "revolve_env/body/robot.py").is_file()
    assert (ROOT / "evolution/__init__.py").is_file()


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(ROOT)))
def test_module_does_not_import_the_physics_engine(path: Path) -> None:
    bad = [
        f"line {line}: import {name}" for line, name in _imports(path)
        if any(name == f or name.startswith(f + ".") for f in FORBIDDEN)
    ]
    assert not bad, f"{path.relative_to(ROOT)} imports the physics layer: {bad}"


def test_importing_all_of_body_loads_no_physics_engine() -> None:
    import revolve_env.body

    names = [m.name for m in pkgutil.walk_packages(revolve_env.body.__path__, "revolve_env.body.")]
    code = (
        "import importlib, sys\n"
        f"for name in {names!r}:\n"
        "    importlib.import_module(name)\n"
        "bad = sorted(m for m in sys.modules if m.split('.')[0] == 'pybullet'"
        " or m.startswith('revolve_env.world'))\n"
        "print(','.join(bad))\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            cwd=ROOT, timeout=900, check=True)  # a hang's bound
    assert result.stdout.strip() == "", f"importing revolve_env.body loaded: {result.stdout}"
