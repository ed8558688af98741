"""A curriculum on the task: :class:`~planar3p_gym.tasks.sampling.TaskConfig` changes applied to the
training environments at set step counts.

A hyperparameter entry (or ``--params``) may hold ``task_schedule: {STEPS: {FIELD: VALUE}}``,
e.g. ``{500000: {position_tolerance: 0.0005, orientation_tolerance: 0.00436}}``: from the first
rollout at or after ``STEPS`` environment steps on, every training environment runs with those
fields changed (:meth:`planar3p_gym.envs.core.Planar3PEnv.set_task_config`; only
:data:`planar3p_gym.tasks.sampling.SCHEDULABLE_FIELDS`).  Stages accumulate in step order.  The
evaluation environment keeps the run's initial configuration, so a run's learning curve stays
on one scale.  A resumed run applies the stages it has passed before training on.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from stable_baselines3.common.callbacks import BaseCallback

from planar3p_gym.tasks.sampling import TaskConfig, updated_config

__all__ = ["TaskScheduleCallback", "parse_task_schedule"]

#: A validated schedule: ``(steps, changes)`` in increasing step order.
Schedule = list[tuple[int, dict[str, Any]]]


def parse_task_schedule(value: Any, base: TaskConfig) -> Schedule:
    """Check a ``task_schedule`` mapping (keys: positive step counts, as integers or digit
    strings as in a run's ``config.json``; values: mappings of schedulable ``TaskConfig``
    fields) against the run's initial config ``base``, each stage on top of the previous
    ones; ``ValueError`` naming the stage otherwise."""
    if not isinstance(value, Mapping) or not value:
        raise ValueError(
            f"task_schedule must be a non-empty mapping {{steps: {{field: value}}}}, got {value!r}"
        )
    stages: Schedule = []
    for key, changes in value.items():
        steps = int(key) if isinstance(key, str) and key.isdigit() else key
        if isinstance(steps, bool) or not isinstance(steps, int) or steps <= 0:
            raise ValueError(f"task_schedule: steps must be a positive integer, got {key!r}")
        if not isinstance(changes, Mapping) or not changes:
            raise ValueError(f"task_schedule[{steps}] must be a non-empty mapping, got {changes!r}")
        stages.append((steps, dict(changes)))
    stages.sort(key=lambda stage: stage[0])
    if len({steps for steps, _ in stages}) != len(stages):
        raise ValueError("task_schedule: the same step count is given twice")
    cfg = base
    for steps, changes in stages:
        try:
            cfg = updated_config(cfg, changes)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"task_schedule[{steps}]: {exc}") from exc
    return stages


class TaskScheduleCallback(BaseCallback):
    """Applies a :func:`parse_task_schedule` schedule to the training environments (through
    ``env_method("set_task_config", ...)``, which reaches the environments in any SB3 vector
    env) and logs each applied field as ``task/<field>``."""

    def __init__(self, schedule: Schedule, verbose: int = 0) -> None:
        super().__init__(verbose)
        self.schedule = list(schedule)
        self.applied = 0  # stages applied so far

    def _on_training_start(self) -> None:
        self._apply_due()

    def _on_rollout_start(self) -> None:
        self._apply_due()

    def _on_step(self) -> bool:
        return True

    def _apply_due(self) -> None:
        while self.applied < len(self.schedule) and (
            self.schedule[self.applied][0] <= self.num_timesteps
        ):
            steps, changes = self.schedule[self.applied]
            self.training_env.env_method("set_task_config", changes)
            for name, value in changes.items():
                self.logger.record(f"task/{name}", value)
            if self.verbose:
                print(f"task schedule: from step {self.num_timesteps} ({steps} planned): {changes}")
            self.applied += 1
