"""planar3p-gym: a 3-PRR planar parallel manipulator as a Gymnasium environment.

Importing the package registers ``Planar3P-v0`` with Gymnasium.
"""

from gymnasium.envs.registration import register, registry

from .design import Design

__all__ = ["ENV_ID", "ENV_ID_V1", "MAX_EPISODE_STEPS", "Design"]
__version__ = "0.1.0"

#: The registered environment id.
ENV_ID = "Planar3P-v0"
#: Time limit of ``Planar3P-v0`` in control steps (5 s at the default 50 Hz).
MAX_EPISODE_STEPS = 250

# H1 (issue 12): the same task on the projected physics (exact loop closure, faster).
#: The reach task with ``projection=True`` and the projected solver settings.
ENV_ID_V1 = "Planar3P-v1"


def _projected_physics() -> dict:
    """Constructor arguments of the projected physics (H1's settings, shared by ``Planar3P-v1``
    and the task ids below)."""
    from .physics import PROJECTED_ITERATIONS, PROJECTED_SUBSTEPS

    return {
        "projection": True,
        "substeps": PROJECTED_SUBSTEPS,
        "solver_iterations": PROJECTED_ITERATIONS,
    }


_PROJECTED = _projected_physics()
for _id, _kwargs in ((ENV_ID, {}), (ENV_ID_V1, _PROJECTED)):
    if _id not in registry:
        register(
            id=_id,
            entry_point="planar3p_gym.env:Planar3PEnv",
            vector_entry_point="planar3p_gym.vector_env:Planar3PVectorEnv",
            max_episode_steps=MAX_EPISODE_STEPS,
            kwargs=dict(_kwargs),
        )

# H2 (issue 10): goal-conditioned reach and trajectory tracking, on the projected physics.
#: Goal-conditioned reach ids (sparse and dense reward).
GOAL_ENV_ID = "Planar3PGoal-v0"
GOAL_DENSE_ENV_ID = "Planar3PGoalDense-v0"
#: Their time limit in control steps (2 s; the analytic controller needs at most 75 over 200
#: episodes in random working modes): short episodes suit hindsight relabelling, and SB3's HER
#: can sample once an episode has ended, before its default ``learning_starts`` of 100 is up.
GOAL_MAX_EPISODE_STEPS = 100
for _id, _reward in ((GOAL_ENV_ID, "sparse"), (GOAL_DENSE_ENV_ID, "dense")):
    if _id not in registry:
        register(
            id=_id,
            entry_point="planar3p_gym.goal_env:Planar3PGoalEnv",
            max_episode_steps=GOAL_MAX_EPISODE_STEPS,
            kwargs={"reward_type": _reward, **_PROJECTED},
        )
#: Trajectory-tracking id and its time limit (control steps: 10 s at 50 Hz).
TRACK_ENV_ID = "Planar3PTrack-v0"
TRACK_MAX_EPISODE_STEPS = 500
if TRACK_ENV_ID not in registry:
    register(
        id=TRACK_ENV_ID,
        entry_point="planar3p_gym.track_env:Planar3PTrackEnv",
        vector_entry_point="planar3p_gym.vector_env:Planar3PTrackVectorEnv",  # H1 (issue 12)
        max_episode_steps=TRACK_MAX_EPISODE_STEPS,
        kwargs=dict(_PROJECTED),
    )

# H3 (issue 10): working-mode change and assembly-mode change, on the projected physics.
#: Working-mode change id and its time limit (control steps: 8 s at 50 Hz).
MODE_CHANGE_ENV_ID = "Planar3PModeChange-v0"
MODE_CHANGE_MAX_EPISODE_STEPS = 400
#: Assembly-mode change id (parallel-singularity crossing) and its time limit (12 s at 50 Hz).
ASSEMBLY_CHANGE_ENV_ID = "Planar3PAssemblyChange-v0"
ASSEMBLY_CHANGE_MAX_EPISODE_STEPS = 600
for _id, _entry, _steps in (
    (MODE_CHANGE_ENV_ID, "mode_change_env:Planar3PModeChangeEnv", MODE_CHANGE_MAX_EPISODE_STEPS),
    (
        ASSEMBLY_CHANGE_ENV_ID,
        "assembly_change_env:Planar3PAssemblyChangeEnv",
        ASSEMBLY_CHANGE_MAX_EPISODE_STEPS,
    ),
):
    if _id not in registry:
        register(
            id=_id,
            entry_point=f"planar3p_gym.{_entry}",
            # H1 (issue 12): the native vector env, environment by environment.
            vector_entry_point="planar3p_gym.vector_env:"
            + _entry.split(":")[1].replace("Env", "VectorEnv"),
            max_episode_steps=_steps,
            kwargs=dict(_PROJECTED),
        )
