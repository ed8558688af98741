"""Controllers that need no training: the paper's analytic simple motions, floor baselines,
travel-space planners, the crossing demonstration, tracking feed-forward, and the residual
policy heads learned on top of them."""
