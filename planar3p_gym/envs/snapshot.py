"""The random and task parts of an environment's snapshot (``Planar3PEnv.get_state``).

- :func:`random_state`: the generator's state, its seed and the task's state (the task's
  ``get_state()`` if it defines one, else a deep copy of its attributes but ``env``);
- :func:`restored_random`: the generator of such a record (the task's state put back);
- :func:`check_snapshot`: ``ValueError`` unless a value is a snapshot of an environment with
  the given settings (checked before anything is restored).
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np

from planar3p_gym.tasks.base import Task

__all__ = ["SNAPSHOT_KEYS", "check_snapshot", "random_state", "restored_random"]

#: The keys of a snapshot.
SNAPSHOT_KEYS = frozenset({"config", "sim", "np_random", "np_random_seed", "task", "episode"})


def random_state(rng: np.random.Generator, seed: int | None, task: Task) -> dict[str, Any]:
    """``rng``'s state, its ``seed`` and ``task``'s state (sampler pools included)."""
    if hasattr(task, "get_state"):
        task_state = task.get_state()
    else:
        task_state = copy.deepcopy({k: v for k, v in vars(task).items() if k != "env"})
    return {
        "np_random": copy.deepcopy(rng.bit_generator.state),
        "np_random_seed": seed,
        "task": task_state,
    }


def restored_random(state: dict[str, Any], task: Task) -> tuple[np.random.Generator, int | None]:
    """The generator and seed :func:`random_state` recorded; puts ``task``'s state back."""
    kind = getattr(np.random, state["np_random"]["bit_generator"])
    rng = np.random.Generator(kind())
    rng.bit_generator.state = copy.deepcopy(state["np_random"])
    if hasattr(task, "set_state"):
        task.set_state(copy.deepcopy(state["task"]))
    else:
        vars(task).update(copy.deepcopy(state["task"]))
    return rng, state["np_random_seed"]


def check_snapshot(state: Any, config: dict[str, Any]) -> None:
    """``ValueError`` unless ``state`` is a snapshot taken with the settings ``config``."""
    if not isinstance(state, dict) or set(state) != SNAPSHOT_KEYS:
        raise ValueError("state must be a snapshot from Planar3PEnv.get_state()")
    if state["config"] != config:
        raise ValueError(
            "the snapshot was taken from an environment with other settings: "
            f"{state['config']} != {config}"
        )
