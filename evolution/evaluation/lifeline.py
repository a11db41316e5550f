"""Worker processes that die with the process that owns them.

A worker pool's processes must not outlive the run that started them, however it ends: a
``kill -9`` of ``revolve run`` used to leave its pool workers (and with them the forkserver and
the resource tracker, which wait for the workers) alive for minutes, holding the killed command's
stdout and stderr open, so whatever read that pipe hung.

:func:`guard_worker` is the initializer of every process a
:class:`~evolution.evaluation.LocalEvaluator` starts (pool workers and the ``Manager`` that
carries progress events). It arranges two things:

* a *lifeline* on the owner (:func:`watch_owner`): a daemon thread blocked on a Linux pidfd of
  the process that made the pool, which kills this process as soon as the owner exits. It works
  for any parent-child layout, and for the ``forkserver`` start method it has to: the workers
  are children of the forkserver, not of the owner, and the forkserver itself stays up while
  any worker lives (each worker holds its liveness pipe), so nothing would ever end them;
* ``prctl(PR_SET_PDEATHSIG, SIGKILL)`` (:func:`die_with_parent`) when the worker's parent is a
  forkserver: the kernel then kills the worker if the forkserver dies first. It is not set when
  the parent is the owner itself (``spawn``): the signal follows the *thread* that forked, and
  a pool's processes may be started from any thread of the owner, one that could end while the
  pool is still in use.

The forkserver and the resource tracker are not ours to initialise; neither needs to be: the
forkserver exits when the owner and every worker have closed its liveness pipe, and the resource
tracker when every process holding its pipe is gone. Both then close their inherited stdout and
stderr, so a pipe from a killed owner reaches its end within moments of the kill.

Elsewhere than Linux, the lifeline polls the owner (every :data:`POLL_SECONDS`) and there is no
parent death signal.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import select
import signal
import sys
import threading
import time

__all__ = ["POLL_SECONDS", "die_with_parent", "guard_worker", "watch_owner"]

POLL_SECONDS = 0.25
"""How often the lifeline checks the owner where no pidfd is available. Seconds."""

_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def _die() -> None:
    """End this process at once, without cleanup (its owner is gone: nobody wants its results)."""
    if hasattr(signal, "SIGKILL"):
        os.kill(os.getpid(), signal.SIGKILL)
    os._exit(1)


def die_with_parent() -> bool:
    """Ask Linux to SIGKILL this process when its parent exits (``PR_SET_PDEATHSIG``).

    The "parent" is the thread that forked this process. If the parent already exited before
    the request took effect, this process ends at once.

    Returns:
        Whether the request was made (False off Linux or without ``prctl``).
    """
    if not sys.platform.startswith("linux"):
        return False
    parent = os.getppid()
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return False
    prctl.argtypes = [ctypes.c_int, ctypes.c_ulong, ctypes.c_ulong, ctypes.c_ulong,
                      ctypes.c_ulong]
    prctl.restype = ctypes.c_int
    if prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) != 0:
        return False
    if os.getppid() != parent:  # the parent died before the request: no signal will come
        _die()
    return True


def watch_owner(owner: int) -> None:
    """Kill this process as soon as process ``owner`` exits (a daemon thread watches it).

    Args:
        owner: Process id of the owner. If it is already gone, this process ends at once.
    """
    try:
        pidfd: int | None = os.pidfd_open(owner)
    except ProcessLookupError:
        _die()
        return
    except (AttributeError, OSError):  # not Linux >= 5.3: poll instead
        pidfd = None
    if pidfd is None and not _alive(owner):
        _die()
    threading.Thread(target=_lifeline, args=(owner, pidfd), name="revolve-lifeline",
                     daemon=True).start()


def _lifeline(owner: int, pidfd: int | None) -> None:
    """Body of the lifeline thread: block until ``owner`` exits, then end this process."""
    if pidfd is not None:
        # A pidfd becomes readable when its process exits (a zombie included). The wait holds
        # no GIL; the kill needs it only for a moment.
        while True:
            with contextlib.suppress(InterruptedError):
                ready, _, _ = select.select([pidfd], [], [])
                if ready:
                    break
    else:
        parent = os.getppid()
        while _alive(owner) and os.getppid() == parent:
            time.sleep(POLL_SECONDS)
    _die()


def _alive(pid: int) -> bool:
    """Whether process ``pid`` exists (a zombie counts as alive)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def guard_worker(owner: int) -> None:
    """Initializer of a pool process: it ends when ``owner`` (or its forkserver parent) does.

    Never raises (a pool whose initializer fails is broken for good): when neither mechanism is
    available the process simply runs unguarded.

    Args:
        owner: Process id of the process that made the pool (``os.getpid()`` there).
    """
    # An unguarded worker beats a broken pool.
    with contextlib.suppress(Exception):
        if os.getppid() != owner:  # started by a forkserver, whose forking thread lives as long
            die_with_parent()
        watch_owner(owner)
