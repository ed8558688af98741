"""Agents for ``Planar3P-v0``: the paper's analytic controller, floor baselines, a policy
loader for Stable-Baselines3 models, and the evaluation used by ``scripts/benchmark.py``.

* :mod:`agents.analytic` -- :class:`~agents.analytic.AnalyticController` (simple motions,
  ``"simultaneous"`` or ``"sequential"``), with SB3's ``predict`` convention.
* :mod:`agents.baselines` -- :class:`~agents.baselines.RandomPolicy`,
  :class:`~agents.baselines.ZeroPolicy`.
* :mod:`agents.policies` -- :func:`~agents.policies.load_policy`: a name
  (``analytic-simultaneous``, ``analytic-sequential``, ``random``, ``zero``,
  ``pretrained:<name>``) or a model path -> a policy.
* :mod:`agents.evaluation` -- fixed suites (``standard``, ``hard``, ``far``), the episode runner
  and the statistics (IQM, bootstrap intervals).

Importing this package does not import torch or Stable-Baselines3 (only loading a model does).
"""

from .analytic import AnalyticController
from .baselines import RandomPolicy, ZeroPolicy

__all__ = ["AnalyticController", "RandomPolicy", "ZeroPolicy"]
