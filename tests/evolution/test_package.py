"""The ``evolution`` package serves its names lazily and as the eager imports did."""

from __future__ import annotations

import subprocess
import sys

import evolution


def test_every_public_name_is_served() -> None:
    for name in evolution.__all__:
        assert getattr(evolution, name) is not None, name
    assert set(evolution.__all__) <= set(dir(evolution))


def test_functions_named_as_their_modules_stay_functions() -> None:
    """``from evolution import random_robot`` is the function even after something imported the
    module ``evolution.random_robot`` (the experiments do), as with the eager imports."""
    code = ("import evolution.experiments, evolution.reporting.data\n"
            "import evolution.random_robot, evolution.diversity\n"
            "from evolution import diversity, random_robot\n"
            "import evolution\n"
            "assert random_robot.__module__ == 'evolution.random_robot'\n"
            "assert diversity.__module__ == 'evolution.diversity'\n"
            "assert evolution.random_robot is random_robot\n"
            "from evolution.random_robot import IdAllocator\n"
            "print('ok')\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, check=False)
    assert done.returncode == 0 and done.stdout.strip() == "ok", done.stderr[-2000:]


def test_importing_the_package_loads_no_module_of_it() -> None:
    code = ("import sys, evolution\n"
            "print(sorted(m for m in sys.modules if m.startswith(('evolution.', 'numpy', "
            "'revolve_env'))))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, check=True)
    assert done.stdout.strip() == "[]"
