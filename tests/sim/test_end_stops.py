"""The end stops hold on every registered id.

On every step either the episode ends with ``"physics_breakdown"`` or the simulated state has
every travel within ``[-0.5 mm, stroke + 0.5 mm]``, every slider rate within the projection's
rate limit (:attr:`planar3p_gym.sim.projection.LoopProjector.rate_limit`: ``max_speed`` plus
:data:`~planar3p_gym.sim.projection.RATE_ALLOWANCE` times it) and the loop closed (1e-9 m on the
projected ids).  The two reproductions of the issue are regression tests (both failed before
the stops became constraints of the projection); a hypothesis property drives random and
bang-bang actions on every id; the numpy batch of the vector env follows the scalar projection
bit for bit through the new paths (stops fixed during the correction, failures, rate limit).
``scripts/soak_end_stops.py`` measures the same on many more steps.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from projection_helpers import project_rows, recorded_projections
from script_loader import load_script

import planar3p_gym
from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.sim.physics import FOLLOWING_ERROR_LIMIT
from planar3p_gym.sim.projection import STOP_CONTACT

soak = load_script("soak_end_stops")

#: Travel allowed past a stop (m).
STROKE_TOLERANCE = 5e-4
#: Steps per property example.
STEPS = 150


def make(env_id: str) -> gym.Env:
    return gym.make(env_id)


_ENVS: dict[str, gym.Env] = {}


def shared(env_id: str) -> gym.Env:
    """One environment per id for the property test (made once: some resets verify)."""
    if env_id not in _ENVS:
        _ENVS[env_id] = make(env_id)
    return _ENVS[env_id]


def assert_step_holds(env: gym.Env, info: dict, tolerance: float = STROKE_TOLERANCE) -> bool:
    """The module docstring's check of one step; True when the episode broke down (the
    projection reported it: closure error ``inf``)."""
    if info["termination_reason"] == "physics_breakdown":
        assert not env.unwrapped.sim.state.finite or env.unwrapped.projection is False
        return True
    m = soak.check_state(env, False)
    state = env.unwrapped.sim.state
    assert m["overshoot"] <= tolerance, state.rho
    assert m["rate"] <= soak.rate_limit(env), state.rho_dot
    assert m["closure_ok"] == 1.0, state.closure_error
    # What the agent is told is the simulated state.
    assert info["rho"] == state.rho and info["rho_dot"] == state.rho_dot
    return False


# ---------------------------------------------------------------------------- the reproductions
def test_assembly_change_seed_9_stays_on_its_stroke():
    """``reset(seed=9)`` then 16 steps of ``[-1, 1, -1]`` near a parallel
    singularity put the travels at (0.97, 1.09, 1.28) m on a 0.3 m stroke at up to 86 m/s."""
    env = make(planar3p_gym.ASSEMBLY_CHANGE_ENV_ID)
    env.reset(seed=9)
    for _ in range(16):
        _, _, terminated, truncated, info = env.step(np.array([-1.0, 1.0, -1.0], np.float32))
        if assert_step_holds(env, info) or terminated or truncated:
            break
    env.close()


def test_v0_bang_bang_seed_22_stays_on_its_stroke():
    """``Planar3P-v0``, ``reset(seed=22)``, bang-bang actions from
    ``default_rng(22)``: slider 1 reached 0.321 m (2.1 cm past its stop) at step 85."""
    env = make(planar3p_gym.ENV_ID)
    env.reset(seed=22)
    rng = np.random.default_rng(22)
    for _ in range(250):
        _, _, terminated, truncated, info = env.step(rng.choice([-1.0, 1.0], 3))
        if assert_step_holds(env, info) or terminated or truncated:
            break
    env.close()


# ---------------------------------------------------------------------------- every id
@pytest.mark.parametrize("env_id", soak.IDS)
@settings(derandomize=True, deadline=None, max_examples=6)
@given(policy=st.sampled_from(soak.POLICIES), seed=st.integers(0, 2**16))
def test_end_stops_hold_on_every_id(env_id, policy, seed):
    env = shared(env_id)
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    for _ in range(STEPS):
        _, _, terminated, truncated, info = env.step(soak.action(policy, rng, env))
        if assert_step_holds(env, info) or terminated or truncated:
            break


# ---------------------------------------------------------------------------- the numpy batch
def recorded_readouts() -> tuple[object, list[list[float]], list[tuple[bool, bool, bool]]]:
    """The readouts projected in the two reproductions (and a few more bang-bang episodes on
    ``Planar3PAssemblyChange-v0``), with their saturation flags."""
    vs, sats = [], []
    projector = None
    for env_id, seeds in (
        (planar3p_gym.ASSEMBLY_CHANGE_ENV_ID, (9, 10, 11, 12)),
        (planar3p_gym.ENV_ID, (22,)),
    ):
        env = make(env_id)
        for seed in seeds:
            env.reset(seed=seed)
            projector = env.unwrapped.sim._projector

            def record(before, saturated, after):
                vs.append(before)
                sats.append(saturated)

            rng = np.random.default_rng(seed)
            with recorded_projections(record):
                for n in range(250):
                    a = np.array([-1.0, 1.0, -1.0]) if seed == 9 else rng.choice([-1.0, 1.0], 3)
                    _, _, terminated, truncated, _ = env.step(a)
                    if terminated or truncated or n > 120:
                        break
        env.close()
    # And readouts with a slider just inside a stop, its servo saturated, the other bodies a
    # millimetre off: the correction with free sliders would move it past the stop.
    rng = np.random.default_rng(3)
    stroke = projector.stroke
    for v in vs[::8]:
        for i in range(3):
            w = np.array(v)
            o = 6 + 18 * i
            w[o] = projector.origins[i] + (1e-5 if rng.random() < 0.5 else stroke - 1e-5)
            w[o + 6], w[o + 9] = w[o], 0.0  # its drive there, at rest
            for b in (0, 18, 36, 54):  # platform and legs
                w[b : b + 6] += rng.normal(0.0, 1e-3, 6)
            vs.append(w.tolist())
            sats.append((True, True, True) if i else (True, bool(rng.random() < 0.5), False))
    # And readouts with a saturated servo's slider at 3 m/s (the projection's rate limit is
    # 1 m/s): the episodes above no longer reach it, the steps that would being recovered.
    for v in vs[::16]:
        w = np.array(v)
        w[9] = 3.0 if rng.random() < 0.5 else -3.0
        vs.append(w.tolist())
        sats.append((True, True, True))
    return projector, vs, sats


def test_batch_projection_follows_the_new_paths_bit_for_bit():
    projector, vs, sats = recorded_readouts()
    buf = np.zeros((len(vs), 132))
    buf[:, :60] = vs
    st_ = project_rows(buf, np.array(sats, dtype=bool).T, projector.constants)
    failed = limited = stopped = 0
    for j, v in enumerate(vs):
        pr = projector.project(v, sats[j], FOLLOWING_ERROR_LIMIT)  # as Planar3PSim._project
        assert buf[j, :60].tolist() == pr.bodies
        assert st_.rho[:, j].tolist() == list(pr.rho)
        assert st_.rho_dot[:, j].tolist() == list(pr.rho_dot)
        assert st_.pose[:, j].tolist() == [pr.pose[0], pr.pose[1], wrap_angle(pr.pose[2])]
        assert st_.twist[:, j].tolist() == list(pr.twist)
        assert st_.leg_angles[:, j].tolist() == list(pr.leg_angles)
        assert st_.closure[j] == pr.closure_error
        assert bool(st_.finite[j]) == math.isfinite(pr.closure_error)
        failed += pr.closure_error == math.inf
        limited += max(abs(r) for r in pr.rho_dot) == projector.rate_limit
        inside = [
            0.0 <= v[o] - a <= projector.stroke
            for o, a in zip((6, 24, 42), projector.origins, strict=True)
        ]
        at_stop = [r in (-STOP_CONTACT, projector.stroke + STOP_CONTACT) for r in pr.rho]
        stopped += any(i and s for i, s in zip(inside, at_stop, strict=True))
    assert failed > 0 and limited > 0 and stopped > 0, (failed, limited, stopped)
