"""The assembly change's check simulation: the demonstration's compiled loop takes the steps
the simulation's own step would, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planar3p_gym import Design
from planar3p_gym.sim.dynamics import MachineDynamics
from planar3p_gym.sim.physics import Planar3PSim
from planar3p_gym.tasks import crossing_checks, sampling
from planar3p_gym.tasks.assembly_change import CrossingLimits, verify_crossing
from planar3p_gym.tasks.travel_motion import TravelCurve

ENV_ID = "Planar3PAssemblyChange-v0"


@settings(derandomize=True, deadline=None, max_examples=100)
@given(
    seed=st.integers(0, 2**32 - 1),
    k=st.integers(0, 600),
    gain=st.floats(0.1, 50.0),
    peak=st.floats(0.01, 0.5),
)
def test_demonstration_commands_are_the_array_commands(seed, k, gain, peak):
    """The demonstration's commands (:func:`crossing_checks._references` in plain floats, then
    :func:`crossing_checks.travel_command`, compiled) are :meth:`TravelCurve.command`'s to the
    bit."""
    rng = np.random.default_rng(seed)
    travels = np.cumsum(rng.normal(0.0, 0.003, (50, 3)), axis=0) + 0.15
    curve = TravelCurve(travels, peak)
    rho = rng.uniform(0.0, 0.3, 3).tolist()
    dt = 0.02
    references, rates = crossing_checks._references(curve, dt, k + 1)
    got = [
        crossing_checks.travel_command(rates[k, i], references[k, i], rho[i], gain, 0.2)
        for i in range(3)
    ]
    assert got == curve.command((k + 1) * dt, rho, gain, 0.2).tolist()


def _pairs(env, n):
    """``n`` feasible (start, target, mode) of the environment's sampler."""
    out = []
    for seed in range(n):
        _, info = env.reset(seed=seed)
        spec = info["episode_spec"]
        out.append((np.array(spec["start"]), np.array(spec["target"]), tuple(spec["working_mode"])))
    return out


@pytest.mark.parametrize("limits", [CrossingLimits(), CrossingLimits(travel_gain=60.0)])
def test_the_compiled_demonstration_takes_the_steps_of_the_step_by_step_one(env, limits):
    """The same figures, final state and command log with the compiled loop as with
    ``step_unchecked`` step by step (the fallback for simulations without the fast path), on
    feasible pairs and, at a high gain, on demonstrations that may break down on the way."""
    task = env.unwrapped.task
    design, breakdown = env.unwrapped.design, env.unwrapped.breakdown_distance
    sims = {}

    def make(fast):
        def build(pose, mode):
            sim = task.make_sim(pose, mode)
            if not fast:
                sim.compiled_step = lambda: None  # the step-by-step loop
            assert (sim.compiled_step() is not None) == fast
            sims[fast] = sim
            return sim

        return build

    for start, target, mode in _pairs(env, 4):
        results = {}
        for fast in (True, False):
            results[fast] = verify_crossing(
                design, start, target, mode, limits, make(fast), breakdown
            )
        assert results[True] == results[False]
        a, b = sims[True], sims[False]
        assert a.state == b.state
        assert a.get_state() == b.get_state()  # the command log and the clock included


def test_only_a_projected_ideal_simulation_has_a_compiled_step():
    """Servo lag (each step filters the command first), no projection or a closed simulation:
    no compiled step, so the demonstration steps one by one."""
    design, mode = Design.fig8(), (1, 1, -1)
    poses, _ = sampling.sample_poses(design, mode, np.random.default_rng(0), sampling.TaskConfig())
    ideal = Planar3PSim(design, poses[0], mode, projection=True)
    assert ideal.compiled_step() is not None
    ideal.close()
    assert ideal.compiled_step() is None
    lagged = Planar3PSim(
        design, poses[0], mode, projection=True, dynamics=MachineDynamics(servo_lag=0.01)
    )
    assert lagged.compiled_step() is None
    assert Planar3PSim(design, poses[0], mode, projection=False).compiled_step() is None


def test_a_kept_check_simulation_gives_the_new_simulations_results(env):
    """``verify_crossing(sim=...)`` moves one simulation from check to check (the task's kept
    check simulation): the same figures as a new simulation per check, and it stays open."""
    task = env.unwrapped.task
    design, breakdown = env.unwrapped.design, env.unwrapped.breakdown_distance
    limits = CrossingLimits()
    pairs = _pairs(env, 3)
    kept = task.make_sim(pairs[0][0], pairs[0][2])
    for start, target, mode in pairs:
        new = verify_crossing(design, start, target, mode, limits, task.make_sim, breakdown)
        moved = verify_crossing(design, start, target, mode, limits, None, breakdown, sim=kept)
        assert moved == new
        assert not kept.closed
    with pytest.raises(ValueError, match="needs make_sim or sim"):
        verify_crossing(design, start, target, mode, limits, None, breakdown)
