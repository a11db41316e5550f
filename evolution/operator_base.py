"""What every reproduction operator shares: its result types and its uniform random pick.

The operators themselves are in :mod:`evolution.operators` (body and whole reproduction) and
:mod:`evolution.brain_mutation` (brain structure and parameters); both re-export these names.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

from revolve_env.body.geometry import Assembly
from revolve_env.body.robot import Path, Robot

__all__ = ["OperatorOutcome", "OperatorRecord", "ReproductionResult", "pick"]

_T = TypeVar("_T")


@dataclass(frozen=True, slots=True)
class OperatorOutcome:
    """What one operator did.

    Attributes:
        robot: The resulting robot (the input unchanged when not applied; None only when crossover
            fails, which means no child).
        applied: Whether the operator changed the robot.
        detail: What it did, or why it did nothing, for people and logs.
        paths: The paths it acted on when applied (crossover: ``(a_c, b_c)``; removals: the
            removed path; duplication: ``(source, new copy)``; swap: ``(s1, s2)``; add_part: the
            new part's path); empty otherwise.
        assembly: The assembly of ``robot`` when the operator checked that its parts do not
            intersect (None otherwise): the child's final check takes it rather than assembling
            the same body again.
    """

    robot: Robot | None
    applied: bool
    detail: str
    paths: tuple[Path, ...] = ()
    assembly: Assembly | None = None


@dataclass(frozen=True, slots=True)
class OperatorRecord:
    """One step of a reproduction: the operator's name, whether it fired, and what it did."""

    name: str
    applied: bool
    detail: str


@dataclass(frozen=True, slots=True)
class ReproductionResult:
    """The child (or None) and the record of every step that made it.

    Attributes:
        child: The child, valid within the configuration's limits, or None.
        records: One record per step, in the order applied.
        failure: Why there is no child (None when there is one).
    """

    child: Robot | None
    records: tuple[OperatorRecord, ...]
    failure: str | None = None

    @property
    def fired(self) -> tuple[str, ...]:
        """Names of the operators that changed the robot, in order."""
        return tuple(r.name for r in self.records if r.applied)


def pick(rng: np.random.Generator, items: Sequence[_T]) -> _T:
    """One item of ``items``, uniformly at random (one draw of ``rng.integers``)."""
    return items[int(rng.integers(len(items)))]
