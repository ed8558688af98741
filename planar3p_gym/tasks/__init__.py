"""Tasks: what an environment id asks of the machine (the contract: :mod:`planar3p_gym.tasks.base`).

Each registered id is :class:`planar3p_gym.envs.core.Planar3PEnv` plus a task plus defaults;
the task reads the environment only through :class:`~planar3p_gym.tasks.base.TaskEnv`.

Adding a task
-------------
A new task needs its module, one row of the registration table and its tests -- nothing
else (``tests/tasks/test_adding_a_task.py`` does exactly this with a toy task):

1. **The task module** ``planar3p_gym/tasks/<name>.py``: a :class:`~planar3p_gym.tasks.base.Task`
   subclass (or a subclass of :class:`ReachTask`) with

   * ``name`` (unique) and a docstring in Gymnasium's template (Description, Action Space,
     Observation Space, Rewards, Starting State, Episode End, Arguments, Version History): the
     documentation page of its id is generated from it;
   * its constructor arguments (validated there: ``ValueError`` naming the argument);
   * the episode: :meth:`~planar3p_gym.tasks.base.Task.episode_spec` (drawn from the env's
     ``np_random`` only, replayable from the spec) and
     :meth:`~planar3p_gym.tasks.base.Task.begin`;
   * per step: :meth:`~planar3p_gym.tasks.base.Task.reference`; optionally
     ``observation_fields`` with :meth:`~planar3p_gym.tasks.base.Task.observation_bounds` and
     :meth:`~planar3p_gym.tasks.base.Task.observation_extra` (appended entries),
     :meth:`~planar3p_gym.tasks.base.Task.is_success`, ``termination`` and ``reward_terms``
     (the defaults use the shared formulas of :mod:`planar3p_gym.tasks.rewards` and
     :mod:`planar3p_gym.tasks.observation` -- write no formula a second time).
2. **One row** in :data:`planar3p_gym.envs.registry.ENV_SPECS`: the id, entry point
   ``planar3p_gym.envs.core:Planar3PEnv`` with ``kwargs={"task":
   "planar3p_gym.tasks.<name>:<Class>"}`` (users pass the task's arguments as ``task_kwargs``), the
   time limit, a one-line summary, the task name, and
   ``vector_entry_point="planar3p_gym.envs.vector:Planar3PVectorEnv"`` for the native vector env (it
   steps such a task environment by environment).
3. **Its tests**: Gymnasium's ``check_env`` on the id, a seeded replay, the native vector env
   against single envs, and the task's own behaviour; then regenerate the episode hashes
   (``python tests/envs/test_episode_hashes.py``), which must list every id.

Optional, on the agents' side: fixed benchmark suites
(:mod:`planar3p_agents.evaluation.task_suites`) and baselines
(:mod:`planar3p_agents.controllers.registry`).  An id may also get an environment class of its
own (as the ids of :mod:`planar3p_gym.envs` do) when it wants flat constructor arguments.
"""

from planar3p_gym.tasks.base import Task, TaskEnv, pose_list
from planar3p_gym.tasks.reach import ReachTask

__all__ = ["ReachTask", "Task", "TaskEnv", "pose_list"]
