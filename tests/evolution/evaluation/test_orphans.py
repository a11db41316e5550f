"""Worker processes die with their parent (issue 13, item 1).

A real offline run (``revolve run quick`` with 2 workers, real physics; one run, or two side by
side with a ``Manager`` for their progress) is SIGKILLed once it has committed something; within
a few seconds no process of its tree may remain, and its stdout and stderr must reach their end
(a script reading them would otherwise hang). It takes about 50-150 ms.

Every wait is on an event (a commit, the processes' end, the pipes' end) with a bound that holds
on a loaded machine (two cores shared by several test runs): a process needs CPU time to start
or end, and waiting longer costs nothing when it comes sooner. Orphans, the failure these tests
catch, stay for minutes (the pool test's tasks sleep an hour), far beyond the bounds.
"""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
GRACE = 30.0
"""Seconds the tree may take to end after the kill (well under one on a quiet machine)."""
START = 300.0
"""Seconds a run may take to commit its first robot, or a pool to start (a few when quiet)."""

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")


def _stat(pid: int) -> tuple[int, str, int] | None:
    """``(parent pid, state, start time in clock ticks)`` of a process, or None if gone."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = text.rsplit(")", 1)[1].split()  # the command name may hold spaces and parentheses
    return int(fields[1]), fields[0], int(fields[19])


def _tree(root: int) -> dict[int, int]:
    """Every process of ``root``'s tree (``root`` included): pid -> start time."""
    children: dict[int, list[int]] = {}
    starts: dict[int, int] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit() and (stat := _stat(int(entry.name))) is not None:
            children.setdefault(stat[0], []).append(int(entry.name))
            starts[int(entry.name)] = stat[2]
    tree, todo = {}, [root]
    while todo:
        pid = todo.pop()
        if pid in starts:
            tree[pid] = starts[pid]
            todo.extend(children.get(pid, []))
    return tree


def _alive(tree: dict[int, int]) -> list[int]:
    """The processes of ``tree`` still running (the same process: same start time; not a zombie)."""
    return [pid for pid, start in tree.items()
            if (stat := _stat(pid)) is not None and stat[2] == start and stat[1] != "Z"]


def _guarded(tree: dict[int, int], owner: int) -> list[int]:
    """The processes of ``tree`` but ``owner`` that run more than one thread: pool workers past
    their initializer, whose lifeline thread watches the owner (the forkserver and the resource
    tracker run one)."""
    guarded = []
    for pid in tree:
        try:
            if pid != owner and len(os.listdir(f"/proc/{pid}/task")) > 1:
                guarded.append(pid)
        except OSError:  # gone meanwhile
            pass
    return guarded


def _committed(db: Path) -> bool:
    """Whether the run has committed a robot (read-only: the run owns the file)."""
    if not db.exists():
        return False
    try:
        con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
        try:
            return bool(con.execute("SELECT COUNT(*) FROM robots").fetchone()[0])
        finally:
            con.close()
    except sqlite3.Error:  # not created yet, or mid-transaction
        return False


@pytest.mark.parametrize("runs", [1, 2])
def test_sigkill_of_an_offline_run_leaves_no_process_and_no_open_pipe(tmp_path: Path,
                                                                      runs: int) -> None:
    """One run evaluates in a pool of 2 workers; two runs go side by side in 2 worker processes
    that send progress through a ``Manager``."""
    # TMPDIR: the killed processes cannot remove their temporary folders; they stay in ours.
    env = {**os.environ, "TMPDIR": str(tmp_path), "PYTHONPATH": os.pathsep.join(
        filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    command = [sys.executable, "-m", "evolution.cli", "run", "quick", "--births", "60",
               "--workers", "2", "--runs", str(runs), "--out", str(tmp_path),
               "--set", "evolution.initial_parts_mean=6", "--set", "evolution.initial_parts_sd=2"]
    proc = subprocess.Popen(command, cwd=ROOT, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + START
        while not _committed(tmp_path / "quick" / "results.sqlite"):
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, f"the run committed nothing within {START:g} s"
            time.sleep(0.05)
        tree = _tree(proc.pid)
        # The run, the resource tracker, the forkserver, two workers (and the Manager).
        assert len(tree) >= (5 if runs == 1 else 6), tree
        proc.send_signal(signal.SIGKILL)
        killed = time.monotonic()
        proc.wait()
        while _alive(tree) and time.monotonic() - killed < GRACE:
            time.sleep(0.01)
        assert _alive(tree) == [], f"alive {GRACE} s after the kill: {_alive(tree)}"
        # Every writer of the pipes is gone: reading them ends.
        out, err = proc.communicate(timeout=GRACE)
        assert proc.returncode == -signal.SIGKILL
        assert b"Traceback" not in err
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


OWNER = """
import time
from evolution.evaluation import LocalEvaluator
with LocalEvaluator(2, function=time.sleep, start_method={method!r}) as pool:
    pool.evaluate([3600.0, 3600.0])  # tasks the workers never finish
"""


@pytest.mark.parametrize("method", ["spawn", "forkserver"])
def test_pool_workers_die_with_their_owner(method: str, tmp_path: Path) -> None:
    """Whatever the start method, the pool's processes end when their owner is SIGKILLed."""
    env = {**os.environ, "TMPDIR": str(tmp_path), "PYTHONPATH": os.pathsep.join(
        filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    proc = subprocess.Popen([sys.executable, "-c", OWNER.format(method=method)], cwd=ROOT,
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + START
        # The owner, two workers, the resource tracker (and the forkserver).
        while len(tree := _tree(proc.pid)) < (5 if method == "forkserver" else 4):
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, f"the pool did not start: {tree}"
            time.sleep(0.05)
        # The workers have passed their initializer: each runs its lifeline thread.
        while len(_guarded(tree := _tree(proc.pid), proc.pid)) < 2:
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, f"the workers were not guarded: {tree}"
            time.sleep(0.05)
        proc.send_signal(signal.SIGKILL)
        killed = time.monotonic()
        proc.wait()
        while _alive(tree) and time.monotonic() - killed < GRACE:
            time.sleep(0.01)
        assert _alive(tree) == [], f"alive {GRACE} s after the kill: {_alive(tree)}"
        proc.communicate(timeout=GRACE)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
