"""Tasks: what an environment id asks of the machine (the contract: :mod:`planar3p_gym.tasks.base`).

Each registered id is :class:`planar3p_gym.envs.core.Planar3PEnv` plus a task plus defaults;
the task reads the environment only through :class:`~planar3p_gym.tasks.base.TaskEnv`.  Adding
a task (the checklist) is a page of the documentation, ``docs/adding_a_task.md``; the public
way to register one is :func:`planar3p_gym.envs.registry.register_task`.
"""

from planar3p_gym.tasks.base import Task, TaskEnv, pose_list
from planar3p_gym.tasks.reach import ReachTask

__all__ = ["ReachTask", "Task", "TaskEnv", "pose_list"]
