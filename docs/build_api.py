"""Build the API reference (HTML) from the docstrings with pdoc: ``python docs/build_api.py [OUT]``.

Writes ``OUT/index.html`` and one page per public module (default ``OUT``: ``build/api``).
``--no-source`` leaves out the pages' "View Source" sections, whose syntax highlighting is a
third of the build's CPU time (the test suite's build, tests/test_api_docs.py, uses it). Needs
``pip install pdoc`` (in the ``test`` extra) and the package importable (installed, or the
repository root on ``PYTHONPATH`` with the compiled extensions built in place).

Why not just ``pdoc revolve_env evolution``:

* pdoc walks only the submodules that a package lists in ``__all__``, and our packages' ``__all__``
  list the names they re-export, so the two roots alone give a handful of pages. Every public
  module is named here instead (except those pdoc reaches through a parent's ``__all__``, which
  it would otherwise add twice).
* pdoc blocks subprocesses while it imports a module, and ``import mujoco`` starts one (glfw's
  library check), so ``revolve_env.world.mujoco_backend`` fails to import under the plain command.
  Every module is imported here first, then pdoc runs in this process.
"""

from __future__ import annotations

import importlib
import pkgutil
import sys
from pathlib import Path

PACKAGES = ("revolve_env", "evolution")

EXTRAS = {"revolve_env.envs.rllib": "ray.rllib", "revolve_env.world.warp_scenes": "mujoco_warp"}
"""Modules of an optional extra and the library they need: left out where it cannot be imported."""


def _importable(module: str) -> bool:
    try:
        importlib.import_module(module)
    except ImportError:
        return False
    return True


def public_modules() -> list[str]:
    """Every module of :data:`PACKAGES` without a ``_private`` part, imported; packages first."""
    names: list[str] = []
    for package in PACKAGES:
        names.append(package)
        root = importlib.import_module(package)
        for info in pkgutil.walk_packages(root.__path__, f"{package}."):
            parent, _, leaf = info.name.rpartition(".")
            if any(part.startswith("_") for part in info.name.split(".")):
                continue
            if info.name in EXTRAS and not _importable(EXTRAS[info.name]):
                continue
            importlib.import_module(info.name)
            if leaf not in getattr(sys.modules[parent], "__all__", ()):  # else pdoc adds it
                names.append(info.name)
    return names


def main(argv: list[str]) -> int:
    """Write the reference of :func:`public_modules` (Google-style docstrings) to ``argv[0]``."""
    import pdoc
    import pdoc.render

    source = "--no-source" not in argv
    argv = [arg for arg in argv if arg != "--no-source"]
    out = Path(argv[0]) if argv else Path("build") / "api"
    modules = public_modules()
    pdoc.render.configure(docformat="google", show_source=source)
    pdoc.pdoc(*modules, output_directory=out)
    print(f"API reference of {len(modules)} modules written to {out / 'index.html'}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
