"""``revolve`` starts without the heavy stack: ``--help`` and ``--version`` load no command.

Each command imports what it uses (the experiments, the reporting stack with scipy and
matplotlib, a physics engine) when it is parsed or run; these tests check it by the modules a
fresh interpreter holds, not by timing (the CPU figures: ``time revolve --version``).
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from evolution.cli import main
from evolution.cli.commands import COMMANDS

HEAVY = ("scipy", "matplotlib", "torch", "pybullet", "mujoco", "ray", "stable_baselines3")
"""Third-party packages that cost seconds to import; none is needed to answer --help."""

_REPORT = (f"import json, sys; print(json.dumps(sorted(m for m in sys.modules "
           f"if m.split('.')[0] in {set(HEAVY)!r} or m.startswith(('evolution.experiments', "
           f"'evolution.reporting', 'evolution.evaluation')))))")


def _loaded_after(code: str) -> list[str]:
    """The heavy (and experiment/reporting) modules a fresh interpreter holds after ``code``."""
    done = subprocess.run([sys.executable, "-c", f"{code}\n{_REPORT}"], capture_output=True,
                          text=True, timeout=120, check=True)
    loaded: list[str] = json.loads(done.stdout.splitlines()[-1])
    return loaded


def test_importing_the_cli_loads_none_of_the_heavy_stack() -> None:
    assert _loaded_after("import evolution.cli") == []


def test_the_cli_starts_without_numpy_or_the_robot_description() -> None:
    """Neither the evolutionary library nor ``revolve_env`` (numpy, Gymnasium's registration)
    is loaded to parse a command line: each command loads them when it runs."""
    code = ("import sys\n"
            "from evolution.cli import main\n"
            "try:\n"
            "    main(['--version'])\n"
            "except SystemExit:\n"
            "    pass\n"
            "loaded = sorted({m.split('.')[0] for m in sys.modules} & "
            "{'numpy', 'gymnasium', 'revolve_env', 'tqdm'})\n"
            "assert not loaded, loaded\n")
    _loaded_after(code)


@pytest.mark.parametrize("argv", [["--help"], ["--version"], []])
def test_help_and_version_load_none_of_the_heavy_stack(argv: list[str]) -> None:
    code = ("from evolution.cli import main\n"
            "try:\n"
            f"    main({argv!r})\n"
            "except SystemExit:\n"
            "    pass\n")
    assert _loaded_after(code) == []


def test_a_command_loads_what_it_uses() -> None:
    """The deferred parser does define the command: its help imports the experiments."""
    code = ("from evolution.cli import main\n"
            "try:\n"
            "    main(['run', '--help'])\n"
            "except SystemExit:\n"
            "    pass\n")
    assert "evolution.experiments" in _loaded_after(code)


def test_the_version_is_the_packages(capsys: pytest.CaptureFixture[str]) -> None:
    from evolution.experiments.store.database import package_version

    with pytest.raises(SystemExit) as exit_info:
        main(["--version"])
    assert exit_info.value.code == 0
    assert capsys.readouterr().out == f"revolve {package_version()}\n"


@pytest.mark.parametrize("command", list(COMMANDS))
def test_every_command_is_listed_and_defined_on_use(command: str,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["--help"])
    listing = capsys.readouterr().out
    assert f"    {command}" in listing and COMMANDS[command][1].split()[0] in listing
    with pytest.raises(SystemExit) as exit_info:
        main([command, "--help"])
    assert exit_info.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith(f"usage: revolve {command}") and "--" in out  # its own options
