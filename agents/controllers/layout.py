"""What a controller reads from the observation of each registered id.

Every flat observation of the package starts with the 31 entries of ``Planar3P-v0``
(:mod:`planar3p_gym.tasks.observation`; the task contract of :mod:`planar3p_gym.tasks.base`),
computed against the task's current reference pose, and then carries the task's own entries
(:meth:`planar3p_gym.tasks.base.Task.observation_extra`) and, with ``travel_goal=True``, the
joint-space goal (:data:`planar3p_gym.tasks.observation.TRAVEL_GOAL_FIELDS`).  The goal ids
have a ``Dict`` observation instead, from which
:class:`planar3p_agents.controllers.goal_adapter.GoalAdapter` rebuilds the 31 entries.

Each task names the entries it appends (:attr:`planar3p_gym.tasks.base.Task.observation_fields`);
:data:`TASK_EXTRA_FIELDS` collects them and :func:`observation_layout` checks the total against
the env's observation space, so a task that changes its entries fails loudly instead of
feeding a controller the wrong numbers.

:func:`env_id_of` tells which registered id an environment is (its spec, else its task).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from gymnasium import spaces

from planar3p_gym.envs.registry import (
    ENV_ID,
    ENV_SPECS,
    GOAL_DENSE_ENV_ID,
)
from planar3p_gym.tasks.observation import OBS_SIZE, TRAVEL_GOAL_FIELDS

__all__ = [
    "REGISTERED_IDS",
    "TASK_EXTRA_FIELDS",
    "TASK_IDS",
    "ObservationLayout",
    "env_id_of",
    "extra_slice",
    "observation_layout",
    "task_observation_size",
]

#: Every registered id, in the order of the registration table.
REGISTERED_IDS: tuple[str, ...] = tuple(row.id for row in ENV_SPECS)

Field = tuple[str, int, str]


def _task_classes() -> dict[str, Any]:
    """Each task's class by :attr:`~planar3p_gym.tasks.base.Task.name`."""
    from planar3p_gym.tasks.base import Task

    found: dict[str, Any] = {}
    todo = list(Task.__subclasses__())
    while todo:
        cls = todo.pop()
        todo.extend(cls.__subclasses__())
        if cls.name and cls.name not in found:
            found[cls.name] = cls
    return found


def _import_tasks() -> None:
    import planar3p_gym.tasks.assembly_change
    import planar3p_gym.tasks.goal
    import planar3p_gym.tasks.mode_change
    import planar3p_gym.tasks.reach
    import planar3p_gym.tasks.track  # noqa: F401


_import_tasks()
#: ``(name, size, description)`` of the entries each task appends to the 31 entries of
#: ``Planar3P-v0``, in order (keyed by :attr:`planar3p_gym.tasks.base.Task.name`): each task's
#: own :attr:`~planar3p_gym.tasks.base.Task.observation_fields`.
TASK_EXTRA_FIELDS: dict[str, tuple[Field, ...]] = {
    name: tuple(cls.observation_fields) for name, cls in _task_classes().items()
}

#: The id of each task's environment, from the registration table (goal: the sparse id; the
#: dense one is told by its reward type).
TASK_IDS: dict[str, str] = {}
for _row in ENV_SPECS:
    TASK_IDS.setdefault(_row.task, _row.id)


def _slices(fields: tuple[Field, ...], start: int) -> dict[str, slice]:
    out = {}
    for name, size, _ in fields:
        out[name] = slice(start, start + size)
        start += size
    return out


def extra_slice(task: str, name: str) -> slice:
    """The slice of the entry ``name`` that task ``task`` appends, in its flat observation."""
    return _slices(TASK_EXTRA_FIELDS[task], OBS_SIZE)[name]


def task_observation_size(task: str) -> int:
    """Length of the flat observation of task ``task`` (``travel_goal`` off)."""
    return OBS_SIZE + sum(size for _, size, _ in TASK_EXTRA_FIELDS[task])


@dataclass(frozen=True)
class ObservationLayout:
    """The observation of one id as a flat-observation controller sees it.

    Attributes:
        env_id: the registered id.
        goal: ``True`` for a ``Dict`` goal observation (a controller is given the 31 entries
            :class:`~planar3p_agents.controllers.goal_adapter.GoalAdapter` rebuilds).
        extras: ``(name, size, description)`` of the entries after the 31 of
            ``Planar3P-v0``, in order (none for a goal observation).
    """

    env_id: str
    goal: bool = False
    extras: tuple[Field, ...] = ()

    @property
    def size(self) -> int:
        """Length of the flat observation a controller is given."""
        return OBS_SIZE + sum(size for _, size, _ in self.extras)

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the appended entries."""
        return tuple(name for name, _, _ in self.extras)

    def slice(self, name: str) -> slice:
        """The slice of the appended entry ``name``; ``KeyError`` if there is none."""
        return _slices(self.extras, OBS_SIZE)[name]


def env_id_of(env: Any) -> str:
    """The registered id ``env`` (possibly wrapped) is an instance of: its ``spec.id`` when
    that is one of :data:`REGISTERED_IDS`, else the id of its task (:data:`TASK_IDS`; an env
    made with the constructor has no spec).  ``ValueError`` for any other environment."""
    spec = getattr(env, "spec", None)
    if spec is not None and spec.id in REGISTERED_IDS:
        return str(spec.id)
    base = getattr(env, "unwrapped", env)
    task = getattr(getattr(base, "task", None), "name", None)
    if task not in TASK_IDS:
        raise ValueError(
            f"{type(base).__name__} is not an environment of planar3p_gym "
            f"(one of {', '.join(REGISTERED_IDS)})"
        )
    if task == "goal" and getattr(base, "reward_type", "sparse") == "dense":
        return GOAL_DENSE_ENV_ID
    return TASK_IDS[str(task)]


def observation_layout(env: Any = None) -> ObservationLayout:
    """The layout of ``env``'s observation (``None``: ``Planar3P-v0``'s 31 entries).

    ``ValueError`` if ``env`` is not an environment of the package, or if its flat
    observation does not have the length :data:`TASK_EXTRA_FIELDS` gives its task."""
    if env is None:
        return ObservationLayout(ENV_ID)
    env_id = env_id_of(env)
    space = env.observation_space
    if isinstance(space, spaces.Dict):
        return ObservationLayout(env_id, goal=True)
    base = env.unwrapped
    extras = TASK_EXTRA_FIELDS[base.task.name]
    if getattr(base, "travel_goal", False):
        extras = extras + TRAVEL_GOAL_FIELDS
    layout = ObservationLayout(env_id, extras=extras)
    if tuple(space.shape) != (layout.size,):
        raise ValueError(
            f"the observation of {env_id} has shape {tuple(space.shape)}, but its layout "
            f"(31 entries of {ENV_ID}, then {', '.join(layout.names) or 'nothing'}) has "
            f"{layout.size} entries"
        )
    return layout
