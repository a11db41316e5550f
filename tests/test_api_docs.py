"""The API reference builds from the docstrings (``python docs/build_api.py OUT``, with pdoc).

CI runs the test suite, so this is where the reference is built in CI: the build must succeed,
give a page to every public package and document the public names where they live.
"""

from __future__ import annotations

import os
import pkgutil
import re
import subprocess
import sys
from pathlib import Path

import pytest

import evolution
import revolve_env

pytest.importorskip("pdoc", reason="the API reference needs pdoc: pip install -e '.[test]'")

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def api(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("api")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    # A bound for a hang, not a speed test: the build takes seconds of CPU, minutes of wall
    # time on a loaded machine. Without the source views, which no test reads: highlighting them
    # is a third of the build's CPU time (56 s with them, 39 s without; 2026-11-27).
    proc = subprocess.run([sys.executable, str(ROOT / "docs" / "build_api.py"), str(out),
                           "--no-source"],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr, proc.stderr  # every module imported
    return out


def test_every_public_package_has_a_page(api: Path) -> None:
    assert (api / "index.html").is_file()
    for package in (revolve_env, evolution):
        assert (api / f"{package.__name__}.html").is_file()
        for info in pkgutil.walk_packages(package.__path__, f"{package.__name__}."):
            if info.ispkg and "._" not in info.name:
                page = api / (info.name.replace(".", "/") + ".html")
                assert page.is_file(), f"no page for {info.name}"


@pytest.mark.parametrize(("page", "names"), [
    ("revolve_env/evaluation.html", ["evaluate", "EvaluationResult"]),
    ("revolve_env/envs/population.html", ["PopulationEnv", "add_robot", "remove_robot"]),
    ("revolve_env/body/export.html", ["to_urdf", "to_sdf", "bill_of_materials"]),
    ("evolution/experiments.html", ["run", "resume", "ExperimentConfig"]),
    ("evolution/learning.html", ["TrainingCenter", "CMAESLearner", "SB3Learner"]),
])
def test_public_names_are_documented(api: Path, page: str, names: list[str]) -> None:
    html = (api / page).read_text(encoding="utf-8")
    for name in names:  # pdoc's anchors: id="name", or id="Class.name" for a method
        assert re.search(rf'id="(\w+\.)?{name}"', html), f"{name} is not documented in {page}"
