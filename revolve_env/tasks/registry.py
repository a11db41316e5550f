"""The shipped tasks by name, and the one resolver of task names, dotted paths and tables.

A new task is one file (its class, whose ``registered`` class variable is its name) plus one
entry in :data:`SHIPPED`. :func:`task_class` resolves a shipped task's name and a user's own
dotted path ``"package.module:ClassName"`` alike; :func:`make_task` turns whatever a ``task=``
keyword was given into a checked task. This module sits above the tasks it names (they import
only :mod:`revolve_env.tasks.base`).
"""

from __future__ import annotations

import dataclasses
import importlib
import re
from collections.abc import Mapping
from typing import Any

from revolve_env.tasks.base import BaseTask, Task, TaskError, check, check_class
from revolve_env.tasks.light import LightFollowing
from revolve_env.tasks.locomotion import DirectedLocomotion, Locomotion

__all__ = ["DEFAULT_TASK", "SHIPPED", "TASKS", "check_task_name", "make_task", "task_class",
           "task_from_dict"]

SHIPPED: dict[str, type[BaseTask]] = {
    cls.registered: cls for cls in (Locomotion, DirectedLocomotion, LightFollowing)
    if cls.registered is not None
}
"""Name of each shipped task -> its class."""

TASKS: dict[str, str] = {name: f"{cls.__module__}:{cls.__qualname__}"
                         for name, cls in SHIPPED.items()}
"""Name of each shipped task -> the dotted path of its class."""

DEFAULT_TASK = "locomotion"
"""The paper's task, ``f = v + 5 s``: what every env and evaluation scores unless told."""

_PATH = re.compile(r"^[A-Za-z_]\w*(\.[A-Za-z_]\w*)*:[A-Za-z_]\w*(\.[A-Za-z_]\w*)*$")


def check_task_name(name: object) -> str:
    """The dotted path ``name`` stands for: a shipped task's, or ``name`` if it is one.

    Imports nothing (the form is checked, not the class).

    Raises:
        TaskError: ``name`` is not a string, a shipped name or ``"package.module:ClassName"``.
    """
    if not isinstance(name, str):
        raise TaskError(f"a task name must be a string, got {type(name).__name__}")
    path = TASKS.get(name, name)
    if not _PATH.match(path):
        raise TaskError(f"unknown task {name!r}: use one of {', '.join(TASKS)} or the dotted "
                        "path of your own class, 'package.module:ClassName'")
    return path


def task_class(name: str, *, allow_import: bool = True) -> type:
    """The class a task name stands for: a shipped task's name or ``"package.module:Class"``.

    Resolving a dotted path imports its module, which runs that module's code: a name read
    from a results folder someone else made must be resolved with ``allow_import=False`` (then
    only the shipped tasks resolve) unless the user asked for it (a resume of their own run).

    Raises:
        TaskError: one line naming the unknown name, the module that does not import (or may
            not be imported), or the class that does not follow the :class:`Task` protocol.
    """
    path = check_task_name(name)
    if name in SHIPPED:
        return SHIPPED[name]
    if not allow_import:
        raise TaskError(f"task {name!r} is a class of your own: resolving it imports its "
                        "module, which is not allowed here")
    module_name, qualname = path.split(":")
    try:
        obj: Any = importlib.import_module(module_name)
    except ImportError as e:
        raise TaskError(f"task {name!r}: cannot import module {module_name!r} ({e})") from None
    for part in qualname.split("."):
        if not hasattr(obj, part):
            raise TaskError(f"task {name!r}: module {module_name!r} has no {qualname!r}")
        obj = getattr(obj, part)
    if not isinstance(obj, type):
        raise TaskError(f"task {name!r} is not a class")
    check_class(obj, name)
    return obj


def task_from_dict(data: Mapping[str, Any], *, allow_import: bool = True) -> Task:
    """The task a :meth:`Task.to_dict` describes.

    Its class (:func:`task_class`, ``allow_import`` as there) made with the other keys as
    keyword arguments.

    Raises:
        TaskError: no ``name``, an unknown name or class, or parameters the class refuses.
    """
    if not isinstance(data, Mapping) or "name" not in data:
        got = dict(data) if isinstance(data, Mapping) else data
        raise TaskError(f"a task table needs a 'name' (one of {', '.join(TASKS)} or "
                        f"'package.module:ClassName'), got {got!r}")
    name = data["name"]
    cls = task_class(name, allow_import=allow_import)
    params = {k: v for k, v in data.items() if k != "name"}
    try:
        task = cls(**params)
    except TypeError as e:
        known = ([f.name for f in dataclasses.fields(cls)] if dataclasses.is_dataclass(cls)
                 else [])
        raise TaskError(f"task {name!r}: bad parameters {sorted(params)} ({e}); its parameters: "
                        f"{', '.join(known) or 'none'}") from None
    except ValueError as e:
        raise TaskError(f"task {name!r}: {e}") from None
    return check(task)


def make_task(task: Task | str | Mapping[str, Any] | None = None) -> Task:
    """A checked task from what a ``task=`` keyword got.

    Args:
        task: None (the paper's :class:`~revolve_env.tasks.Locomotion`), a task object, a name
            (a shipped task with its defaults, or ``"package.module:ClassName"``), or a mapping
            ``{"name": ..., **parameters}`` (:func:`task_from_dict`).

    Raises:
        TaskError: see :func:`task_class` and :func:`task_from_dict`.
    """
    if task is None:
        task = DEFAULT_TASK
    if isinstance(task, str):
        return task_from_dict({"name": task})
    if isinstance(task, Mapping):
        return task_from_dict(task)
    if isinstance(task, type):
        raise TaskError(f"task={task.__qualname__} is a class: pass an instance, "
                        f"{task.__qualname__}()")
    return check(task)
