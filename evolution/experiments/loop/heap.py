"""The memory a run has freed, returned to the system at every commit point (issue 28, item 4).

A long run allocates and frees large blocks all the time: MuJoCo compiles a model and its data
(megabytes) for every offline evaluation and, online, for every birth and death. glibc's
``malloc`` serves blocks that large from ``mmap`` only until the first one is freed; from then
on its threshold rises and they come from the heap, whose freed pages stay resident. A
scenario 3 process so grew by about 100 KB per birth (the heap 200-700 MB, of it 25-60 MB in
use), an offline one by 30 KB, while what it held stayed flat. :func:`release_freed_memory`
hands the heap's free pages back (``malloc_trim(0)``: a few milliseconds, once per commit point)
and leaves every allocation where it is, so no number moves. Other C libraries: nothing to do.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import platform
from collections.abc import Callable

__all__ = ["release_freed_memory"]


@functools.cache
def _malloc_trim() -> Callable[[int], int] | None:
    """The C library's ``malloc_trim`` on glibc, or ``None`` on another C library or platform."""
    if platform.system() != "Linux" or platform.libc_ver()[0] != "glibc":
        return None
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        trim = libc.malloc_trim
    except (OSError, AttributeError):
        return None
    trim.argtypes = [ctypes.c_size_t]
    trim.restype = ctypes.c_int
    return trim


def release_freed_memory() -> bool:
    """Give the pages of the heap's freed blocks back to the system (glibc; else nothing).

    Returns:
        Whether any memory was given back.
    """
    trim = _malloc_trim()
    return bool(trim(0)) if trim is not None else False
