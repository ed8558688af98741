"""The goal task's compiled kernel (:class:`planar3p_gym.tasks.goal.GoalKernel`) against the
reference kernel, its hooks."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import planar3p_gym  # noqa: F401  (registers the ids)
from planar3p_gym.tasks.goal import GoalKernel
from planar3p_gym.tasks.kernel import StepKernel

EPS = np.finfo(np.float64).eps


@pytest.mark.parametrize("env_id", ["Planar3PGoal-v0", "Planar3PGoalDense-v0"])
def test_the_compiled_goal_kernel_agrees_with_the_reference(env_id):
    """Over 2,000 random steps (about 20 episodes, successes and crossings among their ends):
    the same ends, the same goals (the goal test is one compiled definition in both), and the
    margins, errors and rewards of the reach kernel's compiled outputs within a few float64
    rounding errors of the reference's (the compiled margins share intermediate values instead
    of recomputing them; a barrier ``ref / m - 1`` below its reference margin turns a margin's
    difference ``dm`` into ``ref dm / m^2``, which the reward's bound adds, weighted).  The
    robot observation is float32: equal or one float32 rounding apart."""
    compiled, reference = gym.make(env_id), gym.make(env_id)
    assert isinstance(compiled.unwrapped.kernel, GoalKernel)
    kernel = reference.unwrapped.kernel  # (the reference env's task and machine)
    reference.unwrapped.kernel = StepKernel(kernel.task, kernel.settings, kernel.machine)
    w = compiled.unwrapped.reward_weights
    compiled.reset(seed=3)
    reference.reset(seed=3)
    reasons = set()
    for a in np.random.default_rng(0).uniform(-1, 1, (2000, 3)).astype(np.float32):
        o1, r1, te1, tr1, i1 = compiled.step(a)
        o2, r2, te2, tr2, i2 = reference.step(a)
        assert (te1, tr1, i1["termination_reason"]) == (te2, tr2, i2["termination_reason"])
        assert i1["is_success"] == i2["is_success"] and i1["failure"] == i2["failure"]
        for key in ("achieved_goal", "desired_goal"):
            assert o1[key].tobytes() == o2[key].tobytes()
        np.testing.assert_allclose(
            o1["observation"], o2["observation"], rtol=2 * np.finfo(np.float32).eps, atol=1e-12
        )
        for key in ("position_error", "orientation_error", "parallel_margin", "serial_margin"):
            assert abs(i1[key] - i2[key]) <= 64 * EPS, key
        assert i1["pose"] == i2["pose"] and i1["rho"] == i2["rho"]  # the same physics
        slope = sum(
            ref / m**2
            for m, ref in (
                (i2["parallel_margin"], w.parallel_margin_ref),
                (i2["serial_margin"], w.serial_margin_ref),
            )
            if m < ref
        )
        assert abs(r1 - r2) <= 64 * EPS * (max(1.0, abs(r2)) + 2.0 * w.singularity * slope)
        assert r1 == compiled.unwrapped.compute_reward(o1["achieved_goal"], o1["desired_goal"], i1)
        reasons.add(i1["termination_reason"])
        if te1 or tr1:
            compiled.reset()
            reference.reset()
    assert {"singularity_crossing", None} <= reasons
