"""The constrained-dynamics step of the control steps that lock at a parallel singularity
(planar3p_gym.sim.recovery): it takes the steps whose projection fails or that make energy,
keeps the loop closed, the sliders on their stroke and the energy within the servos' work, and
is the same on every path (compiled, pymunk's API, the batch) bit for bit."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import planar3p_gym
from planar3p_gym.sim import chipmunk, recovery
from planar3p_gym.sim.physics import FOLLOWING_ERROR_LIMIT, Planar3PSim
from planar3p_gym.sim.projection import MAX_CLOSURE_ERROR, RECOVERY_OFFSET

#: Assembly-change episodes whose bang-bang actions lock the chain at a parallel singularity
#: (every one of them ended in ``physics_breakdown`` before the recovery).
SEEDS = (10000, 10001, 10003)
STEPS = 150


def machine(seed: int) -> tuple[Planar3PSim, np.ndarray]:
    """A new simulation of the assembly-change episode of ``seed`` (as its env builds it) and
    ``STEPS`` bang-bang slider commands (m/s) from the same seed."""
    env = gym.make(planar3p_gym.ASSEMBLY_CHANGE_ENV_ID)
    env.reset(seed=seed)
    sim = env.unwrapped.sim
    pose, mode, settings = sim._origin
    out = Planar3PSim(sim.design, pose, mode, **settings)
    rng = np.random.default_rng(seed)
    commands = sim.design.max_speed * rng.choice([-1.0, 1.0], size=(STEPS, 3))
    env.close()
    return out, commands


def readout(sim: Planar3PSim) -> np.ndarray:
    return np.array(sim.body_values())


def numbers(sim: Planar3PSim) -> np.ndarray:
    """The recovery's machine numbers in ``sim``'s projector constants."""
    return sim._projector.constants[RECOVERY_OFFSET + 4 :]


def test_the_recovery_has_the_pymunk_models_numbers():
    """One definition: the masses, moments, gravity and force limit the recovery integrates
    with are those of the pymunk bodies and constraints (here of a machine as built)."""
    env = gym.make("Planar3PReal-v0")
    env.reset(seed=4)
    sim = env.unwrapped.sim
    rc = dict(zip(recovery.RECOVERY_FIELDS, numbers(sim).tolist(), strict=True))
    assert rc["platform_mass"] == sim.platform.mass
    assert rc["platform_moment"] == sim.platform.moment
    assert rc["slider_mass"] == sim.sliders[0].mass
    for i, leg in enumerate(sim.legs):
        assert (rc[f"leg_mass_{i + 1}"], rc[f"leg_moment_{i + 1}"]) == (leg.mass, leg.moment)
    assert (rc["gravity_x"], rc["gravity_y"]) == tuple(sim.space.gravity)
    assert rc["max_force"] == sim.servos[0].max_force
    dyn = sim.dynamics
    assert (rc["slider_viscous"], rc["joint_viscous"]) == (dyn.slider_viscous, dyn.joint_viscous)
    assert (rc["slider_coulomb"], rc["joint_coulomb"]) == (dyn.slider_coulomb, dyn.joint_coulomb)
    assert sim._projector.constants[RECOVERY_OFFSET : RECOVERY_OFFSET + 4].tolist() == [
        1.0, sim.iterations, 500, recovery.ENERGY_SLACK
    ]  # fmt: skip
    env.close()


@pytest.mark.parametrize("seed", SEEDS)
def test_locked_steps_are_recovered_on_the_stroke_with_the_loop_closed(seed):
    """Bang-bang commands through the assembly change: no step breaks down, some are
    recovered; every state has the loop closed to 1e-9 m, the sliders on their stroke and
    within the rate limit; no step makes more than the energy slack beyond the servos' work,
    and no recovered step makes any (the projections and the stops only remove energy)."""
    sim, commands = machine(seed)
    rc, stroke, limit = numbers(sim), sim.design.stroke, sim._projector.rate_limit
    recovered = 0
    for c in commands:
        start = readout(sim)
        st = sim.step(c)
        assert st.finite and st.closure_error <= MAX_CLOSURE_ERROR
        assert all(-1e-9 - 1e-15 <= r <= stroke + 1e-9 + 1e-15 for r in st.rho), st.rho
        assert max(abs(r) for r in st.rho_dot) <= limit
        excess = recovery.excess_energy(start, readout(sim), sim.dt, rc)
        assert excess <= recovery.ENERGY_SLACK
        if sim.recovered:
            recovered += 1
            assert excess <= 0.0
    assert recovered >= 5


def test_the_public_api_path_recovers_as_the_compiled_step(monkeypatch):
    """pymunk's API (``use_fast_path`` False) and the compiled step: the same states and
    bodies, recovered steps included."""
    runs = []
    for fast in (True, False):
        monkeypatch.setattr(Planar3PSim, "use_fast_path", fast)
        sim, commands = machine(SEEDS[0])
        assert (sim._fast is not None) == fast
        runs.append([(sim.step(c), sim.recovered, sim.body_values()) for c in commands])
    assert runs[0] == runs[1]
    assert sum(r for _, r, _ in runs[0]) >= 5


def test_stepping_through_the_api_mid_episode_changes_no_number():
    """:meth:`Planar3PSim.step_through_api` from a compiled episode's middle: the same states
    and bodies as the compiled steps, recovered ones included; its hook runs once a step,
    between the physics and the projection; the next reset is compiled again."""
    runs, hooks = [], []
    for switch in (False, True):
        sim, commands = machine(SEEDS[0])
        run = [(sim.step(c), sim.recovered, sim.body_values()) for c in commands[:20]]
        if switch:
            sim.step_through_api(lambda sim=sim: hooks.append(sim.body_values()))
            assert sim.batch_link() is None
        run += [(sim.step(c), sim.recovered, sim.body_values()) for c in commands[20:]]
        runs.append(run)
    assert runs[0] == runs[1]
    assert sum(r for _, r, _ in runs[1][20:]) >= 5
    assert len(hooks) == STEPS - 20
    assert hooks[0] != runs[1][19][2] and hooks[0] != runs[1][20][2]  # moved, not yet projected
    pose, mode, _ = sim._origin
    sim.reset(pose=pose, working_mode=mode)
    assert sim.batch_link() is not None


def test_stepping_through_the_api_rejects_a_hook_that_is_not_callable():
    """A hook that is not callable is refused before anything changes: the simulation stays on
    its compiled path and steps as a new one does."""
    sim, commands = machine(SEEDS[0])
    twin, _ = machine(SEEDS[0])
    with pytest.raises(ValueError, match="before_projection must be None or a callable"):
        sim.step_through_api(before_projection=1.0)
    assert sim.batch_link() is not None
    assert [sim.step(c) for c in commands[:10]] == [twin.step(c) for c in commands[:10]]


def test_the_batch_step_recovers_as_each_simulations_step():
    """:func:`chipmunk.advance_batch` (the native vector env's step) against the same
    simulations stepped one by one, recovered steps included, bit for bit."""
    pairs = [machine(s) for s in SEEDS]
    singles = [p[0] for p in pairs]
    batch = [machine(s)[0] for s in SEEDS]
    n = len(batch)
    readouts = np.zeros((n, 132))
    handles = np.zeros((n, 6), dtype=np.uintp)
    keep = []
    for i, sim in enumerate(batch):
        read = chipmunk.body_readout(readouts[i])
        keep.append(read)
        handles[i] = chipmunk.handle_row(sim._fast.space, sim._fast.servos, read)
        chipmunk.read_bodies(chipmunk.FUNCTIONS, handles[i])
    sim0, rows = batch[0], np.arange(n)
    recovered = 0
    for t in range(STEPS):
        v = np.array([p[1][t] for p in pairs])
        forces, saturated, states, closure = chipmunk.advance_batch(
            chipmunk.FUNCTIONS, handles, rows, v, sim0._h, sim0.substeps, sim0._force_limit,
            readouts, sim0._projector.constants, FOLLOWING_ERROR_LIMIT,
        )  # fmt: skip
        for k in range(n):
            s = singles[k].step(v[k])
            recovered += singles[k].recovered
            assert states[:3, k].tolist() == list(s.rho)
            assert states[6:9, k].tolist() == list(s.pose)
            assert states[9:15, k].tolist() == [*s.twist, *s.leg_angles]
            assert closure[k] == s.closure_error
            assert tuple(saturated[:, k].tolist()) == s.saturated
            assert (forces[k, :3] * sim0._force_scale).tolist() == list(s.actuator_forces)
            assert readouts[k, :60].tolist() == singles[k]._fast.readout[:60].tolist()
    assert recovered >= 10


def test_a_snapshot_replays_recovered_steps_bit_for_bit():
    sim, commands = machine(SEEDS[1])
    for c in commands:
        sim.step(c)
    copy = Planar3PSim.from_state(sim.get_state())
    assert copy.state == sim.state
    assert copy.body_values() == sim.body_values()


def test_a_free_coast_through_the_singularity_makes_no_energy():
    """The recovery alone, servos released (1e-6 N) on the gravity-free machine, coasting
    from a locked state for 100 control steps: the kinetic energy never rises by more than the
    servos could have done (1e-6 N over the whole stroke), the loop stays closed."""
    sim, commands = machine(SEEDS[0])
    for c in commands:  # to a state the bang-bang motion locks in
        sim.step(c)
        if sim.recovered:
            break
    assert sim.recovered
    rc = numbers(sim).copy()
    rc[recovery.RECOVERY_FIELDS.index("max_force")] = 1e-6
    v = readout(sim)[:60]
    e0 = recovery.energy(v, rc)
    assert e0 > 1e-3
    out, forces = np.empty(60), np.empty(6)
    bound = 3 * 1e-6 * sim.design.stroke
    for _ in range(100):
        assert recovery.recover(v, 0.0, 0.0, 0.0, sim.dt, sim._h, rc, out, forces)
        assert recovery.energy(out, rc) <= e0 + bound
        v = out.copy()
    err = []
    for i in range(3):  # leg lengths from the sliders' and the platform's joints
        o = 6 + 18 * i
        hl, d = 0.5 * rc[3 + i], rc[6 + i]
        c = (v[0] + d * math.cos(v[2]), v[1] + d * math.sin(v[2]))
        err.append(abs(math.hypot(c[0] - v[o], c[1]) - 2 * hl))
    assert max(err) <= 1e-9


def test_no_recovery_without_the_numbers():
    """A projector built without recovery numbers (no control period) never recovers."""
    sim, _ = machine(SEEDS[0])
    start = readout(sim)[:60]
    forces = np.zeros(6)
    c = sim._projector.constants[:RECOVERY_OFFSET]
    ok, *_ = chipmunk.recovered_step(start, 0.2, 0.2, 0.2, sim._h, 1.0, c, 1e-3, forces)
    assert not ok and not chipmunk.needs_recovery(start, start, math.inf, c)


@pytest.mark.parametrize("batch", ["numpy", "scalar"])
def test_the_native_vector_env_recovers_as_the_single_envs(batch):
    """``gym.make_vec("Planar3P-v0")`` (its compiled batch step or each simulation's step)
    against single environments under bang-bang actions that lock the chain: the same
    observations and rewards, bit for bit, through the recovered steps."""
    n = 6
    venv = gym.make_vec(
        planar3p_gym.ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", batch=batch
    )
    singles = [gym.make(planar3p_gym.ENV_ID) for _ in range(n)]
    obs, _ = venv.reset(seed=10000)
    for i, env in enumerate(singles):
        assert np.array_equal(env.reset(seed=10000 + i)[0], obs[i])
    rng = np.random.default_rng(1)
    done = np.zeros(n, dtype=bool)
    recovered = 0
    for _ in range(250):
        a = rng.choice(np.array([-1.0, 1.0], dtype=np.float32), (n, 3))
        obs, reward, *_ = venv.step(a)
        for i, env in enumerate(singles):
            if done[i]:  # (the vector env resets on its own from here)
                continue
            o, r, terminated, truncated, _ = env.step(a[i])
            recovered += env.unwrapped.sim.recovered
            assert np.array_equal(o, obs[i]) and r == reward[i]
            done[i] = terminated or truncated
    assert recovered >= 5
    venv.close()


@settings(max_examples=50, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_the_jacobians_zeros_are_where_the_sums_skip(seed):
    """The recovery's sums over the pivots' Jacobian skip the entries outside its structure
    (read from ``_pivots`` at one configuration); at any other configuration those entries are
    exactly zero, so the sums add the same numbers."""
    rng = np.random.default_rng(seed)
    z = rng.uniform(-3.0, 3.0, 15)
    rc = rng.uniform(0.05, 2.0, len(recovery.RECOVERY_FIELDS))
    jac = np.full((12, 15), np.nan)
    recovery._pivots(z, rc, np.empty(12), jac)
    assert np.all(jac[~recovery._NONZERO] == 0.0)
    assert np.isfinite(jac).all()
