"""Controllers that need no training: the paper's analytic simple motions, floor baselines,
travel-space planners, the crossing demonstration, tracking feed-forward, and the residual
policy heads learned on top of them.  :mod:`planar3p_agents.controllers.registry` names the
built-in baselines and the ids each plays on; :mod:`planar3p_agents.controllers.layout` says
what they read from each id's observation; :func:`planar3p_agents.policies.factory.load_policy`
builds them."""
