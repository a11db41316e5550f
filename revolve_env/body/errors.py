"""The error of a robot description that breaks a rule (the lowest module of the body layer)."""

from __future__ import annotations

__all__ = ["RobotError", "format_path"]

Path = tuple[int, ...]
"""Slots from the core down to a part (``()`` is the core); the same as ``robot.Path``."""


def format_path(path: Path) -> str:
    """A part's path as people read it: ``core``, ``core/0/2``."""
    return "core" if not path else "core/" + "/".join(str(s) for s in path)


class RobotError(ValueError):
    """A robot description breaks a rule.

    Attributes:
        path: Path of the offending node (``()`` is the core; None for robot-wide rules).
        rule: Short machine-readable name of the broken rule.
    """

    def __init__(self, message: str, *, path: Path | None = None, rule: str) -> None:
        where = "robot" if path is None else f"part at {format_path(path)}"
        super().__init__(f"{where}: {message} [{rule}]")
        self.path = path
        self.rule = rule
