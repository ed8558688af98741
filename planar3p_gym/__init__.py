"""planar3p-gym: a 3-PRR planar parallel manipulator as a Gymnasium environment.

Importing the package registers ``Planar3P-v0`` with Gymnasium.
"""

from gymnasium.envs.registration import register, registry

from .design import Design

__all__ = ["ENV_ID", "MAX_EPISODE_STEPS", "Design"]
__version__ = "0.1.0"

#: The registered environment id.
ENV_ID = "Planar3P-v0"
#: Time limit of ``Planar3P-v0`` in control steps (5 s at the default 50 Hz).
MAX_EPISODE_STEPS = 250

if ENV_ID not in registry:
    register(
        id=ENV_ID,
        entry_point="planar3p_gym.env:Planar3PEnv",
        max_episode_steps=MAX_EPISODE_STEPS,
    )

# H2 (issue 10): goal-conditioned reach and trajectory tracking.
#: Goal-conditioned reach ids (sparse and dense reward) and their time limit (control steps).
GOAL_ENV_ID = "Planar3PGoal-v0"
GOAL_DENSE_ENV_ID = "Planar3PGoalDense-v0"
for _id, _reward in ((GOAL_ENV_ID, "sparse"), (GOAL_DENSE_ENV_ID, "dense")):
    if _id not in registry:
        register(
            id=_id,
            entry_point="planar3p_gym.goal_env:Planar3PGoalEnv",
            max_episode_steps=MAX_EPISODE_STEPS,
            kwargs={"reward_type": _reward},
        )
