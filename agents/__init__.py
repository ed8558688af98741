"""planar3p_agents: controllers, policies, evaluation, training and the zoo of shipped models.

Installed from the repository's ``agents/`` folder.  The layers, each a subpackage:

* :mod:`planar3p_agents.controllers` -- the paper's analytic simple motions, floor baselines
  (random, zero), travel-space planners, the crossing demonstration, tracking feed-forward, the
  residual policy heads; their registry (:mod:`planar3p_agents.controllers.registry`).
* :mod:`planar3p_agents.policies` -- the one factory
  (:func:`planar3p_agents.policies.factory.load_policy`): a baseline name or a model path ->
  an object with SB3's ``predict`` that plays on any registered id.
* :mod:`planar3p_agents.evaluation` -- fixed suites, the episode runner, the benchmark, its
  report, figures and statistics.
* :mod:`planar3p_agents.training` -- hyperparameters (rl-zoo3 YAML), one training run, Ray
  Tune sweeps, task schedules, kick-starting, the SB3 adapter of the native vector env.
* :mod:`planar3p_agents.zoo` -- shipping a run, the checksum manifest, ``pretrained/``.

Importing this package does not import torch or Stable-Baselines3 (only loading a model does).
"""

from planar3p_agents.controllers.analytic import AnalyticController
from planar3p_agents.controllers.floor import RandomPolicy, ZeroPolicy

__all__ = ["AnalyticController", "RandomPolicy", "ZeroPolicy"]
