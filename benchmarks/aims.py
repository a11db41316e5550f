"""Issue 28's aims, each figure beside its aim: "met", "missed by 1.23x" or "not measured".

``bench_engines.py`` fills the figures of the sections it ran (ratios against raw ``mj_step``
measured in one process) and, with ``--whole-runs BIRTHS`` or ``--given-run``, the whole-run
aims that ``bench_experiments.py`` measures (CPU per birth against its floor, memory per birth,
the paper's study projected onto 2 cores); :func:`summary` prints every aim of the issue, a
figure it did not get marked "not measured in this run" with what measures it.

No timing here: the figures come in, the lines go out (``tests/benchmarks/test_bench_aims.py``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

__all__ = ["ISSUE_28", "Aim", "Figure", "GivenRun", "parse_given_run", "summary", "verdict"]


@dataclass(frozen=True, slots=True)
class Aim:
    """One aim of the issue.

    Attributes:
        key: Its short name (the key of its figure).
        what: The figure, in words.
        target: The aim's bound, in ``unit``.
        at_most: ``True``: met when the figure is at most ``target``; ``False``: at least.
        unit: The unit written after numbers (``"x"``, ``" KB per birth"``, ``" h"``).
        measured_by: What measures it (printed when this run did not).
    """

    key: str
    what: str
    target: float
    at_most: bool
    unit: str
    measured_by: str


@dataclass(frozen=True, slots=True)
class Figure:
    """A measured figure of an aim.

    Attributes:
        value: The figure, in the aim's unit.
        note: Where it comes from, when not from this run's own timing (e.g. a given run).
    """

    value: float
    note: str = ""


_WHOLE = "bench_engines --whole-runs BIRTHS or --given-run (bench_experiments.py)"
ISSUE_28: tuple[Aim, ...] = (
    Aim("evaluate", "evaluate() of one spider / raw mj_step", 1.15, True, "x",
        "bench_engines --only evaluate"),
    Aim("evaluate_many", "evaluate_many of a generation / raw mj_step, per robot-second", 1.05,
        True, "x", "bench_engines --only offline"),
    Aim("crowd", "the 30-robot population env / raw mj_step", 1.1, True, "x",
        "bench_engines --only crowd"),
    Aim("single", "Locomotion-v1 stepping / raw mj_step", 1.2, True, "x",
        "bench_engines --only single"),
    Aim("threads", "2 threads / 1 thread, wall time of a generation", 1.8, False, "x",
        "bench_engines --only offline"),
    Aim("threads_cpu", "2 threads / 1 thread, CPU per robot-second (unchanged: within 10 %)",
        1.1, True, "x", "bench_engines --only offline"),
    Aim("scenario1", "scenario 1, CPU per birth / its floor", 1.25, True, "x", _WHOLE),
    Aim("scenario3", "scenario 3, CPU per birth / its floor", 1.25, True, "x", _WHOLE),
    Aim("memory", "scenario 3, resident memory's growth after its first 300 births", 20.0, True,
        " KB per birth", _WHOLE),
    Aim("study", "the paper's study (5 x 30 x 3000 births) on 2 cores, MuJoCo, projected from "
        "measured runs of >= 1000 births", 7.0, True, " h", _WHOLE),
    Aim("pybullet", "MuJoCo over pybullet, evaluate() of one spider", 4.0, False, "x",
        "bench_engines --only evaluate"),
)
"""Every aim of issue 28, in the order printed."""


def verdict(aim: Aim, value: float) -> str:
    """``"met"`` or ``"missed by 1.23x"`` (how far the figure is from the aim, as a ratio)."""
    if math.isnan(value):
        return "no figure (NaN)"
    met = value <= aim.target if aim.at_most else value >= aim.target
    if met:
        return "met"
    if aim.at_most:
        by = value / aim.target if aim.target > 0 else math.inf
    else:
        by = aim.target / value if value > 0 else math.inf
    return f"missed by {by:.2f}x"


def _number(value: float, unit: str) -> str:
    digits = 2 if unit == "x" else 1
    return f"{value:.{digits}f}{unit}"


def summary(figures: Mapping[str, Figure],
            extra: Mapping[str, tuple[Figure, Aim]] | None = None) -> list[str]:
    """Every aim of issue 28 with its figure, the aim and the verdict; one line each.

    Args:
        figures: The figures measured (or given), by :attr:`Aim.key`; an aim without one is
            printed "not measured in this run".
        extra: Further rows, by name: a figure and the aim it is held to (e.g. a like-for-like
            variant of an aim's ratio).

    Raises:
        KeyError: a figure for no aim of the issue.
    """
    keys = {aim.key for aim in ISSUE_28}
    unknown = sorted(set(figures) - keys)
    if unknown:
        raise KeyError(f"figures for no aim of issue 28: {', '.join(unknown)}")
    rows = [(aim.what, figures.get(aim.key), aim) for aim in ISSUE_28]
    rows += [(name, figure, aim) for name, (figure, aim) in (extra or {}).items()]
    out = ["issue 28's aims (figure, the aim, the verdict):"]
    for what, figure, aim in rows:
        bound = f"{'<=' if aim.at_most else '>='} {_number(aim.target, aim.unit)}"
        if figure is None:
            out.append(f"  {what}: not measured in this run (aim {bound}; {aim.measured_by})")
            continue
        note = f"; {figure.note}" if figure.note else ""
        out.append(f"  {what}: {_number(figure.value, aim.unit)} (aim {bound}): "
                   f"{verdict(aim, figure.value)}{note}")
    return out


@dataclass(frozen=True, slots=True)
class GivenRun:
    """A whole run measured by another process (``bench_experiments.py --workers 1``).

    Attributes:
        name: The experiment (``scenario1``, ``scenario3``, ...).
        cpu_ms: Its CPU per birth. Milliseconds.
        births: Births it ran.
        floor_ms: Its floor's CPU per birth (``None``: not given). Milliseconds.
        memory_kb: Its resident memory's growth per birth after 300 births (``None``: not
            given). Kilobytes per birth.
        alive: Online: the mean robots alive at its commit points (0: not given). Robots.
    """

    name: str
    cpu_ms: float
    births: int
    floor_ms: float | None = None
    memory_kb: float | None = None
    alive: float = 0.0


def parse_given_run(text: str) -> GivenRun:
    """``NAME=CPU_MS@BIRTHS[,floor=MS][,memory=KB][,alive=N]`` as a :class:`GivenRun`.

    E.g. ``scenario3=1315@609,floor=627,memory=5.9`` (what ``bench_experiments.py`` printed).

    Raises:
        ValueError: malformed text, in one line naming it.
    """
    name, eq, rest = text.partition("=")
    head, *options = rest.split(",")
    cpu, at, births = head.partition("@")
    try:
        if not (name and eq and at):
            raise ValueError
        fields: dict[str, float] = {}
        for option in options:
            key, eq2, value = option.partition("=")
            if key not in ("floor", "memory", "alive") or not eq2 or key in fields:
                raise ValueError
            fields[key] = float(value)
        given = GivenRun(name, float(cpu), int(births), fields.get("floor"),
                         fields.get("memory"), fields.get("alive", 0.0))
    except ValueError:
        raise ValueError(f"--given-run {text!r}: expected NAME=CPU_MS@BIRTHS[,floor=MS]"
                         "[,memory=KB][,alive=N], e.g. scenario3=1315@609,floor=627,"
                         "memory=5.9") from None
    if not (given.cpu_ms > 0 and given.births > 0 and math.isfinite(given.cpu_ms)) or (
            given.floor_ms is not None and not given.floor_ms > 0):
        raise ValueError(f"--given-run {text!r}: CPU per birth, births and floor must be "
                         "positive")
    return given
