"""The shipped tasks by name: one line per task, ``name -> "package.module:ClassName"``.

A new task is one file (its class) plus one line here; :func:`revolve_env.tasks.task_class`
resolves these names and a user's own dotted paths alike.
"""

from __future__ import annotations

__all__ = ["DEFAULT_TASK", "TASKS"]

TASKS: dict[str, str] = {
    "locomotion": "revolve_env.tasks.locomotion:Locomotion",
    "directed-locomotion": "revolve_env.tasks.locomotion:DirectedLocomotion",
    "light-following": "revolve_env.tasks.light:LightFollowing",
}
"""Name of each shipped task -> the dotted path of its class."""

DEFAULT_TASK = "locomotion"
"""The paper's task, ``f = v + 5 s``: what every env and evaluation scores unless told."""
