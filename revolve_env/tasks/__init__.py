"""Tasks: what a robot is rewarded for, as pluggable parts (plain data, arrays over robots).

* :class:`Task`: the protocol (``fitness(window)`` and ``reward(...)`` over every robot at once,
  ``name``, ``signal``, ``to_dict()``); :class:`BaseTask` is a user's starting point.
* Shipped (:data:`TASKS`): :class:`Locomotion` (the paper's ``f = v + 5 s``, the default),
  :class:`DirectedLocomotion` (displacement along a heading), :class:`LightFollowing` (the light
  sensors' reading should grow).
* :func:`make_task`, :func:`task_class`, :func:`task_from_dict`: names, dotted paths
  (``"package.module:ClassName"``) and stored tables to tasks, through one resolver.

Every ``task=`` keyword (``revolve_env.evaluate``, ``gymnasium.make("revolve_env/Locomotion-v1",
task=...)``, ``population_env(task=...)``, the learners) takes a task, a name or a table.
"""

from revolve_env.tasks.base import (
    SIGNALS,
    BaseTask,
    Task,
    TaskError,
    own_reward,
    pose_rate,
    score,
    task_name,
)
from revolve_env.tasks.light import LightFollowing
from revolve_env.tasks.locomotion import DirectedLocomotion, Locomotion
from revolve_env.tasks.registry import (
    DEFAULT_TASK,
    TASKS,
    check_task_name,
    make_task,
    task_class,
    task_from_dict,
)

__all__ = [
    "DEFAULT_TASK",
    "SIGNALS",
    "TASKS",
    "BaseTask",
    "DirectedLocomotion",
    "LightFollowing",
    "Locomotion",
    "Task",
    "TaskError",
    "check_task_name",
    "make_task",
    "own_reward",
    "pose_rate",
    "score",
    "task_class",
    "task_from_dict",
    "task_name",
]
