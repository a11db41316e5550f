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
rollout                   ``revolve_env.rollout`` (the one rollout every driver calls) and
                          ``revolve_env.conditions`` (starts and the noise rule, pure data)
env adapters              ``revolve_env.evaluation``, ``revolve_env.envs``, ``revolve_env``
evolutionary library      ``evolution`` itself: config, random robots, operators, selection,
                          diversity, lifecycle; it may import only the description layer
evaluation                ``evolution.evaluation``
learning                  ``evolution.learning``
experiments               ``evolution.experiments``, in three rooms of its own order (below)
reporting                 ``evolution.reporting``
command line              ``evolution.cli``
======================== =================================================================

Every import statement counts: module level, inside functions and under ``TYPE_CHECKING``. So do
imports by name: the string argument of ``importlib.import_module(...)`` or ``__import__(...)``,
and any string that is a dotted path of a project module (``"revolve_env.world.mujoco_backend"``,
``"package.module:Class"``), as in a registry table whose entries are imported when asked for.
One by-name edge is not held to the layers: a package's ``__init__`` serving names of its own
submodules lazily (a PEP 562 ``__getattr__`` table) imports them only when a user asks for such
a name, never when it is imported itself; it still counts for circles.

Inside ``evolution.experiments`` the rooms run one way too, bottom up: the loop
(``evolution.experiments.loop``: the run, which takes the store as an observer and reads it through
a protocol of its own), the store (``evolution.experiments.store``), the application
(``evolution.experiments.app`` and the package itself, which re-exports the public names). The loop
imports nothing of the store, by statement or by name.
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
    ("revolve_env._rollout", 3),
    ("revolve_env.conditions", 4),
    ("revolve_env.rollout", 4),
    ("revolve_env.evaluation", 5),
    ("revolve_env.envs", 5),
    ("revolve_env", 5),
    ("evolution", 6),
    ("evolution.evaluation", 7),
    ("evolution.learning", 8),
    ("evolution.experiments", 9),
    ("evolution.reporting", 10),
    ("evolution.cli", 11),
)
LIBRARY = 6
ROOMS: tuple[tuple[str, int], ...] = (
    ("evolution.experiments", 2),
    ("evolution.experiments.app", 2),
    ("evolution.experiments.store", 1),
    ("evolution.experiments.loop", 0),
)
"""The rooms of the experiments, bottom up (the longest matching prefix wins)."""
LOOP, STORE = "evolution.experiments.loop", "evolution.experiments.store"
"""The pure evolutionary library may import only the description layer, not the physics."""


def _module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules(root: Path = ROOT, packages: tuple[str, ...] = PACKAGES) -> dict[str, Path]:
    found = {}
    for package in packages:
        for path in (root / package).rglob("*.py"):
            found[_module_name(path, root)] = path
        for stub in (root / package).rglob("*.pyi"):  # compiled extensions
            found.setdefault(_module_name(stub, root), stub)
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


def room(module: str) -> int | None:
    """The room of an experiments module (``None`` outside ``evolution.experiments``)."""
    best, rank = -1, None
    for prefix, value in ROOMS:
        if (module == prefix or module.startswith(prefix + ".")) and len(prefix) > best:
            best, rank = len(prefix), value
    return rank


def _inside(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def _parse(path: Path) -> ast.Module:
    return ast.parse(path.read_text(encoding="utf-8"), filename=str(path))


def _known(name: str, module: str, modules: dict[str, Path]) -> str | None:
    """The project module ``name`` is (or is inside), unless it is ``module`` itself."""
    while name and name not in modules:
        name = name.rpartition(".")[0]
    return name if name and name != module else None


def imports(module: str, modules: dict[str, Path] = MODULES) -> set[str]:
    """The project modules that ``module`` imports (a ``from P import name`` of a submodule
    counts as that submodule)."""
    path = modules[module]
    is_package = path.name == "__init__.py"
    found: set[str] = set()
    for node in ast.walk(_parse(path)):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = module.split(".") if is_package else module.split(".")[:-1]
                anchor = anchor[: len(anchor) - node.level + 1]
                base = ".".join([*anchor, base] if base else anchor)
            names = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base
                     for alias in node.names]
        else:
            continue
        found |= {known for name in names if (known := _known(name, module, modules))}
    return found


def _is_import_call(node: ast.Call) -> bool:
    f = node.func
    return ((isinstance(f, ast.Name) and f.id in ("__import__", "import_module"))
            or (isinstance(f, ast.Attribute) and f.attr == "import_module"))


def imports_by_name(module: str, modules: dict[str, Path] = MODULES) -> set[str]:
    """The project modules that ``module`` names as strings to import (see the module doc)."""
    tree = _parse(modules[module])
    docstrings = {id(node.body[0].value) for node in ast.walk(tree)
                  if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef,
                                       ast.AsyncFunctionDef))
                  and node.body and isinstance(node.body[0], ast.Expr)
                  and isinstance(node.body[0].value, ast.Constant)}
    names: set[str] = set()
    for node in ast.walk(tree):
        if (isinstance(node, ast.Call) and _is_import_call(node) and node.args
                and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)):
            names.add(node.args[0].value)
        elif (isinstance(node, ast.Constant) and isinstance(node.value, str)
              and id(node) not in docstrings):
            path = node.value.partition(":")[0]
            if "." in path and path in modules:  # a dotted path, not a word like "evolution"
                names.add(path)
    return {known for name in names if (known := _known(name, module, modules))}


def _lazy_export(module: str, name: str, modules: dict[str, Path] = MODULES) -> bool:
    """Whether ``name`` is a submodule that the package ``module`` serves names of lazily."""
    return (modules[module].name == "__init__.py" and name.startswith(module + ".")
            and name not in imports(module, modules))


def graph(modules: dict[str, Path] = MODULES) -> dict[str, set[str]]:
    """Every module's imports, by statement and by name."""
    return {m: imports(m, modules) | imports_by_name(m, modules) for m in modules}


GRAPH = graph()


def test_the_layers_cover_both_packages() -> None:
    assert "evolution.experiments.loop.evolve" in MODULES and "revolve_env.world" in MODULES
    for module in MODULES:
        layer(module)


@pytest.mark.parametrize("module", sorted(MODULES))
def test_imports_run_down_the_layers(module: str) -> None:
    own = layer(module)
    up = sorted(f"{name} (layer {layer(name)})" for name in GRAPH[module]
                if layer(name) > own and not _lazy_export(module, name))
    assert not up, f"{module} (layer {own}) imports up a layer: {', '.join(up)}"
    if own == LIBRARY:
        physics = sorted(name for name in GRAPH[module] if 0 < layer(name) < LIBRARY)
        assert not physics, f"the pure library module {module} imports {', '.join(physics)}"


EXPERIMENTS = sorted(m for m in MODULES if room(m) is not None)


@pytest.mark.parametrize("module", EXPERIMENTS)
def test_the_experiment_rooms_run_one_way(module: str) -> None:
    own = room(module)
    assert own is not None
    up = sorted(name for name in GRAPH[module]
                if (other := room(name)) is not None and other > own
                and not _lazy_export(module, name))
    assert not up, f"{module} (room {own}) imports a room above it: {', '.join(up)}"


def test_the_loop_imports_nothing_of_the_store() -> None:
    """By statement or by name: the loop reads its store through its own protocol only."""
    loop = [m for m in MODULES if _inside(m, LOOP)]
    assert len(loop) > 5 and "evolution.experiments.loop.evolve" in loop
    found = sorted(f"{m} -> {name}" for m in loop for name in GRAPH[m]
                   if _inside(name, STORE) or room(name) == 2)
    assert not found, "the loop imports the store or the application: " + ", ".join(found)


def test_a_by_name_import_of_the_store_from_the_loop_is_seen(tmp_path: Path) -> None:
    """The check above can fail: a loop module that names the store to import it."""
    fake = tmp_path / "fake.py"
    fake.write_text("import importlib\n"
                    "def load():\n"
                    "    return importlib.import_module('evolution.experiments.store.database')\n"
                    "OBSERVER = 'evolution.experiments.store.observer:StoreObserver'\n")
    modules = {**MODULES, "evolution.experiments.loop.fake": fake}
    assert imports_by_name("evolution.experiments.loop.fake", modules) == {
        "evolution.experiments.store.database", "evolution.experiments.store.observer"}
    assert room("evolution.experiments.loop.fake") == 0
    assert room("evolution.experiments.store.database") == 1
    assert room("evolution.experiments") == room("evolution.experiments.app.api") == 2
    assert room("evolution.reporting.data") is None


def _cycle(edges: dict[str, set[str]] | None = None) -> list[str] | None:
    """One import circle among the project's modules (``edges``: :data:`GRAPH`), or None."""
    edges = GRAPH if edges is None else edges
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(module: str) -> list[str] | None:
        state[module] = 1
        path.append(module)
        for name in sorted(edges[module]):
            if state.get(name) == 1:
                return [*path[path.index(name):], name]
            if name not in state:
                found = visit(name)
                if found:
                    return found
        path.pop()
        state[module] = 2
        return None

    for module in sorted(edges):
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
    assert (layer("evolution.cli.commands") > layer("evolution.experiments.app.api")
            > layer("evolution"))


def test_a_circle_through_a_registry_string_is_a_circle(tmp_path: Path) -> None:
    """A package whose registry names a module by string, and that module imports the registry
    back: no import statement closes the circle, the string does."""
    package = tmp_path / "fakepkg"
    package.mkdir()
    (package / "__init__.py").write_text('"""A fake package."""\n')
    (package / "registry.py").write_text(
        '"""fakepkg.backend is named in this docstring: not an edge."""\n'
        'TABLE = {"backend": ("fakepkg.backend", "Backend")}\n'
        'WORDS = ("fakepkg", "registry")\n')
    (package / "backend.py").write_text("from fakepkg.registry import TABLE\n")
    (package / "loader.py").write_text(
        "import importlib\n"
        "def load():\n"
        "    return importlib.import_module('fakepkg.plugin')\n")
    (package / "plugin.py").write_text("from fakepkg import loader\n")
    (package / "lazy.py").write_text("X = 1\n")
    modules = _modules(tmp_path, ("fakepkg",))
    assert imports("fakepkg.registry", modules) == set()
    assert imports_by_name("fakepkg.registry", modules) == {"fakepkg.backend"}
    assert imports_by_name("fakepkg.loader", modules) == {"fakepkg.plugin"}
    edges = graph(modules)
    cycle = _cycle(edges)
    assert cycle is not None and {"fakepkg.backend", "fakepkg.registry"} <= set(cycle)
    edges["fakepkg.backend"] = set()
    cycle = _cycle(edges)
    assert cycle is not None and {"fakepkg.loader", "fakepkg.plugin"} <= set(cycle)
    edges["fakepkg.plugin"] = set()
    assert _cycle(edges) is None


def test_a_lazy_export_is_held_to_the_layers_only_when_imported() -> None:
    assert "evolution.experiments" in imports_by_name("evolution")
    assert _lazy_export("evolution", "evolution.experiments")
    assert not _lazy_export("evolution", "evolution.operators")  # imported by a statement
    assert not _lazy_export("evolution.experiments.loop.config",
                            "evolution.experiments.loop.registry")
    assert "revolve_env.world.mujoco_backend" in GRAPH["revolve_env.world.engines"]
