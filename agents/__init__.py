"""Agents for ``Planar3P-v0``: the paper's analytic controller, floor baselines, a policy
loader for Stable-Baselines3 models, and the evaluation used by ``scripts/benchmark.py``.

* :mod:`planar3p_agents.controllers.base` -- SB3's ``predict`` convention written once
  (:class:`~planar3p_agents.controllers.base.BatchPolicy`, :class:`~planar3p_agents.controllers.base.PolicyAdapter`); every
  policy below follows it.
* :mod:`planar3p_agents.controllers.analytic` -- :class:`~planar3p_agents.controllers.analytic.AnalyticController` (simple motions,
  ``"simultaneous"`` or ``"sequential"``), with SB3's ``predict`` convention.
* :mod:`planar3p_agents.controllers.floor` -- :class:`~planar3p_agents.controllers.floor.RandomPolicy`,
  :class:`~planar3p_agents.controllers.floor.ZeroPolicy`.
* :mod:`planar3p_agents.policies.factory` -- :func:`~planar3p_agents.policies.factory.load_policy`: a name
  (``analytic-simultaneous``, ``analytic-sequential``, ``random``, ``zero``,
  ``pretrained:<name>``) or a model path -> a policy (parts: :mod:`planar3p_agents.policies.spec`,
  :mod:`planar3p_agents.zoo.manifest`, :mod:`planar3p_agents.policies.sb3_models`).
* Task baselines: :mod:`planar3p_agents.controllers.planner` (mode change) and :mod:`planar3p_agents.controllers.crossing` (assembly
  change) on :mod:`planar3p_agents.controllers.travel_follower`, :mod:`planar3p_agents.controllers.tracking`, :mod:`planar3p_agents.controllers.goal_adapter`.
* The benchmark: :mod:`planar3p_agents.evaluation.reach_suites` (fixed suites ``standard``, ``hard``, ``far``; saving
  and loading), :mod:`planar3p_agents.evaluation.task_suites` (suites and baselines of the task ids),
  :mod:`planar3p_agents.evaluation.path_diagnostics` and :mod:`planar3p_agents.evaluation.region_maps` (path diagnostics and singularity-free
  regions the suites use), :mod:`planar3p_agents.evaluation.episodes` (the episode runner),
  :mod:`planar3p_agents.evaluation.intervals` (IQM, bootstrap and Wilson intervals, summaries),
  :mod:`planar3p_agents.evaluation.report` / :mod:`planar3p_agents.evaluation.report_plots` (report, CSV, figures) and
  :mod:`planar3p_agents.evaluation.benchmark` (:func:`~planar3p_agents.evaluation.benchmark.run_benchmark`, used by
  ``scripts/benchmark.py``).
* Training: :mod:`planar3p_agents.training.config` (hyperparameters, rl-zoo3 format), :mod:`planar3p_agents.training.run`
  (one run: :func:`~planar3p_agents.training.run.plan_run`, :func:`~planar3p_agents.training.run.execute`),
  :mod:`planar3p_agents.training.kickstart`, :mod:`planar3p_agents.training.sweep` (Ray Tune sweeps), :mod:`planar3p_agents.zoo.shipping`
  (``agents/zoo/pretrained`` in both layouts), :mod:`planar3p_agents.evaluation.learning_curves`.

Importing this package does not import torch or Stable-Baselines3 (only loading a model does).
"""

from planar3p_agents.controllers.analytic import AnalyticController
from planar3p_agents.controllers.floor import RandomPolicy, ZeroPolicy

__all__ = ["AnalyticController", "RandomPolicy", "ZeroPolicy"]
