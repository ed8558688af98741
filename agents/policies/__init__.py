"""Policies by name or path: the one factory (:func:`planar3p_agents.policies.factory.load_policy`),
policy specifications, and Stable-Baselines3 model loading."""
