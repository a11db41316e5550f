"""A run hands the heap's freed pages back to the system at every commit point (issue 28, item
4): ``malloc_trim`` on glibc really lowers a fragmented process's resident memory, and the loop
calls it once per step, after its observers (the store's commit and snapshot) ran."""

from __future__ import annotations

import ctypes
import os
import platform
from typing import Any

import pytest
from experiment_fakes import fake_evaluate, small

from evolution.evaluation import LocalEvaluator
from evolution.experiments import Evolution, Observer, Step, preset
from evolution.experiments.loop import evolve, heap

GLIBC = platform.system() == "Linux" and platform.libc_ver()[0] == "glibc"


def _resident() -> int:
    """This process's resident memory. Bytes."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


@pytest.mark.skipif(not GLIBC, reason="malloc_trim is glibc's")
def test_freed_heap_blocks_between_live_ones_go_back_to_the_system() -> None:
    libc = ctypes.CDLL("libc.so.6")
    libc.malloc.restype = ctypes.c_void_p
    libc.malloc.argtypes = [ctypes.c_size_t]
    libc.free.argtypes = [ctypes.c_void_p]
    size, count = 60_000, 1000  # below glibc's mmap threshold: heap blocks, 60 MB in all
    blocks, pins = [], []
    for _ in range(count):
        blocks.append(libc.malloc(size))
        ctypes.memset(blocks[-1], 1, size)  # resident
        pins.append(libc.malloc(4000))  # a live block after each: the heap cannot shrink
    try:
        for b in blocks:
            libc.free(b)
        freed = _resident()  # free() alone keeps the holes' pages
        heap.release_freed_memory()
        # most of the 60 MB of holes leaves the process (their whole pages)
        assert freed - _resident() > 0.7 * size * count
    finally:
        for p in pins:
            libc.free(p)


def test_other_c_libraries_are_left_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    heap._malloc_trim.cache_clear()
    monkeypatch.setattr(heap.platform, "system", lambda: "Darwin")
    try:
        assert heap._malloc_trim() is None and heap.release_freed_memory() is False
    finally:
        heap._malloc_trim.cache_clear()


class _Order(Observer):
    def __init__(self, calls: list[str]) -> None:
        self.calls = calls

    def stepped(self, evolution: Evolution, step: Step) -> None:
        self.calls.append(f"stepped {step.checkpoint.births}")


def test_the_loop_releases_freed_memory_after_every_step(
        monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[str] = []

    def release() -> bool:
        calls.append("release")
        return True

    monkeypatch.setattr(evolve, "release_freed_memory", release)
    config = small(preset("scenario1", births=20, population_size=5, offspring_size=5, runs=1,
                          seed=2))
    evaluator: Any = LocalEvaluator(workers=1, function=fake_evaluate)
    with Evolution(config, evaluator=evaluator, observers=[_Order(calls)]) as evolution:
        evolution.run()
    assert calls == [c for b in (5, 10, 15, 20) for c in (f"stepped {b}", "release")]
