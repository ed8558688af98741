"""The registration table: every environment id of the package, in one place.

Each row names the id, the env class, the native vector env class (``gym.make_vec(id,
vectorization_mode="vector_entry_point")``), the time limit and the constructor defaults.
Every id runs the exact machine (the projected physics of :mod:`planar3p_gym.sim.projection`);
the unprojected pymunk-only model is the constructor argument ``projection=False`` and has no
id of its own.

* :data:`ENV_SPECS`: the package's own ids (frozen from 1.0.0: a changed behaviour is a new
  ``-vN`` row, the old row stays);
* :func:`register_all`: registers them with Gymnasium (``import planar3p_gym`` calls it);
* :func:`register_task`: registers another package's task as an id of the generic
  environment (``docs/adding_a_task.md``);
* :func:`registrations`: the package's rows and the rows :func:`register_task` added.
"""

from __future__ import annotations

import inspect
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from gymnasium.envs.registration import parse_env_id, register, registry

from planar3p_gym.envs.latency import REALISTIC_LATENCY
from planar3p_gym.sim.randomization import REALISTIC_RANDOMIZATION
from planar3p_gym.sim.sensors import REALISTIC_SENSORS

__all__ = [
    "ASSEMBLY_CHANGE_ENV_ID",
    "ENV_ID",
    "ENV_SPECS",
    "GOAL_DENSE_ENV_ID",
    "GOAL_ENV_ID",
    "MODE_CHANGE_ENV_ID",
    "REAL_ENV_ID",
    "REAL_ON_OFF_ENV_ID",
    "TRACK_ENV_ID",
    "EnvRegistration",
    "action_type_of",
    "register_all",
    "register_task",
    "registrations",
]

ENV_ID = "Planar3P-v0"
GOAL_ENV_ID = "Planar3PGoal-v0"
GOAL_DENSE_ENV_ID = "Planar3PGoalDense-v0"
TRACK_ENV_ID = "Planar3PTrack-v0"
MODE_CHANGE_ENV_ID = "Planar3PModeChange-v0"
ASSEMBLY_CHANGE_ENV_ID = "Planar3PAssemblyChange-v0"
REAL_ENV_ID = "Planar3PReal-v0"
REAL_ON_OFF_ENV_ID = "Planar3PRealOnOff-v0"

_ENVS = "planar3p_gym.envs"


@dataclass(frozen=True)
class EnvRegistration:
    """One registered id.

    ``max_episode_steps`` is the time limit in control steps (50 Hz by default);
    ``vector_entry_point`` is ``None`` where the id has no native vector env; ``summary`` is the
    one-line description of the table in the README and the docs; ``task`` names the task.
    """

    id: str
    entry_point: str
    max_episode_steps: int
    summary: str
    #: :attr:`planar3p_gym.tasks.base.Task.name` of the id's task.
    task: str
    vector_entry_point: str | None = None
    kwargs: dict[str, Any] = field(default_factory=dict)


#: Every id of the package.  Time limits: reach 5 s; goal-conditioned reach 2 s (short
#: episodes suit hindsight relabelling; the analytic controller needs at most 75 steps over
#: 200 episodes in random working modes); tracking 10 s; mode change 8 s; assembly change 12 s;
#: the built machine's reach, like the reach, 5 s, and with on-off motors (their rated speed is a
#: tenth of ``max_speed``) 20 s.
ENV_SPECS: tuple[EnvRegistration, ...] = (
    EnvRegistration(
        ENV_ID,
        f"{_ENVS}.core:Planar3PEnv",
        250,
        "reach a target pose and stop there (the mission's id)",
        "reach",
        vector_entry_point=f"{_ENVS}.vector:Planar3PVectorEnv",
    ),
    EnvRegistration(
        GOAL_ENV_ID,
        f"{_ENVS}.goal:Planar3PGoalEnv",
        100,
        "goal-conditioned reach, sparse reward (HER)",
        "goal",
        vector_entry_point=f"{_ENVS}.vector:Planar3PGoalVectorEnv",
        kwargs={"reward_type": "sparse"},
    ),
    EnvRegistration(
        GOAL_DENSE_ENV_ID,
        f"{_ENVS}.goal:Planar3PGoalEnv",
        100,
        "goal-conditioned reach, dense reward",
        "goal",
        vector_entry_point=f"{_ENVS}.vector:Planar3PGoalVectorEnv",
        kwargs={"reward_type": "dense"},
    ),
    EnvRegistration(
        TRACK_ENV_ID,
        f"{_ENVS}.track:Planar3PTrackEnv",
        500,
        "follow a moving reference pose",
        "track",
        vector_entry_point=f"{_ENVS}.vector:Planar3PTrackVectorEnv",
    ),
    EnvRegistration(
        MODE_CHANGE_ENV_ID,
        f"{_ENVS}.mode_change:Planar3PModeChangeEnv",
        400,
        "reach a target pose in another working mode (through serial singularities)",
        "mode_change",
        vector_entry_point=f"{_ENVS}.vector:Planar3PModeChangeVectorEnv",
    ),
    EnvRegistration(
        ASSEMBLY_CHANGE_ENV_ID,
        f"{_ENVS}.assembly_change:Planar3PAssemblyChangeEnv",
        600,
        "reach a target pose in the other assembly mode (through a parallel singularity)",
        "assembly_change",
        vector_entry_point=f"{_ENVS}.vector:Planar3PAssemblyChangeVectorEnv",
    ),
    EnvRegistration(
        REAL_ENV_ID,
        f"{_ENVS}.core:Planar3PEnv",
        250,
        "reach on the machine as built: randomised dynamics, encoder readings, one step of delay",
        "reach",
        kwargs={
            "randomization": REALISTIC_RANDOMIZATION.to_dict(),
            "sensors": REALISTIC_SENSORS.to_dict(),
            "latency": REALISTIC_LATENCY.to_dict(),
        },
        vector_entry_point=f"{_ENVS}.vector:Planar3PVectorEnv",
    ),
    EnvRegistration(
        REAL_ON_OFF_ENV_ID,
        f"{_ENVS}.core:Planar3PEnv",
        1000,
        "the built machine's reach with the prototype's on-off motors (MultiDiscrete actions)",
        "reach",
        kwargs={
            "randomization": REALISTIC_RANDOMIZATION.to_dict(),
            "sensors": REALISTIC_SENSORS.to_dict(),
            "latency": REALISTIC_LATENCY.to_dict(),
            "action_type": "on-off",
        },
        vector_entry_point=f"{_ENVS}.vector:Planar3PVectorEnv",
    ),
)


def action_type_of(row: EnvRegistration) -> str:
    """The action type of a registered id (:data:`planar3p_gym.envs.actuation.ACTION_TYPES`)."""
    return str(row.kwargs.get("action_type", "continuous"))


def register_all() -> None:
    """Register every id of :data:`ENV_SPECS` with Gymnasium (ids already registered are kept)."""
    for row in ENV_SPECS:
        if row.id not in registry:
            _register(row)


#: The generic environment (its task a constructor argument) and its native vector env.
GENERIC_ENTRY_POINT = f"{_ENVS}.core:Planar3PEnv"
GENERIC_VECTOR_ENTRY_POINT = f"{_ENVS}.vector:Planar3PVectorEnv"
#: The rows :func:`register_task` added, in order.
_ADDED: list[EnvRegistration] = []


def registrations() -> tuple[EnvRegistration, ...]:
    """The package's rows (:data:`ENV_SPECS`), then the rows :func:`register_task` added."""
    return (*ENV_SPECS, *_ADDED)


def register_task(
    env_id: str,
    task: Any,
    max_episode_steps: int,
    summary: str,
    *,
    kwargs: Mapping[str, Any] | None = None,
    vector: bool = True,
) -> EnvRegistration:
    """Register ``env_id`` as the generic environment running ``task``; the row it added.

    The public way for another package to add a task (``docs/adding_a_task.md``): ``task`` is a
    :class:`~planar3p_gym.tasks.base.Task` subclass (module-level) or its ``"module:Class"``;
    ``max_episode_steps`` the time limit (control steps); ``summary`` one line for the table of
    ids; ``kwargs`` the registered defaults of :class:`~planar3p_gym.envs.core.Planar3PEnv`'s
    arguments (JSON values; ``task_kwargs`` for the task's own arguments, checked here by
    building the task); ``vector``: the native vector env
    (:class:`~planar3p_gym.envs.vector.Planar3PVectorEnv`) as its vector entry point.  Every
    argument is checked before anything is registered: ``ValueError`` names the argument, and
    a rejected call registers nothing.  The id's page is generated from the task class's
    docstring.
    """
    from planar3p_gym.envs.core import Planar3PEnv
    from planar3p_gym.envs.settings import make_task

    if not isinstance(env_id, str):
        raise ValueError(f"env_id must be a string 'Name-vN', got {env_id!r}")
    try:
        _, _, version = parse_env_id(env_id)
    except Exception as exc:  # gymnasium.error.Error: not an id
        raise ValueError(f"env_id {env_id!r} is not a Gymnasium id: {exc}") from None
    if version is None:
        raise ValueError(f"env_id must end in a version -vN, got {env_id!r}")
    if env_id in registry or any(row.id == env_id for row in registrations()):
        raise ValueError(f"env_id {env_id!r} is already registered; register a new -vN")
    if isinstance(task, type):
        path = f"{task.__module__}:{task.__qualname__}"
    elif isinstance(task, str):
        path = task
    else:
        raise ValueError(f"task must be a Task subclass or its 'module:Class', got {task!r}")
    if (
        not isinstance(max_episode_steps, int)
        or isinstance(max_episode_steps, bool)
        or max_episode_steps < 1
    ):
        raise ValueError(f"max_episode_steps must be an integer >= 1, got {max_episode_steps!r}")
    if not isinstance(summary, str) or not summary.strip() or "\n" in summary:
        raise ValueError(f"summary must be one non-empty line, got {summary!r}")
    if not isinstance(vector, bool):
        raise ValueError(f"vector must be True or False, got {vector!r}")
    if kwargs is None:
        kwargs = {}
    if not isinstance(kwargs, Mapping):
        raise ValueError(f"kwargs must be a dict of Planar3PEnv's arguments, got {kwargs!r}")
    arguments = set(inspect.signature(Planar3PEnv.__init__).parameters) - {"self", "task"}
    unknown = sorted(set(kwargs) - arguments)
    if unknown:
        raise ValueError(f"kwargs: {unknown} are not arguments of Planar3PEnv (task is set here)")
    try:
        json.dumps(dict(kwargs))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"kwargs must hold JSON values: {exc}") from None
    instance = make_task(path, kwargs.get("task_kwargs"))  # imports and checks the task
    if isinstance(task, type) and type(instance) is not task:
        raise ValueError(f"task {path!r} is not importable as 'module:Class' (not module-level)")
    row = EnvRegistration(
        env_id,
        GENERIC_ENTRY_POINT,
        max_episode_steps,
        summary.strip(),
        instance.name,
        vector_entry_point=GENERIC_VECTOR_ENTRY_POINT if vector else None,
        kwargs={**kwargs, "task": path},
    )
    _register(row)
    _ADDED.append(row)
    return row


def _register(row: EnvRegistration) -> None:
    """Register one row with Gymnasium."""
    register(
        id=row.id,
        entry_point=row.entry_point,
        vector_entry_point=row.vector_entry_point,
        max_episode_steps=row.max_episode_steps,
        kwargs=dict(row.kwargs),
    )
