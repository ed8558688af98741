"""Episode runner (agents/evaluation/episodes.py), policy loading and the benchmark
(agents/evaluation/benchmark.py, planar3p benchmark)."""

from __future__ import annotations

import json
import pickle
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from bench_helpers import read_csv, replay

import planar3p_gym
from planar3p_agents.controllers.analytic import AnalyticController
from planar3p_agents.controllers.floor import RandomPolicy, ZeroPolicy
from planar3p_agents.evaluation import benchmark as bm
from planar3p_agents.evaluation import episodes as ep
from planar3p_agents.policies.factory import (
    TRUSTED_FILES_NOTE,
    PolicyError,
    SB3Policy,
    list_pretrained,
    load_policy,
    parse_policy_spec,
    policy_label,
)
from planar3p_gym import Design
from planar3p_gym.tasks.observation import SLICES

ROOT = Path(__file__).resolve().parents[1]
DESIGN = Design.fig8()


# =============================================================================== runner
def test_run_episode_zero_and_analytic(env, suites):
    spec = suites["standard"].episodes[0]
    zero = ep.run_episode(env, ZeroPolicy(), spec, policy_name="zero", record=True)
    assert not zero.success and zero.termination_reason == "timeout"
    assert zero.steps == planar3p_gym.MAX_EPISODE_STEPS
    assert zero.energy == pytest.approx(0.0, abs=1e-3)
    assert zero.trajectory.shape == (zero.steps + 1, 3)
    ana = ep.run_episode(env, AnalyticController.from_env(env), spec, policy_name="a")
    assert ana.success and ana.cause == "success"
    assert ana.time_to_success == pytest.approx(ana.steps * env.unwrapped.dt)
    assert ana.energy > 0 and ana.final_position_error <= 0.002
    assert ana.trajectory is None


def test_random_policy_is_reproducible(env, suites):
    spec = suites["far"].episodes[1]
    runs = [
        ep.run_episode(env, RandomPolicy(seed=1), spec, policy_name="random", seed=5).row()
        for _ in range(2)
    ]
    assert runs[0] == runs[1]
    other = ep.run_episode(env, RandomPolicy(), spec, policy_name="random", seed=6).row()
    assert other["episode_return"] != runs[0]["episode_return"]


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
    # checkpoints of different runs get different labels (and group by run across seeds)
    ckpt = "ppo:runs/r-s2/checkpoints/rl_model_1000000_steps.zip:stats=x.pkl"
    assert policy_label(ckpt) == "r-s2/rl_model_1000000_steps"
    assert isinstance(list_pretrained(), list)
    assert isinstance(load_policy("zero"), ZeroPolicy)


def test_analytic_controller_with_another_gain(env):
    """``analytic-...:gain=K`` is the controller with both gains K (1/s); near the target the
    command is proportional to the gain (below saturation), so gain 12 commands twice the
    default 6's rates; bad gains are refused with the rule."""
    spec = parse_policy_spec("analytic-simultaneous:gain=12")
    assert (spec.kind, spec.name, spec.gain) == ("builtin", "analytic-simultaneous", 12.0)
    assert policy_label(" analytic-simultaneous:gain=12") == "analytic-simultaneous:gain=12"
    retuned = load_policy(spec, env=env)
    assert (retuned.position_gain, retuned.orientation_gain, retuned.mode) == (
        12.0,
        12.0,
        "simultaneous",
    )
    assert load_policy("analytic-sequential:gain=3", env=env).mode == "sequential"
    obs, _ = env.reset(seed=0)
    obs = obs.copy()
    obs[SLICES["position_error"]] = (0.001, -0.0005)  # 1 mm: far below saturation
    obs[SLICES["orientation_error"]] = 0.0005
    default = load_policy("analytic-simultaneous", env=env).predict(obs)[0]
    np.testing.assert_allclose(retuned.predict(obs)[0], 2.0 * default, rtol=1e-5)
    for bad in ("0", "-1", "nan", "inf", "fast", ""):
        with pytest.raises(PolicyError, match="finite number > 0"):
            parse_policy_spec(f"analytic-simultaneous:gain={bad}")
    with pytest.raises(PolicyError, match="unknown policy"):
        parse_policy_spec("zero:gain=2")


def test_vecnormalize_lookup_follows_the_training_layout(tmp_path):
    from planar3p_agents.policies.factory import vecnormalize_candidates

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
    stats = f":stats={tmp_path / 'vecnormalize.pkl'}"
    policy = load_policy(f"{tmp_path / 'ppo_tiny.zip'}{stats}", env=env)
    assert isinstance(policy, SB3Policy) and policy.vecnormalize is not None
    assert policy.env_kwargs == {"a": 1}
    assert np.allclose(policy.vecnormalize.obs_rms.mean, 0.1)
    obs, _ = env.reset(seed=0)
    action, _ = policy.predict(obs)
    assert action.shape == (3,) and np.isfinite(action).all()
    expected, _ = model.predict(venv.normalize_obs(obs), deterministic=True)
    np.testing.assert_allclose(action, expected)
    # ... and the benchmark runs it given by path, with its statistics named; unnamed, they
    # are not loaded and the benchmark refuses the model (exit 2), saying how to name them.
    out = tmp_path / "bench"
    args = ["--policies", f"ppo:{tmp_path / 'ppo_tiny.zip'}", "--suites", "standard"]
    assert bench.main([*_quick_args(out, *args), "--no-plots", "--episodes", "1"]) == 2
    assert ":stats=" in capsys.readouterr().err and not out.exists()
    args[1] += stats
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
    rows = read_csv(out / "episodes.csv")
    assert len(rows) == 2 * 2 * 2
    assert all(r["training_seed"] == "" for r in rows)  # built-in policies: no training seed
    summary = json.loads((out / "summary.json").read_text())
    assert len(summary["summaries"]) == 4
    # Replaying the saved suites gives the same episodes and results.
    first = [r for r in rows if (r["policy"], r["suite"]) == ("analytic-simultaneous", "standard")]
    assert first == replay(bench, out, "standard", "analytic-simultaneous", tmp_path / "replay")


def test_script_plays_reach_suites_on_the_exact_machine(tmp_path, bench):
    """The reach suites are played on ``Planar3P-v0``, the projected physics, where the loop
    closes to round-off (closure error <= 1e-9 m)."""
    out = tmp_path / "run"
    args = _quick_args(out, "--suites", "standard", "--policies", "analytic-simultaneous")
    assert bench.main([*args, "--no-plots"]) == 0
    settings = json.loads((out / "summary.json").read_text())["settings"]
    assert settings["env"]["projection"] is True
    rows = read_csv(out / "episodes.csv")
    assert all(r["success"] == "True" for r in rows)
    assert max(float(r["max_closure_error"]) for r in rows) <= 1e-9


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
    code = bench.main(_quick_args(out, "--force", *extra))
    assert code == 2
    err = capsys.readouterr().err
    assert message in err and "error:" in err
    assert keep.read_text() == "results of an earlier run"
    assert sorted(p.name for p in out.iterdir()) == ["report.md"]


def test_script_keeps_results_when_a_policy_fails(tmp_path, bench, capsys, monkeypatch):
    class Broken:
        def predict(self, obs, state=None, episode_start=None, deterministic=True):
            return np.zeros(5), None  # wrong shape: the environment refuses it

    real = bm.load_policy

    def fake(spec, **kw):
        return Broken() if spec.name == "random" else real(spec, **kw)

    monkeypatch.setattr(bm, "load_policy", fake)
    out = tmp_path / "partial"
    code = bench.main(
        _quick_args(out, "--suites", "standard", "--policies", "zero,random", "--no-plots")
    )
    assert code == 1
    assert "evaluation failed" in capsys.readouterr().err
    rows = read_csv(out / "episodes.csv")
    assert len(rows) == 2 and all(r["policy"] == "zero" for r in rows)
    assert "Incomplete run" in (out / "report.md").read_text()


def test_script_refuses_to_overwrite_results(tmp_path, bench, capsys):
    """An --out holding an earlier run's files is refused (exit 2, nothing touched) unless
    --force; a directory without them, or a new one, is used as is."""
    out = tmp_path / "earlier"
    out.mkdir()
    (out / "summary.json").write_text("earlier results")
    (out / "notes.txt").write_text("mine")
    args = _quick_args(out, "--suites", "standard", "--policies", "zero", "--no-plots")
    assert bench.main([*args, "--episodes", "1"]) == 2
    err = capsys.readouterr().err
    assert "already holds benchmark results (summary.json)" in err and "--force" in err
    assert (out / "summary.json").read_text() == "earlier results"
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt", "summary.json"]
    assert bench.main([*args, "--episodes", "1", "--force"]) == 0
    assert json.loads((out / "summary.json").read_text())["summaries"][0]["policy"] == "zero"
    assert (out / "notes.txt").read_text() == "mine"
    a_file = tmp_path / "plain.txt"
    a_file.write_text("x")
    assert bench.main(_quick_args(a_file, "--policies", "zero")) == 2
    assert "not a directory" in capsys.readouterr().err
    other = tmp_path / "other"
    other.mkdir()
    (other / "unrelated.txt").write_text("y")
    bm.check_output_dir(other)  # no results there: accepted


class _Marker:
    """Unpickling this creates a file: proof that a pickle was loaded."""

    def __init__(self, path):
        self.path = str(path)

    def __reduce__(self):
        return (Path(self.path).write_text, ("unpickled",))


def _zoo_run(tmp_path):
    """An rl-zoo3 layout: <run>/<env>.zip, <run>/<env>/vecnormalize.pkl and config.yml."""
    from stable_baselines3 import PPO

    run = tmp_path / "logs" / "ppo" / "Planar3P-v0_1"
    (run / "Planar3P-v0").mkdir(parents=True)
    model = PPO("MlpPolicy", gym.make(planar3p_gym.ENV_ID), n_steps=32, batch_size=32, seed=0)
    model.save(run / "Planar3P-v0.zip")
    marker = tmp_path / "unpickled.txt"
    (run / "Planar3P-v0" / "vecnormalize.pkl").write_bytes(pickle.dumps(_Marker(marker)))
    (run / "Planar3P-v0" / "config.yml").write_text("!!python/object/apply:collections.Ordered\n")
    return run, marker


def test_script_refuses_an_rl_zoo_model_without_its_statistics(tmp_path, bench, capsys):
    """An rl-zoo3 model keeps its statistics in <run>/<env id>/vecnormalize.pkl: unnamed, the
    benchmark refuses the model (exit 2, nothing written, the pickle never loaded) and says
    how to name them; named as absent (:stats=none) it runs, labelled by its run."""
    run, marker = _zoo_run(tmp_path)
    model = run / "Planar3P-v0.zip"
    out = tmp_path / "out"
    assert bench.main(_quick_args(out, "--policies", str(model))) == 2
    err = capsys.readouterr().err
    assert f"{model}:stats={run / 'Planar3P-v0' / 'vecnormalize.pkl'}" in err
    assert not marker.exists()  # the statistics were never unpickled
    assert not out.exists()
    args = _quick_args(out, "--policies", f"{model}:stats=none", "--suites", "standard")
    assert bench.main([*args, "--no-plots", "--episodes", "1"]) == 0
    assert not marker.exists()
    assert "| Planar3P-v0_1/Planar3P-v0 | standard | 1 |" in capsys.readouterr().out


def test_help_says_model_files_are_code(bench, capsys):
    assert bench.main(["--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert " ".join(TRUSTED_FILES_NOTE.split()) in text and ":stats=" in text


def test_training_seed_from_the_run_record(tmp_path):
    assert bm.training_seed(None) is None
    run = tmp_path / "run"
    (run / "checkpoints").mkdir(parents=True)
    (run / "config.json").write_text(json.dumps({"config": {"seed": 5, "algo": "ppo"}}))
    assert bm.training_seed(run / "model.zip") == 5
    assert bm.training_seed(run / "checkpoints" / "rl_model_100_steps.zip") == 5
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "config.json").write_text("{not json")
    assert bm.training_seed(tmp_path / "bad" / "model.zip") is None
    (tmp_path / "noseed").mkdir()
    (tmp_path / "noseed" / "config.json").write_text(json.dumps({"config": {"seed": True}}))
    assert bm.training_seed(tmp_path / "noseed" / "model.zip") is None
    shipped = ROOT / "agents" / "zoo" / "pretrained"
    for name in list_pretrained():
        record = json.loads((shipped / f"{name}.json").read_text())
        assert bm.training_seed(shipped / f"{name}.zip") == record["run"]["config"]["seed"]


def test_episodes_csv_carries_the_training_seed(tmp_path, bench):
    from stable_baselines3 import PPO

    run = tmp_path / "run-s4"
    run.mkdir()
    PPO("MlpPolicy", gym.make(planar3p_gym.ENV_ID), n_steps=32, batch_size=32, seed=0).save(
        run / "model.zip"
    )
    (run / "config.json").write_text(json.dumps({"config": {"seed": 4}}))
    out = tmp_path / "out"
    policies = f"zero,{run / 'model.zip'}"
    args = _quick_args(out, "--suites", "standard", "--policies", policies, "--no-plots")
    assert bench.main([*args, "--episodes", "1"]) == 0
    seeds = {r["policy"]: r["training_seed"] for r in read_csv(out / "episodes.csv")}
    assert seeds == {"zero": "", "run-s4/model": "4"}
    summary = json.loads((out / "summary.json").read_text())
    assert summary["settings"]["training_seeds"] == {"run-s4/model": 4}
