"""planar3p-gym: a 3-PRR planar parallel manipulator as a Gymnasium environment.

Importing the package registers every id of :data:`planar3p_gym.envs.registry.ENV_SPECS`
(``Planar3P-v0``, the task ids and the built machine's ids) with Gymnasium;
:func:`register_task` registers another package's task.  The layers, each a subpackage:

* :mod:`planar3p_gym.machine` -- design, exact kinematics, statics (numpy, numba);
* :mod:`planar3p_gym.sim` -- the pymunk model, its projection, rendering;
* :mod:`planar3p_gym.tasks` -- what an episode asks of the machine;
* :mod:`planar3p_gym.envs` -- the Gymnasium environments and their registration table;
* :mod:`planar3p_gym.analysis` -- the workspace study.

The package imports neither torch nor Stable-Baselines3 nor ``planar3p_agents``.
"""

from planar3p_gym.envs.registry import (
    ASSEMBLY_CHANGE_ENV_ID,
    ENV_ID,
    ENV_SPECS,
    GOAL_DENSE_ENV_ID,
    GOAL_ENV_ID,
    MODE_CHANGE_ENV_ID,
    REAL_ENV_ID,
    REAL_ON_OFF_ENV_ID,
    TRACK_ENV_ID,
    register_all,
    register_task,
    registrations,
)
from planar3p_gym.machine.design import Design

__all__ = [
    "ASSEMBLY_CHANGE_ENV_ID",
    "ENV_ID",
    "ENV_SPECS",
    "GOAL_DENSE_ENV_ID",
    "GOAL_ENV_ID",
    "MAX_EPISODE_STEPS",
    "MODE_CHANGE_ENV_ID",
    "REAL_ENV_ID",
    "REAL_ON_OFF_ENV_ID",
    "TRACK_ENV_ID",
    "Design",
    "max_episode_steps",
    "register_task",
    "registrations",
]
#: The package's version (``pyproject.toml`` reads it from here).
__version__ = "1.0.0"


def max_episode_steps(env_id: str) -> int:
    """The time limit of a registered id (the package's or :func:`register_task`'s), in control
    steps."""
    rows = registrations()
    for row in rows:
        if row.id == env_id:
            return row.max_episode_steps
    raise ValueError(f"{env_id!r} is not an id of planar3p_gym: {[r.id for r in rows]}")


#: Time limit of ``Planar3P-v0`` in control steps (5 s at the default 50 Hz).
MAX_EPISODE_STEPS = max_episode_steps(ENV_ID)

register_all()
