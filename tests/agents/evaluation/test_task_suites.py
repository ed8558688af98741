"""Task suites (agents/evaluation/task_suites.py): seeded episode specs of the task ids,
replayed exactly, their baselines, and the benchmark script on them."""

from __future__ import annotations

import json
import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from bench_helpers import read_csv, replay

import planar3p_gym
from planar3p_agents.evaluation import benchmark as bm
from planar3p_agents.evaluation import episodes as ep
from planar3p_agents.evaluation import intervals as st
from planar3p_agents.evaluation import reach_suites as su
from planar3p_agents.evaluation import task_suites as ts
from planar3p_agents.policies.factory import load_policy

ROOT = Path(__file__).resolve().parents[3]


def test_generic_mechanism_on_planar3p_v0(monkeypatch):
    """Episode i of a task suite is the environment's own draw after reset(seed=s_i); the
    saved spec replays it: same start pose and target, also after a JSON round trip."""
    # The reach task of Planar3P-v0 publishes its episode spec too.
    reach = ts.TaskSuiteDef(planar3p_gym.ENV_ID, {}, ("analytic-simultaneous",), "reach", 99)
    monkeypatch.setitem(ts.TASK_SUITES, "reach-env", reach)
    env = gym.make(planar3p_gym.ENV_ID)
    suite = ts.make_task_suite("reach-env", 3, seed=5, env=env)
    assert suite.params["task"] == "reach" and suite.params["env_id"] == planar3p_gym.ENV_ID
    for spec in suite.episodes:
        _, drawn = env.reset(seed=ts.task_episode_seed("reach-env", 5, spec.index))
        options = json.loads(json.dumps(spec.to_dict()))["options"]
        _, replayed = env.reset(seed=123, options=options)
        np.testing.assert_array_equal(replayed["pose"], drawn["pose"])
        assert env.unwrapped.target == tuple(spec.target) == tuple(drawn["episode_spec"]["target"])
    again = ts.make_task_suite("reach-env", 2, seed=5)
    assert [e.to_dict() for e in again.episodes] == [e.to_dict() for e in suite.episodes[:2]]
    other = ts.make_task_suite("reach-env", 2, seed=6)
    assert other.episodes[0].options != suite.episodes[0].options


def test_task_suite_files_roundtrip(tmp_path):
    goal = ts.make_task_suite("goal", 2, seed=1)
    reach = su.make_suite("standard", 2, seed=1)
    su.save_suites(tmp_path / "suites.json", {"standard": reach, "goal": goal})
    loaded, _ = su.load_suites(tmp_path / "suites.json")
    assert loaded["goal"].to_dict() == json.loads(json.dumps(goal.to_dict()))
    assert loaded["standard"].episodes[0].options is None
    assert "options" not in loaded["standard"].to_dict()["episodes"][0]


def test_unknown_task_suite_and_baseline():
    with pytest.raises(ValueError, match="unknown task suite"):
        ts.make_task_suite("juggling", 2, seed=0)
    env = ts.make_task_env("goal")
    with pytest.raises(ValueError, match="does not apply to Planar3PGoal-v0"):
        load_policy("planner", env)


def test_tracking_suite_metrics_and_replay():
    """Tracking has no success test: its episodes end 'completed' and the summary has no
    success rate; the task metrics come from the last info; a replay is identical; feeding
    the reference velocity forward removes most of the feedback controller's lag."""
    env = ts.make_task_env("track-figure-eight")
    suite = ts.make_task_suite("track-figure-eight", 2, seed=0, env=env)
    ff = load_policy("analytic-feedforward", env)
    fb = load_policy("analytic-simultaneous", env)
    res_ff = ep.evaluate(env, ff, suite, policy_name="ff")
    res_fb = ep.evaluate(env, fb, suite, policy_name="fb")
    again = ep.evaluate(env, ff, suite, policy_name="ff")
    assert [r.row() for r in again] == [r.row() for r in res_ff]
    for r in res_ff + res_fb:
        assert r.cause == "completed" and not r.success_defined
        assert r.steps == env.spec.max_episode_steps
        assert set(r.task_metrics) >= {"tracking_rms_error", "tracking_max_error"}
        assert r.task_metrics["tracking_rms_error"] <= r.task_metrics["tracking_max_error"]
    s_ff = st.summarize(res_ff, n_resamples=100)
    s_fb = st.summarize(res_fb, n_resamples=100)
    assert math.isnan(s_ff["success_rate"]) and all(math.isnan(v) for v in s_ff["success_ci"])
    assert s_ff["causes"]["completed"] == 2
    rms_ff = s_ff["task_metrics"]["tracking_rms_error"]["max"]
    rms_fb = s_fb["task_metrics"]["tracking_rms_error"]["median"]
    assert rms_ff < 0.2 * rms_fb


def test_script_on_task_suites_and_replay(tmp_path, bench, capsys):
    out = tmp_path / "tasks"
    args = ["--suites", "goal,track-segments", "--episodes", "1", "--seed", "2", "--no-progress"]
    assert bench.main([*args, "--out", str(out), "--no-plots"]) == 0
    printed = capsys.readouterr().out
    assert "| analytic-simultaneous | goal | 1 |" in printed
    assert "| analytic-feedforward | track-segments | 1 | – |" in printed
    report = (out / "report.md").read_text()
    assert "Task suites at a glance" in report and "tracking rms error mm" in report
    rows = read_csv(out / "episodes.csv")
    assert {(r["policy"], r["suite"]) for r in rows} == {
        ("analytic-simultaneous", "goal"),
        ("analytic-tuned", "goal"),  # the strongest reach baselines on the goal ids
        ("slider-line", "goal"),
        ("certified", "goal"),
        ("certified-line", "goal"),
        ("random", "goal"),
        ("random", "track-segments"),
        ("analytic-simultaneous", "track-segments"),
        ("analytic-feedforward", "track-segments"),
        ("analytic-feedforward-tuned", "track-segments"),  # (tuned on seed 1000)
        ("zero", "track-segments"),
    }
    assert all(r["tracking_rms_error"] for r in rows if r["suite"] == "track-segments")
    first = [r for r in rows if r["policy"] == "analytic-feedforward"]
    assert replay(bench, out, "track-segments", "analytic-feedforward", tmp_path / "r") == first


def test_script_policies_that_do_not_apply(tmp_path, bench, capsys):
    """A baseline is played on every suite whose id it supports (the registry's), skipped with
    a warning on the others; a suite left without any policy is an error."""
    out = tmp_path / "x"
    base = ["--suites", "goal", "--episodes", "1", "--no-progress", "--out", str(out)]
    assert bench.main([*base, "--policies", "planner"]) == 2
    err = capsys.readouterr().err
    assert "planner does not apply to suite goal (Planar3PGoal-v0" in err and "no policy" in err
    assert not out.exists()
    assert bench.main([*base, "--policies", "baselines,crossing,random", "--no-plots"]) == 0
    assert "crossing does not apply to suite goal" in capsys.readouterr().err
    rows = read_csv(out / "episodes.csv")
    # random is one of the goal suite's baselines and is played once
    assert [r["policy"] for r in rows] == list(ts.TASK_SUITES["goal"].baselines)


def test_load_suite_policies_shares_reach_policies():
    env = gym.make(planar3p_gym.ENV_ID)
    per_suite, meta = bm.load_suite_policies(
        ["baselines"], ["standard", "far"], {"standard": env, "far": env}
    )
    assert list(per_suite["standard"]) == list(bm.REACH_BASELINES)
    assert per_suite["standard"]["random"] is per_suite["far"]["random"]
    assert meta["zero"] == ("zero", None)


def test_a_retuned_analytic_controller_plays_every_suite():
    """``analytic-simultaneous:gain=K`` is played on reach and task suites alike (the analytic
    controller reads every id's observation); the task's own baselines are skipped, with a
    warning, on a suite of another id."""
    reach = gym.make(planar3p_gym.ENV_ID)
    track = ts.make_task_env("track-segments")
    warnings: list[str] = []
    per_suite, meta = bm.load_suite_policies(
        ["baselines", "analytic-simultaneous:gain=12", "planner"],
        ["standard", "track-segments"],
        {"standard": reach, "track-segments": track},
        warn=warnings.append,
    )
    assert per_suite["standard"]["analytic-simultaneous:gain=12"].position_gain == 12.0
    retuned = per_suite["track-segments"]["analytic-simultaneous:gain=12"]
    assert retuned.position_gain == 12.0 and retuned.obs_size == 34
    assert meta["analytic-simultaneous:gain=12"] == ("analytic-simultaneous:gain=12", None)
    assert "analytic-feedforward" in per_suite["track-segments"]
    assert not any("planner" in pols for pols in per_suite.values())
    assert warnings == [
        f"planner does not apply to suite {suite} ({env_id}; it plays on Planar3PModeChange-v0)"
        for suite, env_id in (("standard", "Planar3P-v0"), ("track-segments", "Planar3PTrack-v0"))
    ]


@pytest.mark.parametrize(
    ("suite", "baseline", "flag"),
    [("mode-change", "planner", "in_target_mode"), ("assembly-change", "crossing", None)],
)
def test_mode_and_assembly_change_suites(suite, baseline, flag):
    """The planner / crossing baselines on seeded episodes of their suites: success, the task's
    own flags in the metrics (target-describing ones left out), and an identical replay."""
    env = ts.make_task_env(suite)
    episodes = ts.make_task_suite(suite, 1, seed=0, env=env)
    policy = load_policy(baseline, env)
    first = ep.evaluate(env, policy, episodes, policy_name=baseline)
    again = ep.evaluate(env, policy, episodes, policy_name=baseline)
    assert [r.row() for r in again] == [r.row() for r in first]
    (r,) = first
    assert r.success and r.cause == "success" and r.success_defined
    assert not any(k.startswith("target_") for k in r.task_metrics)
    if flag:
        assert r.task_metrics[flag] == 1.0 and r.working_mode_changed
    else:
        assert r.task_metrics["in_target_assembly"] == 1.0 and r.task_metrics["crossings"] >= 1


def test_real_assembly_change_suite():
    """``real-assembly-change`` is the assembly change on the machine as built (the
    randomisation, sensors and delay of ``real-mode-change``) under its own seed index: its
    analytic-simultaneous episode replays identically, and differs from the same episode
    played on the exact machine."""
    real, exact = ts.TASK_SUITES["real-assembly-change"], ts.TASK_SUITES["assembly-change"]
    assert real.env_id == exact.env_id and exact.env_kwargs == {}
    assert real.env_kwargs == ts.TASK_SUITES["real-mode-change"].env_kwargs
    assert set(real.env_kwargs) == {"randomization", "sensors", "latency"}
    assert real.baselines[:2] == ("analytic-simultaneous", "crossing")
    assert len({d.index for d in ts.TASK_SUITES.values()}) == len(ts.TASK_SUITES)
    env = ts.make_task_env("real-assembly-change")
    episodes = ts.make_task_suite("real-assembly-change", 1, seed=0, env=env)
    assert episodes.params["env_kwargs"] == real.env_kwargs
    policy = load_policy("analytic-simultaneous", env)
    first = ep.evaluate(env, policy, episodes, policy_name="analytic-simultaneous")
    again = ep.evaluate(env, policy, episodes, policy_name="analytic-simultaneous")
    assert [r.row() for r in again] == [r.row() for r in first]
    nominal_env = ts.make_task_env("assembly-change")
    nominal = ep.evaluate(nominal_env, load_policy("analytic-simultaneous", nominal_env), episodes)
    assert first[0].row()["episode_return"] != nominal[0].row()["episode_return"]
