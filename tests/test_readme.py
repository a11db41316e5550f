"""The README's Python examples run as written (a new user's first contact with the API)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
BLOCKS = re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)


def test_the_readme_has_python_examples() -> None:
    assert len(BLOCKS) >= 4


@pytest.mark.parametrize("index", range(len(BLOCKS)))
def test_readme_python_block_runs(index: int, capsys: pytest.CaptureFixture[str]) -> None:
    # dont_inherit: compiled as a user's script would be, without this module's __future__
    # imports (string annotations would send dataclasses looking for a module "__readme__").
    exec(compile(BLOCKS[index], f"README.md block {index}", "exec", dont_inherit=True),
         {"__name__": "__readme__"})
    capsys.readouterr()


def test_readme_opens_with_the_two_setup_commands() -> None:
    text = README.read_text(encoding="utf-8")
    first_shell = re.search(r"```bash\n(.*?)```", text, flags=re.S)
    assert first_shell is not None
    commands = [line for line in first_shell.group(1).splitlines() if line.strip()]
    assert len(commands) == 2
    ci = (Path(__file__).resolve().parents[1] / ".ci" / "run").read_text(encoding="utf-8")
    assert commands[1] in ci  # CI runs exactly the README's test command


TOML_BLOCKS = re.findall(r"```toml\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)


@pytest.mark.parametrize("index", range(len(TOML_BLOCKS)))
def test_readme_toml_block_is_a_valid_experiment_config(index: int) -> None:
    import tomllib

    from evolution.experiments import ExperimentConfig

    config = ExperimentConfig.from_dict(tomllib.loads(TOML_BLOCKS[index]))
    config.fitness_task()  # a task table names a task that resolves
