"""The import graph: no circles, and every import runs down the layers, never up.

The layers, bottom up (a module may import its own layer and the ones below it):

======================== =================================================================
layer                     packages
======================== =================================================================
description               ``revolve_env.body``
brain                     ``revolve_env.brain`` (and the compiled ``revolve_env._controller``)
fitness, tasks, terrain   ``revolve_env.fitness``, ``revolve_env.tasks`` (what a robot is scored
                          on), ``revolve_env.terrain`` (the ground it walks on, pure data)
physics world             ``revolve_env.world`` (the only code that imports a physics engine)
env adapters              ``revolve_env.evaluation``, ``revolve_env.envs``, ``revolve_env``
evolutionary library      ``evolution`` itself: config, random robots, operators, selection,
                          diversity, lifecycle; it may import only the description layer
evaluation                ``evolution.evaluation``
learning                  ``evolution.learning``
experiments               ``evolution.experiments``
reporting                 ``evolution.reporting``
command line              ``evolution.cli``
======================== =================================================================

Every import statement counts: module level, inside functions and under ``TYPE_CHECKING``.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("revolve_env", "evolution")

# (prefix, layer); the longest matching prefix wins.
LAYERS: tuple[tuple[str, int], ...] = (
    ("revolve_env.body", 0),
    ("revolve_env.brain", 1),
    ("revolve_env._controller", 1),
    ("revolve_env.fitness", 2),
    ("revolve_env.tasks", 2),
    ("revolve_env.terrain", 2),
    ("revolve_env.world", 3),
    ("revolve_env.evaluation", 4),
    ("revolve_env.envs", 4),
    ("revolve_env", 4),
    ("evolution", 5),
    ("evolution.evaluation", 6),
    ("evolution.learning", 7),
    ("evolution.experiments", 8),
    ("evolution.reporting", 9),
    ("evolution.cli", 10),
)
LIBRARY = 5
"""The pure evolutionary library may import only the description layer, not the physics."""


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    found = {}
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            found[_module_name(path)] = path
        for stub in (ROOT / package).rglob("*.pyi"):  # compiled extensions
            found.setdefault(_module_name(stub), stub)
    return found


MODULES = _modules()


def layer(module: str) -> int:
    """The layer of a project module (its longest matching prefix)."""
    best, rank = -1, -1
    for prefix, value in LAYERS:
        if (module == prefix or module.startswith(prefix + ".")) and len(prefix) > best:
            best, rank = len(prefix), value
    assert rank >= 0, f"{module} is in no layer"
    return rank


def imports(module: str) -> set[str]:
    """The project modules that ``module`` imports (a ``from P import name`` of a submodule
    counts as that submodule)."""
    path = MODULES[module]
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    is_package = path.name == "__init__.py"
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = module.split(".") if is_package else module.split(".")[:-1]
                anchor = anchor[: len(anchor) - node.level + 1]
                base = ".".join([*anchor, base] if base else anchor)
            names = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in MODULES else base
                     for alias in node.names]
        else:
            continue
        for name in names:
            while name and name not in MODULES:
                name = name.rpartition(".")[0]
            if name and name != module:
                found.add(name)
    return found


GRAPH = {module: imports(module) for module in MODULES}


def test_the_layers_cover_both_packages() -> None:
    assert "evolution.experiments.loop" in MODULES and "revolve_env.world" in MODULES
    for module in MODULES:
        layer(module)


@pytest.mark.parametrize("module", sorted(MODULES))
def test_imports_run_down_the_layers(module: str) -> None:
    own = layer(module)
    up = sorted(f"{name} (layer {layer(name)})" for name in GRAPH[module] if layer(name) > own)
    assert not up, f"{module} (layer {own}) imports up a layer: {', '.join(up)}"
    if own == LIBRARY:
        physics = sorted(name for name in GRAPH[module] if 0 < layer(name) < LIBRARY)
        assert not physics, f"the pure library module {module} imports {', '.join(physics)}"


def _cycle() -> list[str] | None:
    """One import circle among the project's modules, or None."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(module: str) -> list[str] | None:
        state[module] = 1
        path.append(module)
        for name in sorted(GRAPH[module]):
            if state.get(name) == 1:
                return [*path[path.index(name):], name]
            if name not in state:
                found = visit(name)
                if found:
                    return found
        path.pop()
        state[module] = 2
        return None

    for module in sorted(GRAPH):
        if module not in state:
            found = visit(module)
            if found:
                return found
    return None


def test_there_is_no_import_circle() -> None:
    cycle = _cycle()
    assert cycle is None, "import circle: " + " -> ".join(cycle or [])


def test_the_checker_sees_a_circle_and_an_upward_import() -> None:
    """The checks above can fail: a made-up graph with a circle and an upward edge."""
    saved = dict(GRAPH)
    try:
        GRAPH["evolution.config"] = {*saved["evolution.config"], "evolution.operators"}
        assert _cycle() is not None
    finally:
        GRAPH.clear()
        GRAPH.update(saved)
    assert layer("evolution.cli.commands") > layer("evolution.experiments.api") > layer("evolution")
