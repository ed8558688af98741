"""Tasks: what an environment id asks of the machine (see :mod:`planar3p_gym.tasks.base`).

Each registered id is :class:`planar3p_gym.envs.core.Planar3PEnv` plus a task plus defaults.
"""

from planar3p_gym.tasks.base import Task, pose_list
from planar3p_gym.tasks.reach import ReachTask

__all__ = ["ReachTask", "Task", "pose_list"]
