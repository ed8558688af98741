"""Tests of ``Planar3PTrack-v0``: API conformance, feasibility and smoothness of the reference,
metrics, replay from episode specs, input validation, and the feed-forward baseline."""

from __future__ import annotations

import json
import math

import gymnasium as gym
import numpy as np
import pytest

import planar3p_gym
from planar3p_agents.controllers.tracking import TrackingController
from planar3p_gym.machine import kinematics
from planar3p_gym.tasks.kernel import StepKernel
from planar3p_gym.tasks.observation import OBS_SIZE, SLICES
from planar3p_gym.tasks.track import SAMPLE_CHUNK, TRACKING_METRICS, TrackKernel
from planar3p_gym.tasks.track_references import parse_reference, reference_at, reference_samples
from tooling.goal_track_baselines import run_tracking_episodes, summarize_tracking

KINDS = ("segments", "figure_eight")
ID = planar3p_gym.TRACK_ENV_ID


def make(kind: str, **kwargs) -> gym.Env:
    return gym.make(ID, reference=kind, **kwargs)


@pytest.mark.parametrize("kind", KINDS)
def test_observation_is_the_reach_observation_plus_the_reference_velocity(kind):
    # (Gymnasium's and SB3's env checkers run on every task id in tests/tasks/test_tasks.py.)
    assert make(kind).observation_space.shape == (OBS_SIZE + 3,)


@pytest.mark.parametrize("kind", KINDS)
def test_reference_is_feasible_smooth_and_within_the_speed_budget(kind):
    """Sampled references pass the task's own validation; the observed reference velocity is
    the time derivative of the observed reference pose (central differences, error O(dt^2));
    the slider rates the exact kinematics needs along it stay within ``speed_fraction`` of the
    speed limit (5 % slack for the sampled rate bound)."""
    env = make(kind, working_mode="random")
    u = env.unwrapped
    t = u.task
    env.reset(seed=0)
    for _ in range(6):
        _, info = env.reset()
        spec = info["episode_spec"]
        mode = tuple(spec["working_mode"])
        assert t._reference_problem(parse_reference(spec["reference"]), mode) is None
        steps = np.arange(0, 600)
        ref = [t._reference_at(spec["reference"], k) for k in steps]
        poses = np.array([p for p, _ in ref])
        vels = np.array([v for _, v in ref])
        np.testing.assert_allclose(poses[0], spec["start"], atol=1e-12)
        diff = poses[2:] - poses[:-2]
        diff[:, 2] = (diff[:, 2] + math.pi) % (2 * math.pi) - math.pi  # waypoints are wrapped
        fd = diff / (2 * u.dt)
        scale = np.abs(vels).max(axis=0) + 1e-9
        assert (np.abs(fd - vels[1:-1]) / scale).max() < 0.02
        rho = kinematics.inverse(u.design, poses, mode).rho
        rates = kinematics.simple_motion_rates(u.design, poses, rho, vels)
        assert np.abs(rates).max() <= 1.05 * t.speed_fraction * u.design.max_speed


@pytest.mark.parametrize("kind", KINDS)
def test_observation_carries_reference_pose_and_velocity(kind):
    env = make(kind)
    u = env.unwrapped
    obs, info = env.reset(seed=1)
    spec = info["episode_spec"]
    for k in range(1, 40):
        obs, *_ = env.step(np.zeros(3, np.float32))
        pose, vel = u.task._reference_at(spec["reference"], k)
        np.testing.assert_allclose(obs[SLICES["target_position"]], pose[:2], atol=1e-6)
        np.testing.assert_allclose(
            obs[SLICES["target_orientation"]], [math.cos(pose[2]), math.sin(pose[2])], atol=1e-6
        )
        np.testing.assert_allclose(obs[OBS_SIZE:], vel, rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("kind", KINDS)
def test_reference_samples_are_each_steps_reference_whatever_the_chunks(kind):
    """The episode's reference samples (what every step reads, single and vector env) are
    the reference at each step time bit for bit, however they are split into chunks (each
    time's numbers are the same operations), past the end of the segments too (at rest
    there), and :meth:`TrackTask.sample` extends them beyond the first chunk."""
    u = make(kind).unwrapped
    u.reset(seed=4)
    t = u.task
    ref = parse_reference(u.episode.spec["reference"])
    whole = reference_samples(ref, u.dt, 0, 900)
    parts = [reference_samples(ref, u.dt, a, b) for a, b in ((0, 1), (1, 333), (333, 900))]
    np.testing.assert_array_equal(np.concatenate(parts), whole)
    for k in (0, 1, 250, 499, 899):
        pose, vel = reference_at(ref, k * u.dt)
        row = [*pose, math.cos(pose[2]), math.sin(pose[2]), *vel]
        np.testing.assert_array_equal(whole[k], row)
    assert t.samples.shape == (SAMPLE_CHUNK, 8)
    np.testing.assert_array_equal(t.sample(SAMPLE_CHUNK), whole[SAMPLE_CHUNK])
    assert t.samples.shape[0] == 2 * SAMPLE_CHUNK  # (doubled)
    np.testing.assert_array_equal(t.sample(899), whole[899])
    assert t.samples.shape[0] >= 900
    np.testing.assert_array_equal(t.samples[:900], whole)
    if kind == "segments":  # (the episode's 10 s of segments end before step 900)
        np.testing.assert_array_equal(whole[899, 5:], 0.0)
        assert t.reference(899) == tuple(ref["waypoints"][-1])


@pytest.mark.parametrize("kind", KINDS)
def test_metrics_are_rms_and_max_of_the_step_errors(kind):
    env = make(kind)
    ctrl = TrackingController.from_env(env)
    obs, info = env.reset(seed=2)
    assert all(info[k] == 0.0 for k in TRACKING_METRICS)
    errs, pos, ang = [], [], []
    for _ in range(150):
        obs, _reward, terminated, _truncated, info = env.step(ctrl.predict(obs)[0])
        length = env.unwrapped.design.characteristic_length
        errs.append(info["position_error"] + length * abs(info["orientation_error"]))
        pos.append(info["position_error"])
        ang.append(abs(info["orientation_error"]))
        assert info["tracking_error"] == pytest.approx(errs[-1], rel=1e-12)
        assert info["is_success"] is False and not terminated
    for name, values in (("error", errs), ("position_error", pos), ("orientation_error", ang)):
        v = np.array(values)
        assert info[f"tracking_rms_{name}"] == pytest.approx(np.sqrt(np.mean(v * v)), rel=1e-9)
        assert info[f"tracking_max_{name}"] == pytest.approx(v.max(), rel=1e-12)


@pytest.mark.parametrize("kind", KINDS)
def test_many_resets_never_raise(kind):
    env = make(kind, working_mode="random")
    env.reset(seed=0)
    for _ in range(60):
        obs, info = env.reset()
        assert env.observation_space.contains(obs)
        assert info["episode_spec"]["reference"]["kind"] == kind


def test_start_option_begins_the_reference_there():
    env = make("segments")
    start = env.reset(seed=4)[1]["episode_spec"]["start"]
    for kind in KINDS:
        env = make(kind)
        _, info = env.reset(seed=5, options={"start": start})
        assert info["episode_spec"]["start"] == start
        np.testing.assert_allclose(info["pose"], start, atol=1e-9)


def test_bad_input_raises():
    env = make("segments")
    spec = env.reset(seed=0)[1]["episode_spec"]
    ref = spec["reference"]
    far = dict(ref, waypoints=[ref["waypoints"][0], [5.0, 5.0, 0.0], *ref["waypoints"][2:]])
    with pytest.raises(ValueError, match=r"not feasible|segment"):
        env.reset(options={"reference": far})
    with pytest.raises(ValueError, match="duration"):
        env.reset(options={"reference": dict(ref, durations=ref["durations"][:-1])})
    with pytest.raises(ValueError, match="kind"):
        env.reset(options={"reference": {"kind": "circle"}})
    with pytest.raises(ValueError, match="initial pose"):
        env.reset(options={"reference": ref, "start": ref["waypoints"][1]})
    with pytest.raises(ValueError, match="unknown reset options"):
        env.reset(options={"target": ref["waypoints"][1]})
    with pytest.raises(ValueError, match="not reachable"):
        env.reset(options={"start": [5.0, 5.0, 0.0]})
    eight = make("figure_eight").reset(seed=0)[1]["episode_spec"]["reference"]
    with pytest.raises(ValueError, match="not feasible"):
        env.reset(options={"reference": dict(eight, amplitude=[0.5, 0.5, 0.0])})
    with pytest.raises(ValueError, match="period"):
        env.reset(options={"reference": dict(eight, period=-1.0)})
    for kwargs in ({"reference": "circle"}, {"speed_fraction": 0.0}, {"duration": -1.0}):
        with pytest.raises(ValueError):
            gym.make(ID, **kwargs)


@pytest.mark.parametrize("kind", KINDS)
def test_feed_forward_beats_feedback_alone(kind):
    """The reference velocity fed forward removes the feedback controller's lag: over the same
    episodes its RMS tracking error is several times smaller (measured over 100 episodes:
    47x on segments, 28x on the figure-eight, ``scripts/goal_track_baselines.py``)."""
    rows = {}
    for ff in (0.0, 1.0):
        env = make(kind)
        ctrl = TrackingController.from_env(env, feedforward=ff)
        rows[ff] = summarize_tracking(run_tracking_episodes(env, ctrl, 3, seed=11))
    assert rows[1.0]["failures"] == rows[0.0]["failures"] == 0
    assert rows[1.0]["rms_error_mean"] < 0.25 * rows[0.0]["rms_error_mean"]


def test_tracking_controller_validates_input():
    with pytest.raises(ValueError):
        TrackingController(feedforward=math.nan)
    with pytest.raises(ValueError):
        TrackingController(mode="sequential")
    with pytest.raises(ValueError, match="shape"):
        TrackingController().predict(np.zeros(OBS_SIZE))


def test_goal_track_baselines_script(tmp_path, capsys):
    from script_loader import load_script

    module = load_script("goal_track_baselines")
    out = tmp_path / "b.json"
    assert module.main(["--episodes", "1", "--seed", "3", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["Planar3PGoal-v0/analytic"]["success_rate"] == 1.0
    assert len(data) == 6
    assert "figure_eight" in capsys.readouterr().out
    assert module.main(["--episodes", "0"]) == 2


@pytest.mark.parametrize("kind", KINDS)
def test_the_compiled_tracking_kernel_agrees_with_the_reference(kind):
    """Over 1,500 random steps: the same ends and metrics' course, the observation equal or
    one float32 rounding apart, margins, errors and rewards within a few float64 rounding
    errors of the reference kernel's (the bound of the reach kernel's test,
    ``tests/sim/test_batch_step.py``: a barrier below its reference margin turns a margin's
    difference ``dm`` into ``ref dm / m^2``, which the reward's bound adds, weighted)."""
    eps = np.finfo(np.float64).eps
    compiled, reference = make(kind), make(kind)
    assert isinstance(compiled.unwrapped.kernel, TrackKernel)
    k = reference.unwrapped.kernel
    reference.unwrapped.kernel = StepKernel(k.task, k.settings, k.machine)
    w = compiled.unwrapped.reward_weights
    compiled.reset(seed=5)
    reference.reset(seed=5)
    for a in np.random.default_rng(1).uniform(-1, 1, (1500, 3)).astype(np.float32):
        o1, r1, te1, tr1, i1 = compiled.step(a)
        o2, r2, te2, tr2, i2 = reference.step(a)
        assert (te1, tr1, i1["termination_reason"]) == (te2, tr2, i2["termination_reason"])
        np.testing.assert_allclose(o1, o2, rtol=2 * np.finfo(np.float32).eps, atol=1e-12)
        for key in ("position_error", "orientation_error", "parallel_margin", "serial_margin"):
            assert abs(i1[key] - i2[key]) <= 64 * eps, key
        for key in TRACKING_METRICS:
            assert abs(i1[key] - i2[key]) <= 64 * eps * max(1.0, abs(i2[key])), key
        assert i1["pose"] == i2["pose"] and i1["rho"] == i2["rho"]  # the same physics
        slope = sum(
            ref / m**2
            for m, ref in (
                (i2["parallel_margin"], w.parallel_margin_ref),
                (i2["serial_margin"], w.serial_margin_ref),
            )
            if m < ref
        )
        assert abs(r1 - r2) <= 64 * eps * (max(1.0, abs(r2)) + 2.0 * w.singularity * slope)
        if te1 or tr1:
            compiled.reset()
            reference.reset()
