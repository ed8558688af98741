"""Residual tracking policy (agents/controllers/residual.py), its training path and the mixed
reference."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import torch as th
from residual_helpers import (
    TINY_RUN_ARGS,
    assert_correction_bounded,
    assert_round_trip,
    observation_with_errors,
    residual_model,
)
from script_loader import command, load_script
from stable_baselines3 import PPO

import planar3p_gym
from planar3p_agents.controllers.residual import ERROR_SCALE, ResidualTrackPolicy, TrackFeatures
from planar3p_agents.controllers.tracking import TrackingController
from planar3p_agents.training import config as training
from planar3p_gym.tasks.observation import SLICES

ID = planar3p_gym.TRACK_ENV_ID
train_script = command("train")


def _model(scale: float = 0.1, **policy_kwargs) -> PPO:
    return residual_model(ResidualTrackPolicy, ID, scale, -4.0, **policy_kwargs)


def _observations(n_steps: int = 60) -> np.ndarray:
    """Observations met by the feed-forward controller on a segments and a figure-eight
    episode (seeded)."""
    out = []
    for kind, seed in (("segments", 3), ("figure_eight", 4)):
        env = gym.make(ID, reference=kind)
        ctrl = TrackingController.from_env(env)
        obs, _ = env.reset(seed=seed)
        for _ in range(n_steps):
            out.append(obs)
            obs, *_ = env.step(ctrl(obs))
        env.close()
    return np.asarray(out)


def test_untrained_policy_is_the_feedforward_controller():
    """The correction's output layer starts at zero, so the deterministic action is the
    controller's, bit for bit (float32), on observations of both reference kinds."""
    obs = _observations()
    model = _model()
    actions = model.predict(obs, deterministic=True)[0]
    expected = TrackingController().predict(obs)[0]
    np.testing.assert_array_equal(actions, expected)
    assert np.abs(expected).max() > 0.05  # the reference moves: the comparison is not 0 == 0


def test_correction_is_bounded_by_the_residual_scale():
    assert_correction_bounded(_model(0.07), TrackingController(), _observations(30), 0.07)


def test_round_trip_through_a_model_file(tmp_path: Path):
    model = _model(0.05, net_arch={"pi": [16], "vf": [16]})
    loaded = assert_round_trip(model, ResidualTrackPolicy, _observations(20), tmp_path / "m.zip")
    assert loaded.policy.design_dict == planar3p_gym.Design.fig8().to_dict()


def test_features_scale_a_millimetre_to_one():
    design = planar3p_gym.Design.fig8()
    env = gym.make(ID)
    feats = TrackFeatures(env.observation_space)
    x, _ = observation_with_errors(env, ERROR_SCALE, -2 * ERROR_SCALE, ERROR_SCALE)
    x[SLICES["rho"]] = design.stroke / 2
    x[31:34] = (design.max_speed, 0.0, design.max_speed / design.characteristic_length)
    f = feats(th.as_tensor(x[None], dtype=th.float32))[0].numpy()
    assert f.shape == (37,)
    np.testing.assert_allclose(f[SLICES["position_error"]], [1.0, -2.0], rtol=1e-5)
    np.testing.assert_allclose(f[SLICES["orientation_error"]], [1.0], rtol=1e-5)
    np.testing.assert_allclose(f[SLICES["rho"]], 0.0, atol=1e-6)
    np.testing.assert_allclose(f[31:34], [1.0, 0.0, 1.0], rtol=1e-5)
    np.testing.assert_allclose(f[34:], TrackingController().predict(x.astype(np.float32))[0])
    # a large error is clipped
    x[SLICES["position_error"]] = (1.0, 0.0)
    assert feats(th.as_tensor(x[None], dtype=th.float32))[0, 23].item() == 10.0


def test_bad_arguments_raise():
    for scale in (0.0, 1.5, float("nan")):
        with pytest.raises(ValueError, match="residual_scale"):
            _model(scale)
    with pytest.raises(ValueError, match="features_extractor_class"):
        _model(features_extractor_class=TrackFeatures)
    with pytest.raises(ValueError, match="observation of shape"):
        TrackFeatures(gym.spaces.Box(-1, 1, (31,)))
    with pytest.raises(ValueError, match="Box"):
        ResidualTrackPolicy(
            gym.spaces.Box(-1, 1, (34,)), gym.spaces.Box(-1, 1, (2,)), lambda _: 1e-3
        )


def test_policy_names_resolve():
    assert training.policy_class("MlpPolicy") == "MlpPolicy"
    assert training.policy_class("ResidualTrackPolicy") is ResidualTrackPolicy


def test_train_script_trains_the_shipped_entry(tmp_path: Path):
    """scripts/train.py with the Planar3PTrack-v0 entry of ppo.yml (native vector env, mixed
    references): a complete run whose model is a residual policy."""
    run = tmp_path / "track"
    argv = [
        "--algo", "ppo", "--env", ID, "--vec-env", "native",
        "--env-kwargs", 'reference="mixed"', "--run-dir", str(run), *TINY_RUN_ARGS,
    ]  # fmt: skip
    assert train_script.main(argv) == 0
    config = json.loads((run / "config.json").read_text())["config"]
    assert config["policy"] == "ResidualTrackPolicy"
    assert config["env_kwargs"] == {"reference": "mixed"}
    model = PPO.load(run / "model.zip", device="cpu")
    assert isinstance(model.policy, ResidualTrackPolicy)
    # Its statistics normalise rewards only; loaded by name they leave observations alone.
    from planar3p_agents.policies.factory import load_policy

    env = gym.make(ID)
    obs = _observations(5)
    with_stats = load_policy(f"{run / 'model.zip'}:stats={run / 'vecnormalize.pkl'}", env=env)
    assert not with_stats.vecnormalize.norm_obs
    np.testing.assert_array_equal(
        with_stats.predict(obs)[0], model.predict(obs, deterministic=True)[0]
    )
    # Its learning curve in tracking error: step 0 is the controller; kept and reused.
    from tooling.track_curves import CACHE, SuitePlayer, run_curve

    player = SuitePlayer("track-segments", 1, 0)
    curve = run_curve(run, [player])["track-segments"]
    assert sorted(curve) == [0, 128]
    assert curve[0] == player.play(TrackingController())[0]
    assert (run / CACHE).is_file()
    player.play = None  # a second call must not play again
    assert run_curve(run, [player]) == {"track-segments": curve}
    player.close()


def test_benchmark_plays_an_untrained_residual_model_like_the_controller(tmp_path: Path):
    """Loaded through a policy specification and played by the benchmark's episode runner
    on a tracking suite, the untrained residual model gives the feed-forward controller's
    tracking errors exactly."""
    from planar3p_agents.evaluation.episodes import evaluate
    from planar3p_agents.evaluation.task_suites import make_task_env, make_task_suite
    from planar3p_agents.policies.factory import load_policy

    _model().save(tmp_path / "residual.zip")
    for suite_name in ("track-segments", "track-figure-eight"):
        env = make_task_env(suite_name)
        suite = make_task_suite(suite_name, 1, 0, env=env)
        learned = load_policy(f"{tmp_path / 'residual.zip'}:stats=none", env=env)
        ff = TrackingController.from_env(env)
        a = evaluate(env, learned, suite)[0].task_metrics
        b = evaluate(env, ff, suite)[0].task_metrics
        assert a["tracking_rms_error"] == b["tracking_rms_error"] > 0
        env.close()


# ---------------------------------------------------------------------- mixed references
def test_mixed_reference_draws_both_kinds_and_replays_in_either_env():
    env = gym.make(ID, reference="mixed")
    specs = [env.reset(seed=s)[1]["episode_spec"] for s in range(30)]
    kinds = {s["reference"]["kind"] for s in specs}
    assert kinds == {"segments", "figure_eight"}
    # an episode of the mixed env replays exactly in the env of its own kind
    spec = next(s for s in specs if s["reference"]["kind"] == "figure_eight")
    other = gym.make(ID, reference="figure_eight")
    ctrl = TrackingController.from_env(env)
    runs = []
    for e in (env, other):
        obs, _ = e.reset(options=spec)
        traj = [obs]
        for _ in range(40):
            obs, *_ = e.step(ctrl(obs))
            traj.append(obs)
        runs.append(np.asarray(traj))
    np.testing.assert_array_equal(runs[0], runs[1])
    assert env.unwrapped.config()["task_arguments"]["reference"] == "mixed"


def test_unknown_reference_kind_is_refused():
    with pytest.raises(ValueError, match="mixed"):
        gym.make(ID, reference="circle")


# ---------------------------------------------------------------------- retuned gains
def test_gain_sweep_plays_the_benchmark_episodes():
    """At the default gain the sweep gives the benchmark's analytic-feedforward on the same
    suite episodes; a higher gain shrinks the lag (median RMS error)."""
    from planar3p_agents.evaluation.episodes import evaluate
    from planar3p_agents.evaluation.task_suites import make_task_env, make_task_suite
    from tooling.track_gains import gain_sweep

    rows = gain_sweep([6.0, 25.0], 2, 0, ["track-figure-eight"])
    env = make_task_env("track-figure-eight")
    suite = make_task_suite("track-figure-eight", 2, 0, env=env)
    res = evaluate(env, TrackingController.from_env(env), suite)
    rms = [r.task_metrics["tracking_rms_error"] for r in res]
    assert rows[0]["rms_median"] == float(np.median(rms))
    assert rows[0]["failures"] == rows[1]["failures"] == 0
    assert rows[1]["rms_median"] < 0.5 * rows[0]["rms_median"]


def test_gain_sweep_script_rejects_bad_input(capsys):
    script = load_script("track_gains")
    for argv in (["--gains", "6,x"], ["--gains", "-1"], ["--episodes", "0"], ["--suites", "goal"]):
        assert script.main([*argv, "--episodes", "1"] if "--episodes" not in argv else argv) == 2
        assert ": error: " in capsys.readouterr().err


# ---------------------------------------------------------------------- learning curves
def test_suite_player_plays_the_benchmark_episodes_side_by_side():
    """Batched play gives the benchmark runner's tracking errors exactly."""
    from planar3p_agents.evaluation.episodes import evaluate
    from tooling.track_curves import SuitePlayer

    player = SuitePlayer("track-segments", 2, 0)
    batched = player.play(TrackingController())
    env = player.envs[0]
    res = evaluate(env, TrackingController.from_env(env), player.suite)
    assert batched.tolist() == [r.task_metrics["tracking_rms_error"] for r in res]
    player.close()


def test_checkpoints_and_seed_curves(tmp_path: Path):
    from tooling.track_curves import checkpoints, seed_curves

    run = tmp_path / "run"
    (run / "checkpoints").mkdir(parents=True)
    config = {"config": {"seed": 1, "normalize": {"norm_obs": False, "norm_reward": True}}}
    (run / "config.json").write_text(json.dumps(config))
    with pytest.raises(ValueError, match="no checkpoints"):
        checkpoints(run)
    for n in (200, 100):
        (run / "checkpoints" / f"rl_model_{n}_steps.zip").write_bytes(b"")
    (run / "model.zip").write_bytes(b"")
    (run / "metrics.json").write_text(json.dumps({"timesteps": 256}))
    assert [s for s, _ in checkpoints(run)] == [100, 200, 256]
    config["config"]["normalize"] = {}
    (run / "config.json").write_text(json.dumps(config))
    with pytest.raises(ValueError, match="normalised observations"):
        checkpoints(run)
    curves = {1: {"a": {0: 1.0, 5: 0.5}}, 2: {"a": {0: 1.0, 5: 0.3, 9: 0.1}}}
    rows = seed_curves(curves, n_resamples=50)["a"]
    assert [r[0] for r in rows] == [0, 5]  # only the steps every seed has
    assert rows[0][1:] == (1.0, 1.0, 1.0)
    assert rows[1][1] == pytest.approx(0.4) and 0.3 <= rows[1][2] <= rows[1][3] <= 0.5
