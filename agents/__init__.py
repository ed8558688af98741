"""Agents for ``Planar3P-v0``: the paper's analytic controller, floor baselines, a policy
loader for Stable-Baselines3 models, and the evaluation used by ``scripts/benchmark.py``.

* :mod:`agents.policy_base` -- SB3's ``predict`` convention written once
  (:class:`~agents.policy_base.BatchPolicy`, :class:`~agents.policy_base.PolicyAdapter`); every
  policy below follows it.
* :mod:`agents.analytic` -- :class:`~agents.analytic.AnalyticController` (simple motions,
  ``"simultaneous"`` or ``"sequential"``), with SB3's ``predict`` convention.
* :mod:`agents.baselines` -- :class:`~agents.baselines.RandomPolicy`,
  :class:`~agents.baselines.ZeroPolicy`.
* :mod:`agents.policies` -- :func:`~agents.policies.load_policy`: a name
  (``analytic-simultaneous``, ``analytic-sequential``, ``random``, ``zero``,
  ``pretrained:<name>``) or a model path -> a policy (parts: :mod:`agents.policy_spec`,
  :mod:`agents.pretrained_manifest`, :mod:`agents.sb3_models`).
* Task baselines: :mod:`agents.planner` (mode change) and :mod:`agents.crossing` (assembly
  change) on :mod:`agents.travel_follower`, :mod:`agents.tracking`, :mod:`agents.goal_adapter`.
* The benchmark: :mod:`agents.suites` (fixed suites ``standard``, ``hard``, ``far``; saving
  and loading), :mod:`agents.task_suites` (suites and baselines of the task ids),
  :mod:`agents.paths` and :mod:`agents.region_maps` (path diagnostics and singularity-free
  regions the suites use), :mod:`agents.episodes` (the episode runner),
  :mod:`agents.statistics` (IQM, bootstrap and Wilson intervals, summaries),
  :mod:`agents.report` / :mod:`agents.report_plots` (report, CSV, figures) and
  :mod:`agents.benchmark` (:func:`~agents.benchmark.run_benchmark`, used by
  ``scripts/benchmark.py``).
* Training: :mod:`agents.training` (hyperparameters, rl-zoo3 format), :mod:`agents.train_run`
  (one run: :func:`~agents.train_run.plan_run`, :func:`~agents.train_run.execute`),
  :mod:`agents.kickstart`, :mod:`agents.sweep` (Ray Tune sweeps), :mod:`agents.shipping`
  (``agents/pretrained`` in both layouts), :mod:`agents.learning_curves`.

Importing this package does not import torch or Stable-Baselines3 (only loading a model does).
"""

from .analytic import AnalyticController
from .baselines import RandomPolicy, ZeroPolicy

__all__ = ["AnalyticController", "RandomPolicy", "ZeroPolicy"]
