"""The analytic simple-motion controller: formulas, modes, robustness, and closed loop."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import planar3p_gym
from planar3p_agents.controllers.analytic import (
    HORIZONTAL,
    ROTATE,
    VERTICAL,
    AnalyticController,
)
from planar3p_agents.controllers.floor import RandomPolicy, ZeroPolicy
from planar3p_gym import Design
from planar3p_gym.machine import kinematics
from planar3p_gym.tasks.observation import OBS_SIZE, SLICES

DESIGN = Design.fig8()
MODE = (1, 1, -1)
# An easy, comfortable reaching task of the default working mode (checked in a test below).
EASY_START = np.array([0.006, 0.158, -0.16])
EASY_TARGET = np.array([0.023, 0.194, -0.50])


def _obs_for(pose, target, mode=MODE) -> np.ndarray:
    """The environment's observation of the mechanism at rest at ``pose``."""
    e = gym.make(planar3p_gym.ENV_ID)
    obs, _ = e.reset(options={"start": pose, "target": target, "working_mode": mode})
    e.close()
    return obs


def _play(env, controller, start, target, steps=250):
    obs, info = env.reset(options={"start": start, "target": target, "working_mode": MODE})
    state, first = None, True
    for _ in range(steps):
        action, state = controller.predict(obs, state=state, episode_start=np.array([first]))
        first = False
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    return info


def test_easy_case_is_comfortable():
    for pose in (EASY_START, EASY_TARGET):
        rho = kinematics.inverse(DESIGN, pose, MODE).rho
        assert float(kinematics.parallel_margin(DESIGN, pose, rho)) > 0.04
        assert float(kinematics.serial_margin(DESIGN, pose, rho)) > 0.2


@pytest.mark.parametrize("mode", ["simultaneous", "sequential"])
def test_reaches_target_in_simulation(env, mode):
    info = _play(env, AnalyticController.from_env(env, mode), EASY_START, EASY_TARGET)
    assert info["termination_reason"] == "success", info["termination_reason"]
    assert info["position_error"] <= 0.002
    assert abs(info["orientation_error"]) <= math.radians(1.0)
    assert max(abs(v) for v in info["rho_dot"]) <= 0.01


def test_simultaneous_follows_the_straight_path(env):
    """Resolved-rate control moves along the straight line in pose space (no saturation of
    one leg only, thanks to the uniform scaling)."""
    ctrl = AnalyticController.from_env(env, "simultaneous")
    obs, info = env.reset(
        options={"start": EASY_START, "target": EASY_TARGET, "working_mode": MODE}
    )
    line = EASY_TARGET - EASY_START
    scale = np.array([1.0, 1.0, DESIGN.characteristic_length])
    worst = 0.0
    for _ in range(60):
        obs, *_, info = env.step(ctrl.predict(obs)[0])
        d = (np.array(info["pose"]) - EASY_START) * scale
        u = line * scale / np.linalg.norm(line * scale)
        worst = max(worst, float(np.linalg.norm(d - (d @ u) * u)))
    assert worst < 0.003  # metres (pose-distance units), off a 0.1 m long path


def test_the_floored_basis_is_exact_away_from_the_floor():
    rng = np.random.default_rng(0)
    alpha = rng.uniform(-1.3, 1.3, (50, 3)) + np.where(rng.random((50, 3)) < 0.5, 0, np.pi)
    theta = rng.uniform(-np.pi, np.pi, 50)
    twist = rng.normal(size=(50, 3))
    hor, ver, rot = kinematics.simple_motion_basis(
        DESIGN, np.cos(alpha), np.sin(alpha), np.cos(theta), np.sin(theta), epsilon=1e-12
    )
    mine = twist[:, :1] * hor + twist[:, 1:2] * ver + twist[:, 2:] * rot
    ref = kinematics.simple_motion_rates_from_angles(DESIGN, alpha, theta, twist)
    np.testing.assert_allclose(mine, ref, rtol=1e-9, atol=1e-12)


def test_rates_realise_the_commanded_twist():
    """B rho_dot = A p_dot for the controller's rates at a real configuration."""
    ctrl = AnalyticController(DESIGN, "simultaneous", position_gain=1.0, orientation_gain=1.0)
    obs = _obs_for(EASY_START, EASY_TARGET)
    action, _ = ctrl.predict(obs)
    rho_dot = action.astype(np.float64) * DESIGN.max_speed
    err = obs[SLICES["position_error"]].astype(np.float64)
    twist = np.array([err[0], err[1], float(obs[SLICES["orientation_error"]][0])])
    rho = obs[SLICES["rho"]].astype(np.float64)
    pose = np.array([*obs[SLICES["position"]], math.atan2(*obs[SLICES["orientation"]][::-1])])
    A, B = kinematics.jacobians(DESIGN, pose, rho)
    # Same direction of motion (uniform scaling may shorten it).
    lhs, rhs = B @ rho_dot, A @ twist
    cos = lhs @ rhs / (np.linalg.norm(lhs) * np.linalg.norm(rhs))
    assert cos > 0.9999


def test_modes_agree_for_small_motions():
    """With small errors nothing saturates, and the superposition of the three sequential
    simple motions is exactly the simultaneous command."""
    obs = _obs_for(EASY_START, EASY_START + np.array([0.0, 0.0, 1e-3]))
    err = np.array([1.0e-3, -0.8e-3, 4e-3])  # m, m, rad
    obs[SLICES["position_error"]] = err[:2]
    obs[SLICES["orientation_error"]] = err[2]
    sim = AnalyticController(DESIGN, "simultaneous")
    seq = AnalyticController(
        DESIGN,
        "sequential",
        rotation_done=1e-9,
        rotation_reenter=1.0,
        vertical_done=1e-9,
        vertical_reenter=1.0,
    )
    a_sim, state = sim.predict(obs)
    assert state is None
    total = np.zeros(3)
    for phase in (ROTATE, VERTICAL, HORIZONTAL):
        a, new_state = seq.predict(obs, state=np.array([phase]))
        assert new_state.tolist() == [phase]
        total += a
    assert np.abs(a_sim).max() < 0.5  # far from saturation
    np.testing.assert_allclose(total, a_sim, rtol=1e-5, atol=1e-7)


def test_modes_agree_in_closed_loop_for_a_small_motion():
    """A small pure rotation: while the sequential controller rotates, both modes issue the
    same commands and the simulated motions coincide; both reach the target, the sequential
    one stopping its rotation within its phase threshold.  On the unprojected model, whose
    gripper keeps its position to 1e-5 m during a pure rotation command; on the exact machine
    the simultaneous controller corrects a position drift of ~0.2 mm that the sequential one
    leaves to its later phases, so their commands differ by ~1 %."""
    env = gym.make(planar3p_gym.ENV_ID, projection=False)
    target = EASY_START + np.array([0.0, 0.0, math.radians(2.0)])
    paths, finals = [], []
    for mode in ("simultaneous", "sequential"):
        ctrl = AnalyticController.from_env(env, mode)
        obs, info = env.reset(options={"start": EASY_START, "target": target, "working_mode": MODE})
        state, first, poses = None, True, []
        for _ in range(250):
            action, state = ctrl.predict(obs, state=state, episode_start=np.array([first]))
            first = False
            obs, _, terminated, truncated, info = env.step(action)
            poses.append(info["pose"])
            if terminated or truncated:
                break
        assert info["is_success"], mode
        paths.append(np.array(poses[:8]))
        finals.append(np.array(info["pose"]))
    np.testing.assert_allclose(paths[0], paths[1], atol=1e-5)
    assert np.abs(finals[0][:2] - finals[1][:2]).max() < 1e-3
    assert abs(finals[0][2] - finals[1][2]) < math.radians(0.3) + 1e-3


def test_sequential_phases_in_order():
    ctrl = AnalyticController(DESIGN, "sequential")
    obs = _obs_for(EASY_START, EASY_TARGET)
    _, state = ctrl.predict(obs, episode_start=np.array([True]))
    assert state.tolist() == [ROTATE]
    # Orientation reached: the controller moves on (vertical error still large).
    obs2 = obs.copy()
    obs2[SLICES["orientation_error"]] = 0.0
    _, state = ctrl.predict(obs2, state=state)
    assert state.tolist() == [VERTICAL]
    # Only the horizontal error left.
    obs3 = obs2.copy()
    obs3[SLICES["position_error"].start + 1] = 0.0
    action, state = ctrl.predict(obs3, state=state)
    assert state.tolist() == [HORIZONTAL]
    assert np.allclose(action, action[0])  # horizontal translation: all sliders alike
    # The orientation error grows again: back to rotation; a new episode also restarts.
    _, state = ctrl.predict(obs, state=state)
    assert state.tolist() == [ROTATE]
    _, state = ctrl.predict(obs2, state=np.array([HORIZONTAL]), episode_start=np.array([True]))
    assert state.tolist() == [VERTICAL]  # restarted at rotation, which is already done


def test_batched_predict_matches_single():
    obs = np.stack([_obs_for(EASY_START, EASY_TARGET), _obs_for(EASY_TARGET, EASY_START)])
    for mode in ("simultaneous", "sequential"):
        ctrl = AnalyticController(DESIGN, mode)
        batch, state = ctrl.predict(obs, episode_start=np.array([True, True]))
        assert batch.shape == (2, 3) and batch.dtype == np.float32
        for k in range(2):
            single, _ = AnalyticController(DESIGN, mode).predict(obs[k])
            np.testing.assert_allclose(batch[k], single)
        if mode == "sequential":
            assert state.shape == (2,)


def test_rates_vanish_with_the_errors():
    obs = _obs_for(EASY_START, EASY_TARGET)
    obs[SLICES["position_error"]] = 0.0
    obs[SLICES["orientation_error"]] = 0.0
    for mode in ("simultaneous", "sequential"):
        action, _ = AnalyticController(DESIGN, mode).predict(obs)
        assert np.all(action == 0.0)


def _obs_with_legs(cos_a, sin_sign=1.0, err=(0.05, -0.03, 0.4)) -> np.ndarray:
    obs = np.zeros(OBS_SIZE, dtype=np.float32)
    c = np.asarray(cos_a, dtype=np.float64)
    legs = np.stack([c, sin_sign * np.sqrt(np.clip(1 - c * c, 0, 1))], axis=1)
    obs[SLICES["legs"]] = legs.ravel()
    obs[SLICES["orientation"]] = (math.cos(-0.5), math.sin(-0.5))
    obs[SLICES["position_error"]] = err[:2]
    obs[SLICES["orientation_error"]] = err[2]
    return obs


@given(
    cos_a=st.lists(
        st.one_of(st.just(0.0), st.floats(-1e-3, 1e-3), st.floats(-1.0, 1.0)),
        min_size=3,
        max_size=3,
    ),
    err=st.tuples(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5), st.floats(-math.pi, math.pi)),
    mode=st.sampled_from(["simultaneous", "sequential"]),
)
def test_never_nan_near_serial_singularity(cos_a, err, mode):
    ctrl = AnalyticController(DESIGN, mode)
    action, _ = ctrl.predict(_obs_with_legs(cos_a, err=err))
    assert np.isfinite(action).all()
    assert np.all(np.abs(action) <= 1.0)


def test_stops_before_a_serial_singularity():
    """A motion that turns a leg towards the perpendicular is braked to a stop close to it;
    the opposite motion, away from the singularity, is not."""
    ctrl = AnalyticController(DESIGN, "simultaneous")
    for c in (0.0, 1e-9, 0.02, 0.049):
        # Leg 3 leans right (cos > 0, sin > 0): rising needs rho_dot_3 = y_dot tan(alpha_3),
        # which turns it towards the vertical.
        towards, _ = ctrl.predict(_obs_with_legs([0.8, 0.7, c], err=(0.0, 0.05, 0.0)))
        away, _ = ctrl.predict(_obs_with_legs([0.8, 0.7, max(c, 1e-6)], err=(0.0, -0.05, 0.0)))
        assert np.all(towards == 0.0)
        assert np.abs(away).max() > 0.1
    # Far from the singularity nothing is braked.
    free, _ = ctrl.predict(_obs_with_legs([0.8, 0.7, 0.5], err=(0.0, 0.05, 0.0)))
    assert np.abs(free).max() == pytest.approx(1.0)


def test_at_a_real_serial_singularity(env):
    """Leg 3 exactly perpendicular to its rail: finite commands, within bounds."""
    theta = -0.6
    k3, L3 = DESIGN.joint_offsets[2], DESIGN.leg_lengths[2]
    y = L3 - k3 * math.sin(theta)  # C_3y = L_3
    pose = np.array([0.15, y, theta])
    rho, _ = kinematics.inverse(DESIGN, pose, MODE)
    assert float(kinematics.serial_margin(DESIGN, pose, rho)) < 1e-6
    u = kinematics.leg_vectors(DESIGN, pose, rho)
    alpha = np.arctan2(u[:, 1], u[:, 0])
    obs = _obs_with_legs(np.cos(alpha))
    obs[SLICES["legs"]] = np.stack([np.cos(alpha), np.sin(alpha)], 1).ravel()
    for mode in ("simultaneous", "sequential"):
        action, _ = AnalyticController(DESIGN, mode).predict(obs)
        assert np.isfinite(action).all() and np.abs(action).max() <= 1.0


def test_non_finite_observation_gives_finite_action():
    obs = _obs_for(EASY_START, EASY_TARGET)
    obs[SLICES["legs"].start] = np.nan
    obs[SLICES["position_error"].start] = np.inf
    for mode in ("simultaneous", "sequential"):
        action, _ = AnalyticController(DESIGN, mode).predict(obs)
        assert np.isfinite(action).all()


def test_bad_arguments():
    with pytest.raises(ValueError, match="mode"):
        AnalyticController(DESIGN, "diagonal")
    with pytest.raises(ValueError, match="position_gain"):
        AnalyticController(DESIGN, position_gain=-1.0)
    with pytest.raises(ValueError, match="shape"):
        AnalyticController(DESIGN).predict(np.zeros(5))
    with pytest.raises(ValueError, match="state"):
        AnalyticController(DESIGN, "sequential").predict(np.zeros((2, OBS_SIZE)), state=np.zeros(3))


def test_floor_policies():
    obs = np.zeros((4, OBS_SIZE), dtype=np.float32)
    a, _ = ZeroPolicy().predict(obs)
    assert a.shape == (4, 3) and not a.any()
    r1, r2 = RandomPolicy(seed=3), RandomPolicy(seed=3)
    x, _ = r1.predict(obs[0])
    y, _ = r2.predict(obs[0])
    assert x.shape == (3,) and np.array_equal(x, y) and np.all(np.abs(x) <= 1)
    r1.reset(seed=3)
    assert np.array_equal(r1.predict(obs[0])[0], x)
