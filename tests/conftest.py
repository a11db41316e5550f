"""Shared test configuration.

Its presence puts ``tests/`` on ``sys.path`` (pytest's rootdir-relative import), so every test
module can ``from strategies import robots``.

The suite leaves nothing behind outside its own temporary folders: the code under test (and
every process it starts) gets a temporary folder of its own for the session (``TMPDIR``), which
must be empty at the end; anything left there fails the run, named. pytest's own folders
(``tmp_path``) stay where they always were. torch keeps a compiler cache in the temporary
folder (``torchinductor_<user>``, made when an optimizer is made): it goes into the session's
folder under a name of its own and is deleted with it; Ray keeps its sessions' logs in a
folder of its own (``RAY_TMPDIR``, short: its sockets' paths must stay under 108 characters),
deleted at the end, once the tests have shut Ray down. Warp (the MuJoCo Warp engine's tests) keeps
a folder per thread for the precompiled headers of the kernels it compiles on the CPU
(``wp_pch_*``, a ``TemporaryDirectory`` it removes only at exit): deleted with the rest, not
counted as left.

Under pytest-xdist (``-n``), each worker is a session of its own: it takes back the variables
as they were before the controller set them, then makes its own folder (so each worker starts
its own Ray instance, since ``ray.init()`` joins the latest cluster recorded in ``RAY_TMPDIR``,
and checks its own leftovers).
"""

from __future__ import annotations

import json
import multiprocessing
import multiprocessing.util
import os
import shutil
import tempfile
from pathlib import Path

import pytest

_KEY = pytest.StashKey[Path]()
_TORCH_CACHE = "torch-compiler-cache"
_RAY = "ray"
_WARP_PCH = "wp_pch_"
_SET = ("TMPDIR", "TORCHINDUCTOR_CACHE_DIR", "RAY_TMPDIR")
_BEFORE = "REVOLVE_TESTS_ENVIRONMENT"
"""The variables of :data:`_SET` as the first session found them (JSON), for xdist's workers."""


def pytest_configure(config: pytest.Config) -> None:
    if _BEFORE in os.environ:  # an xdist worker: the controller's values are not ours
        for name, value in json.loads(os.environ[_BEFORE]).items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
        tempfile.tempdir = None  # gettempdir() reads TMPDIR again
    else:
        os.environ[_BEFORE] = json.dumps({name: os.environ.get(name) for name in _SET})
    system = tempfile.gettempdir()
    session = Path(tempfile.mkdtemp(prefix="revolve-tests-", dir=system))
    session.chmod(0o755)  # another user must reach folders made in it (the read-only test)
    os.environ.setdefault("PYTEST_DEBUG_TEMPROOT", system)  # tmp_path: where it always was
    os.environ["TMPDIR"] = str(session)
    os.environ.setdefault("TORCHINDUCTOR_CACHE_DIR", str(session / _TORCH_CACHE))
    os.environ.setdefault("RAY_TMPDIR", str(session / _RAY))
    tempfile.tempdir = str(session)
    config.stash[_KEY] = session
    # MuJoCo's OpenGL backend, before a test module imports mujoco (as the package does).
    from revolve_env.world.opengl import choose_mujoco_gl

    choose_mujoco_gl()


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    folder = session.config.stash.get(_KEY, None)
    if folder is None:
        return
    # This process's own multiprocessing folder is removed by multiprocessing when it exits.
    own = multiprocessing.process.current_process()._config.get("tempdir")  # type: ignore[attr-defined]
    mine = {_TORCH_CACHE, _RAY} | ({Path(own).name} if own else set())
    left = sorted(p.name for p in folder.iterdir()
                  if p.name not in mine and not p.name.startswith(_WARP_PCH))
    for path in folder.iterdir():
        if own is None or path != Path(own):
            shutil.rmtree(path, ignore_errors=True) if path.is_dir() else path.unlink()
    # After multiprocessing's removal of its folder (priority -100), the session's folder.
    multiprocessing.util.Finalize(None, shutil.rmtree, args=(str(folder),),
                                  kwargs={"ignore_errors": True}, exitpriority=-101)
    if left:
        reporter = session.config.pluginmanager.get_plugin("terminalreporter")
        text = (f"the tests left {len(left)} item(s) in the temporary folder: "
                f"{', '.join(left[:10])}{', ...' if len(left) > 10 else ''}")
        if reporter is not None:
            reporter.write_line(text, red=True)
        if session.exitstatus == pytest.ExitCode.OK:
            session.exitstatus = pytest.ExitCode.TESTS_FAILED
