"""pybullet's build banner is silenced in our processes (issue 15); what the process itself prints
still shows, and the descriptors are back in place after the import."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

SCRIPT = """
import os, sys
import revolve_env
result = revolve_env.evaluate(revolve_env.example('spider'), seconds=0.1, insertion=0)
print('fitness', result.fitness, flush=True)
os.write(1, b'fd1 still open\\n')
os.write(2, b'fd2 still open\\n')
print('stderr still open', file=sys.stderr)
"""


def _run(code: str) -> subprocess.CompletedProcess[str]:
    # A bound for a hang, not a speed test (it holds on a loaded machine).
    return subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                          timeout=900, check=True)


def test_evaluating_a_robot_prints_no_pybullet_banner() -> None:
    done = _run(SCRIPT)
    assert "pybullet build time" not in done.stdout + done.stderr
    assert "fitness" in done.stdout and "fd1 still open" in done.stdout
    assert "fd2 still open" in done.stderr and "stderr still open" in done.stderr


def test_the_bare_package_still_prints_it() -> None:
    # The check above can fail: importing pybullet itself shows the banner on this wheel.
    done = _run("import pybullet")
    assert "pybullet build time" in done.stdout + done.stderr
