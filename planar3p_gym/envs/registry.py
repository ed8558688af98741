"""The registration table: every environment id of the package, in one place.

Each row names the id, the env class, the native vector env class (``gym.make_vec(id,
vectorization_mode="vector_entry_point")``), the time limit and the constructor defaults.
:func:`register_all` registers them with Gymnasium (``import planar3p_gym`` calls it); the
documentation generates one page per row.  Every id runs the exact machine (the projected
physics of :mod:`planar3p_gym.sim.projection`); the unprojected pymunk-only model is the
constructor argument ``projection=False``, for fidelity studies, and has no id of its own.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from gymnasium.envs.registration import register, registry

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
            register(
                id=row.id,
                entry_point=row.entry_point,
                vector_entry_point=row.vector_entry_point,
                max_episode_steps=row.max_episode_steps,
                kwargs=dict(row.kwargs),
            )
