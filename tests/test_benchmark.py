"""Evaluation suites, episode runner, statistics, policy loading and the benchmark script."""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import planar3p_gym
from agents import evaluation as ev
from agents.analytic import AnalyticController
from agents.baselines import RandomPolicy, ZeroPolicy
from agents.policies import (
    PolicyError,
    SB3Policy,
    list_pretrained,
    load_policy,
    parse_policy_spec,
    policy_label,
)
from planar3p_gym import Design, kinematics
from planar3p_gym.statics import holding_forces

ROOT = Path(__file__).resolve().parents[1]
DESIGN = Design.fig8()


def _load_script():
    spec = importlib.util.spec_from_file_location("benchmark_script", ROOT / "scripts/benchmark.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def bench():
    return _load_script()


@pytest.fixture(scope="module")
def env():
    e = gym.make(planar3p_gym.ENV_ID)
    yield e
    e.close()


@pytest.fixture(scope="module")
def suites():
    return {name: ev.make_suite(name, 4, seed=7) for name in ev.SUITE_NAMES}


# =============================================================================== suites
def test_suites_identical_for_the_same_seed(suites):
    again = {name: ev.make_suite(name, 4, seed=7) for name in ev.SUITE_NAMES}
    for name in ev.SUITE_NAMES:
        assert again[name].to_dict() == suites[name].to_dict()
    other = ev.make_suite("standard", 4, seed=8)
    assert other.to_dict()["episodes"] != suites["standard"].to_dict()["episodes"]


def test_shorter_suite_is_a_prefix(suites):
    for name in ("standard", "far"):
        short = ev.make_suite(name, 2, seed=7)
        assert [e.to_dict() for e in short.episodes] == [
            e.to_dict() for e in suites[name].episodes[:2]
        ]


def test_suites_do_not_touch_global_random_state():
    before = np.random.get_state()[1].copy()  # noqa: NPY002
    ev.make_suite("standard", 2, seed=0)
    assert np.array_equal(np.random.get_state()[1], before)  # noqa: NPY002


def test_suite_episodes_are_valid_reset_options(env, suites):
    for suite in suites.values():
        assert len(suite) == 4
        for spec in suite.episodes:
            _, info = env.reset(options=spec.reset_options())
            assert info["working_mode"] == spec.working_mode
            assert np.allclose(info["pose"][:2], spec.start[:2], atol=1e-6)
            s, t = np.array(spec.start), np.array(spec.target)
            dets = [
                int(
                    kinematics.assembly_mode(
                        DESIGN, p, kinematics.inverse(DESIGN, p, spec.working_mode).rho
                    )
                )
                for p in (s, t)
            ]
            assert dets[0] == dets[1] != 0


def test_suite_kinds(suites):
    for spec in suites["standard"].episodes:
        assert spec.path["clear"]
    hard = suites["hard"]
    for spec in hard.episodes:
        p = spec.path
        assert p["reachable"] and p["min_serial_margin"] >= 0.1
        assert p["crosses"] or p["min_parallel_margin"] <= hard.params["hard_margin"]
        for pose in (spec.start, spec.target):
            f = holding_forces(DESIGN, np.array(pose), spec.working_mode)
            assert np.abs(f).max() <= 0.25 * DESIGN.max_force
    far = suites["far"]
    for spec in far.episodes:
        assert spec.path["distance"] >= far.params["far_distance"]
    assert far.params["far_distance"] > np.median(
        [e.path["distance"] for e in suites["standard"].episodes]
    )


def test_suite_file_roundtrip(tmp_path, suites):
    path = tmp_path / "suites.json"
    ev.save_suites(path, suites, DESIGN)
    loaded, design = ev.load_suites(path)
    assert design == DESIGN
    assert {k: v.to_dict() for k, v in loaded.items()} == {
        k: json.loads(json.dumps(v.to_dict())) for k, v in suites.items()
    }
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(ValueError, match="cannot read"):
        ev.load_suites(tmp_path / "bad.json")
    with pytest.raises(ValueError, match="not found"):
        ev.load_suites(tmp_path / "missing.json")


def test_suite_hold_force_fraction_replaces_the_task_limit():
    """A suite's ``hold_force_fraction`` decides how hard its ends may be to hold, above the
    environment's own sampling limit (0.75 of max_force) too: the crossing stress suite."""
    mode = (1, 1, 1)
    loose = ev.make_suite(
        "hard", 20, 0, working_mode=mode, end_parallel_margin=0.02, hold_force_fraction=1.0
    )
    ends = np.array([p for e in loose.episodes for p in (e.start, e.target)])
    forces = np.abs(holding_forces(DESIGN, ends, mode)).max(axis=-1)
    assert (forces <= DESIGN.max_force).all()
    assert (forces > 0.75 * DESIGN.max_force).any()
    strict = ev.make_suite(
        "hard", 5, 0, working_mode=mode, end_parallel_margin=0.02, hold_force_fraction=0.5
    )
    ends = np.array([p for e in strict.episodes for p in (e.start, e.target)])
    assert (np.abs(holding_forces(DESIGN, ends, mode)).max(axis=-1) <= 0.5 * DESIGN.max_force).all()


def test_unknown_suite():
    with pytest.raises(ValueError, match="unknown suite"):
        ev.make_suite("easy", 3, 0)
    with pytest.raises(ValueError, match="unknown suite"):
        ev.make_suites(["standard", "easy"], 3, 0)


def test_holding_forces_match_the_simulation(env, suites):
    spec = suites["standard"].episodes[0]
    env.reset(options=spec.reset_options())
    for _ in range(5):
        _, _, _, _, info = env.step(np.zeros(3))
    f = np.abs(holding_forces(DESIGN, np.array(info["pose"]), spec.working_mode))
    np.testing.assert_allclose(f, info["actuator_forces"], rtol=0.05, atol=0.05)


# =============================================================================== runner
def test_run_episode_zero_and_analytic(env, suites):
    spec = suites["standard"].episodes[0]
    zero = ev.run_episode(env, ZeroPolicy(), spec, policy_name="zero", record=True)
    assert not zero.success and zero.termination_reason == "timeout"
    assert zero.steps == planar3p_gym.MAX_EPISODE_STEPS
    assert zero.energy == pytest.approx(0.0, abs=1e-3)
    assert zero.trajectory.shape == (zero.steps + 1, 3)
    ana = ev.run_episode(env, AnalyticController.from_env(env), spec, policy_name="a")
    assert ana.success and ana.cause == "success"
    assert ana.time_to_success == pytest.approx(ana.steps * env.unwrapped.dt)
    assert ana.energy > 0 and ana.final_position_error <= 0.002
    assert ana.trajectory is None


def test_random_policy_is_reproducible(env, suites):
    spec = suites["far"].episodes[1]
    runs = [
        ev.run_episode(env, RandomPolicy(seed=1), spec, policy_name="random", seed=5).row()
        for _ in range(2)
    ]
    assert runs[0] == runs[1]
    other = ev.run_episode(env, RandomPolicy(), spec, policy_name="random", seed=6).row()
    assert other["episode_return"] != runs[0]["episode_return"]


# =============================================================================== statistics
def test_iqm_hand_checked():
    assert ev.iqm([1, 2, 3, 4, 5, 6, 7, 8]) == pytest.approx(4.5)  # mean of 3, 4, 5, 6
    assert ev.iqm([4, 1, 3, 2]) == pytest.approx(2.5)  # mean of 2, 3
    assert ev.iqm([0, 0, 0, 0, 100]) == pytest.approx(0.0)  # 100 trimmed
    assert ev.iqm([7.0]) == pytest.approx(7.0)
    assert math.isnan(ev.iqm([]))
    np.testing.assert_allclose(ev.iqm(np.array([[1, 2, 3, 4], [10, 20, 30, 40]])), [2.5, 25])


def test_bootstrap_hand_checked():
    assert ev.bootstrap_ci([3.0] * 10) == (3.0, 3.0)
    x = np.array([0.0, 1.0] * 50)  # mean 0.5, standard error 0.05
    lo, hi = ev.bootstrap_ci(x, n_resamples=4000, seed=1)
    assert 0.38 <= lo <= 0.42 and 0.58 <= hi <= 0.62
    assert ev.bootstrap_ci(x, seed=1) == ev.bootstrap_ci(x, seed=1)
    lo, hi = ev.bootstrap_ci(np.arange(100.0), ev.iqm, seed=0)
    assert lo < 49.5 < hi
    assert all(math.isnan(v) for v in ev.bootstrap_ci([]))


def _result(success, ret, cause="success", steps=50, **kw):
    base = dict(
        policy="p",
        suite="standard",
        index=0,
        success=success,
        termination_reason=cause if cause in ("success", "singularity_crossing") else "timeout",
        cause=cause,
        steps=steps,
        duration=steps * 0.02,
        time_to_success=steps * 0.02 if success else math.nan,
        episode_return=ret,
        final_position_error=0.001,
        final_orientation_error=0.01,
        min_parallel_margin=0.05,
        min_serial_margin=0.3,
        saturation_fraction=0.0,
        energy=1.0,
        end_stop_fraction=0.0,
        max_closure_error=0.0,
        working_mode_changed=False,
        path_crosses=False,
        path_clear=True,
        sequential_path_clear=True,
    )
    base.update(kw)
    return ev.EpisodeResult(**base)


def test_summarize_hand_checked():
    res = [
        _result(True, 10.0, steps=50, final_position_error=0.001, saturation_fraction=0.5),
        _result(True, 20.0, steps=100, final_position_error=0.003),
        _result(False, -5.0, cause="singularity_crossing", steps=10, min_parallel_margin=0.001),
        _result(False, -1.0, cause="not_converged", steps=250, final_position_error=0.01),
    ]
    s = ev.summarize(res, n_resamples=500)
    assert s["episodes"] == 4 and s["successes"] == 2 and s["success_rate"] == 0.5
    assert s["return_iqm"] == pytest.approx(4.5)  # mean of -1 and 10
    assert s["median_position_error_mm"] == pytest.approx(2.0)
    assert s["median_time_to_success"] == pytest.approx(1.5)  # 1.0 s and 2.0 s
    assert s["worst_min_parallel_margin"] == pytest.approx(0.001)
    assert s["singularity_crossings"] == 1 and s["timeouts"] == 1
    assert s["saturation_fraction"] == pytest.approx(25 / 410)
    assert s["causes"]["not_converged"] == 1
    assert 0.0 <= s["success_ci"][0] <= 0.5 <= s["success_ci"][1] <= 1.0


# =============================================================================== policies
def test_policy_specs(tmp_path):
    assert parse_policy_spec("analytic-sequential").kind == "builtin"
    with pytest.raises(PolicyError, match="unknown policy"):
        parse_policy_spec("analytic-magic")
    with pytest.raises(PolicyError, match="not found"):
        parse_policy_spec(str(tmp_path / "nope.zip"))
    with pytest.raises(PolicyError, match="unknown pretrained model"):
        parse_policy_spec("pretrained:does_not_exist")
    assert policy_label("sac:runs/x/model.zip") == "x/model"
    assert policy_label("runs/ppo_fast.zip") == "ppo_fast"
    assert isinstance(list_pretrained(), list)
    assert isinstance(load_policy("zero"), ZeroPolicy)


def test_vecnormalize_lookup_follows_the_training_layout(tmp_path):
    from agents.policies import vecnormalize_candidates

    names = [p.name for p in vecnormalize_candidates(tmp_path / "best_model.zip")]
    assert names.index("best_vecnormalize.pkl") < names.index("vecnormalize.pkl")
    ckpt = [p.name for p in vecnormalize_candidates(tmp_path / "rl_model_5000_steps.zip")]
    assert "rl_model_vecnormalize_5000_steps.pkl" in ckpt
    assert vecnormalize_candidates(tmp_path / "sac.zip")[0].name == "sac_vecnormalize.pkl"


def test_corrupt_model_file(tmp_path):
    bad = tmp_path / "broken.zip"
    bad.write_bytes(b"this is not a zip archive")
    with pytest.raises(PolicyError, match="corrupt"):
        load_policy(str(bad))


def test_loads_sb3_model_with_vecnormalize(tmp_path, env, bench, capsys):
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    venv = VecNormalize(DummyVecEnv([lambda: gym.make(planar3p_gym.ENV_ID)]))
    venv.obs_rms.mean[:] = 0.1  # recognisable statistics
    model = PPO("MlpPolicy", venv, n_steps=32, batch_size=32, device="cpu", seed=0)
    model.save(tmp_path / "ppo_tiny.zip")
    venv.save(tmp_path / "vecnormalize.pkl")
    (tmp_path / "config.json").write_text(json.dumps({"config": {"env_kwargs": {"a": 1}}}))
    policy = load_policy(str(tmp_path / "ppo_tiny.zip"), env=env)
    assert isinstance(policy, SB3Policy) and policy.vecnormalize is not None
    assert policy.env_kwargs == {"a": 1}
    assert np.allclose(policy.vecnormalize.obs_rms.mean, 0.1)
    obs, _ = env.reset(seed=0)
    action, _ = policy.predict(obs)
    assert action.shape == (3,) and np.isfinite(action).all()
    expected, _ = model.predict(venv.normalize_obs(obs), deterministic=True)
    np.testing.assert_allclose(action, expected)
    # ... and the benchmark runs it given by path.
    out = tmp_path / "bench"
    args = ["--policies", f"ppo:{tmp_path / 'ppo_tiny.zip'}", "--suites", "standard"]
    assert bench.main([*_quick_args(out, *args), "--no-plots", "--episodes", "1"]) == 0
    assert "| ppo_tiny | standard | 1 |" in capsys.readouterr().out


# =============================================================================== script
def _quick_args(out, *extra):
    return ["--episodes", "2", "--seed", "3", "--out", str(out), "--no-progress", *extra]


def test_script_end_to_end(tmp_path, bench, capsys):
    out = tmp_path / "run"
    code = bench.main(
        _quick_args(out, "--suites", "standard,far", "--policies", "analytic-simultaneous,zero")
    )
    assert code == 0
    printed = capsys.readouterr().out
    assert "| analytic-simultaneous | standard | 2 |" in printed
    for name in ("report.md", "episodes.csv", "summary.json", "suites.json"):
        assert (out / name).is_file()
    for name in ("success_rate.png", "errors.png", "trajectories.png"):
        assert (out / name).stat().st_size > 1000
    rows = (out / "episodes.csv").read_text().strip().splitlines()
    assert len(rows) == 1 + 2 * 2 * 2
    summary = json.loads((out / "summary.json").read_text())
    assert len(summary["summaries"]) == 4
    # Replaying the saved suites gives the same episodes and results.
    out2 = tmp_path / "replay"
    code = bench.main(
        [
            "--suite-file",
            str(out / "suites.json"),
            "--suites",
            "standard",
            "--policies",
            "analytic-simultaneous",
            "--out",
            str(out2),
            "--no-progress",
            "--no-plots",
        ]
    )
    assert code == 0
    first = [r for r in rows[1:] if r.startswith("analytic-simultaneous,standard")]
    second = (out2 / "episodes.csv").read_text().strip().splitlines()[1:]
    assert first == second


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--policies", "zero,{missing}"], "model file not found"),
        (["--policies", "zero,{corrupt}"], "corrupt model file"),
        (["--policies", "analytic-magic"], "unknown policy"),
        (["--suites", "standard,easy"], "unknown suite"),
        (["--policies", "pretrained:nothing_here"], "unknown pretrained model"),
        (["--working-mode", "1,2,1"], "--working-mode"),
    ],
)
def test_script_bad_input(tmp_path, bench, capsys, extra, message):
    out = tmp_path / "out"
    out.mkdir()
    keep = out / "report.md"
    keep.write_text("results of an earlier run")
    corrupt = tmp_path / "corrupt.zip"
    corrupt.write_bytes(b"\x00garbage")
    extra = [e.format(missing=tmp_path / "missing.zip", corrupt=corrupt) for e in extra]
    code = bench.main(_quick_args(out, *extra))
    assert code == 2
    err = capsys.readouterr().err
    assert message in err and "error:" in err
    assert keep.read_text() == "results of an earlier run"
    assert sorted(p.name for p in out.iterdir()) == ["report.md"]


def test_script_keeps_results_when_a_policy_fails(tmp_path, bench, capsys, monkeypatch):
    class Broken:
        def predict(self, obs, state=None, episode_start=None, deterministic=True):
            return np.zeros(5), None  # wrong shape: the environment refuses it

    real = bench.load_policy

    def fake(spec, **kw):
        return Broken() if spec.name == "random" else real(spec, **kw)

    monkeypatch.setattr(bench, "load_policy", fake)
    out = tmp_path / "partial"
    code = bench.main(
        _quick_args(out, "--suites", "standard", "--policies", "zero,random", "--no-plots")
    )
    assert code == 1
    assert "evaluation failed" in capsys.readouterr().err
    rows = (out / "episodes.csv").read_text().strip().splitlines()
    assert len(rows) == 1 + 2 and all(r.startswith("zero,") for r in rows[1:])
    assert "Incomplete run" in (out / "report.md").read_text()
