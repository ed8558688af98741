"""The Gymnasium environments: the core env, the goal-conditioned env, the task envs, the native
vector env and the registration table (:mod:`planar3p_gym.envs.registry`)."""
