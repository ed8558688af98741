"""The batch's projection rows (planar3p_gym.sim.projection.project_row) and reach outputs
(planar3p_gym.tasks.reach_step.reach_outputs_batch) give the scalar code's numbers bit for bit,
and the fused reach step the general step's to float64 rounding."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
from projection_helpers import project_rows

import planar3p_gym  # noqa: F401  (registers the ids)
from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.tasks.kernel import ReachKernel, StepKernel
from planar3p_gym.tasks.observation import OBS_SIZE
from planar3p_gym.tasks.reach_step import RESULT_FIELDS, BatchReach, reach_outputs_batch


def readouts(seed: int, n: int) -> tuple[object, list[list[float]], np.ndarray]:
    """A simulation and ``n`` perturbed copies of its body readout (perturbations from 1e-7
    to 1e-2 of the natural units, some sliders pushed past an end stop) with random servo
    saturation flags ``(n, 3)``."""
    env = gym.make("Planar3P-v0", working_mode="random").unwrapped
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    for a in rng.uniform(-1, 1, (20, 3)):
        env.step(a)
    sim = env.sim
    base = np.array(sim._batch_values(sim._fast)[:66])
    out = []
    for k in range(n):
        v = base + rng.normal(0.0, 10.0 ** rng.uniform(-7, -2), base.shape)
        if k % 7 == 0:  # a slider past an end stop, its servo's setpoint either side
            i = int(rng.integers(3))
            a = sim.design.rail_origins[i]
            v[6 + 18 * i] = a + (-2e-4 if k % 2 else sim.design.stroke + 2e-4)
            v[12 + 18 * i] = v[6 + 18 * i] + rng.choice((-1e-3, 1e-3))
        out.append(v.tolist())
    return sim, out, rng.integers(0, 2, (n, 3)).astype(bool)


def test_batch_projection_is_the_scalar_projection_bit_for_bit():
    checked = restarts = 0
    for seed in range(3):
        sim, vs, sat = readouts(seed, 64)
        scalar = sim._projector
        buf = np.zeros((len(vs), 132))
        buf[:, :66] = vs
        st = project_rows(buf, sat.T, scalar.constants)
        for j, v in enumerate(vs):
            pr = scalar.project(v, tuple(bool(b) for b in sat[j]))
            restarts += pr.newton_steps > 4
            out = list(pr.bodies)
            for o in (12, 30, 48):  # Planar3PSim._project's setpoint limit
                lim, slider = 0.001, out[o - 6]
                if out[o] - slider > lim:
                    out[o] = slider + lim
                elif slider - out[o] > lim:
                    out[o] = slider - lim
            assert buf[j, :60].tolist() == out
            assert st.rho[:, j].tolist() == list(pr.rho)
            assert st.rho_dot[:, j].tolist() == list(pr.rho_dot)
            assert st.pose[:, j].tolist() == [pr.pose[0], pr.pose[1], wrap_angle(pr.pose[2])]
            assert st.twist[:, j].tolist() == list(pr.twist)
            assert st.leg_angles[:, j].tolist() == list(pr.leg_angles)
            assert st.closure[j] == pr.closure_error
            x1, y1, x2, y2, x3, y3, c, s = pr.geometry
            assert st.ux[:, j].tolist() == [x1, x2, x3]
            assert st.uy[:, j].tolist() == [y1, y2, y3]
            assert (st.c[j], st.s[j]) == (c, s)
            checked += 1
    assert checked == 192 and restarts > 0  # the restart with free sliders was exercised


def test_batch_reach_outputs_are_the_fused_outputs_bit_for_bit():
    """:func:`reach_outputs_batch` (the native vector env's outputs) against the single
    environment's :meth:`ReachStep.compute`, state by state, with both termination branches."""
    env = gym.make("Planar3P-v0", working_mode="random").unwrapped
    rng = np.random.default_rng(5)
    rows, targets, actions, assemblies = [], [], [], []
    for episode in range(4):
        env.reset(seed=40 + episode)
        for a in rng.uniform(-1, 1, (30, 3)):
            a = tuple(float(x) for x in np.clip(a * 1.3, -1, 1))
            s = env.sim.step_unchecked(*(x * env.design.max_speed for x in a))
            rows.append((*s.rho, *s.rho_dot, *s.pose, *s.twist, *s.leg_angles, *env.sim.geometry))
            targets.append(env.episode.target)
            actions.append(a)
            assemblies.append(int(rng.choice((-1, 1))))  # both termination branches
    reach = env.kernel.reach
    batch = BatchReach(reach)
    n = len(rows)
    states = np.array(rows).T.copy()  # (23, N)
    target = np.array([(*t, math.cos(t[2]), math.sin(t[2])) for t in targets]).T.copy()
    tolerances = np.tile(np.array(reach.tolerances)[:, None], (1, n))
    obs_rows, obs = np.empty((n, OBS_SIZE)), np.empty((n, OBS_SIZE), dtype=np.float32)
    res = np.empty((len(RESULT_FIELDS), n))
    reach_outputs_batch(
        states, target, np.array(assemblies), np.array(actions).T.copy(), tolerances,
        batch.consts, batch.weights.as_array(), batch.low, batch.high, obs_rows, obs, res,
    )  # fmt: skip
    for j in range(n):
        single = reach.compute(
            np.array(rows[j]), rows[j][8], targets[j], tuple(target[3:, j]), assemblies[j],
            actions[j],
        )  # fmt: skip
        assert res[:, j].tolist() == single.tolist()
        np.testing.assert_array_equal(obs[j], reach.obs)
    out = BatchReach.results(obs, res)
    assert set(out["reason"].tolist()) >= {0, 2}  # steps going on and singularity crossings
    assert out["reward"].tolist() == res[0].tolist()


def test_fused_reach_step_agrees_with_the_general_step():
    """The fused step shares intermediate values (``cos alpha_i = u_ix / |u_i|``, ...) instead
    of recomputing them: observations, margins, errors and rewards agree with the general
    step's to a few float64 rounding errors of their magnitude, over 2,000 steps.  Below its
    reference margin ``ref`` a singularity barrier ``ref / m - 1`` turns a margin's difference
    ``dm`` into ``ref dm / m^2``, which the reward's bound adds (weighted)."""
    fused, general = gym.make("Planar3P-v0"), gym.make("Planar3P-v0")
    w = fused.unwrapped.reward_weights
    compiled = general.unwrapped.kernel
    assert isinstance(compiled, ReachKernel)
    general.unwrapped.kernel = StepKernel(compiled.task, compiled.settings, compiled.machine)
    rng = np.random.default_rng(0)
    fused.reset(seed=3)
    general.reset(seed=3)
    eps = np.finfo(np.float64).eps
    for a in rng.uniform(-1, 1, (2000, 3)).astype(np.float32):
        o1, r1, te1, tr1, i1 = fused.step(a)
        o2, r2, te2, tr2, i2 = general.step(a)
        assert (te1, tr1, i1["termination_reason"]) == (te2, tr2, i2["termination_reason"])
        # float32 observations: equal or one float32 rounding apart
        np.testing.assert_allclose(o1, o2, rtol=2 * np.finfo(np.float32).eps, atol=1e-12)
        for key in ("position_error", "orientation_error", "parallel_margin", "serial_margin"):
            assert abs(i1[key] - i2[key]) <= 64 * eps, key
        barrier_slope = sum(
            ref / m**2
            for m, ref in (
                (i2["parallel_margin"], w.parallel_margin_ref),
                (i2["serial_margin"], w.serial_margin_ref),
            )
            if m < ref
        )
        bound = 64 * eps * (max(1.0, abs(r2)) + 2.0 * w.singularity * barrier_slope)
        assert abs(r1 - r2) <= bound
        assert i1["pose"] == i2["pose"] and i1["rho"] == i2["rho"]  # the same physics
        if te1 or tr1:
            fused.reset()
            general.reset()
