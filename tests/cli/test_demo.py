"""The demo's pieces: GIF recording of one fixed episode, and benchmarks of task suites alone."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import gymnasium as gym
import imageio.v2 as imageio
import pytest
from gif_helpers import gif_delays
from script_loader import command

from planar3p_agents.commands import demo
from planar3p_agents.controllers.floor import ZeroPolicy
from planar3p_agents.controllers.registry import STRONGEST_REACH_BASELINES
from planar3p_agents.evaluation.episode_gif import GIF_SIZE, record_gif
from planar3p_agents.evaluation.task_suites import TASK_SUITES, make_task_suite
from planar3p_agents.policies.factory import load_policy


@pytest.fixture(scope="module")
def mode_change_episode():
    return make_task_suite("mode-change", 1, seed=0).episodes[0]


def test_record_gif_plays_the_fixed_episode(tmp_path, mode_change_episode):
    """The planner reaches the target (a certified mode change); the GIF holds the reset,
    every ``frame_every``-th step and the last one, each shown 60 ms (``render_fps /
    frame_every`` = 50 / 3 Hz), the last held 1 s more: read back, the delays add up to that
    (Pillow may merge identical frames, adding their delays), and it loops."""
    env_id = TASK_SUITES["mode-change"].env_id
    path = tmp_path / "planner.gif"
    outcome = record_gif(
        env_id,
        lambda env: load_policy("planner", env),
        mode_change_episode.reset_options(),
        path,
        frame_every=3,
    )
    assert outcome["success"] and outcome["reason"] == "success"
    assert outcome["position_error_mm"] <= 2.0  # the task's position tolerance, 2 mm
    steps = outcome["steps"]
    rendered = 1 + steps // 3 + (steps % 3 != 0)
    delays, loop = gif_delays(path)
    assert sum(delays) == 60 * rendered + 1000
    assert all(d % 60 == 0 and d > 0 for d in delays[:-1])
    assert delays[-1] >= 1060
    assert loop == 0
    first = imageio.mimread(path, memtest=False)[0]
    assert first.shape[:2] == (GIF_SIZE[1], GIF_SIZE[0])


def test_record_gif_reports_a_timeout(tmp_path, mode_change_episode):
    """Zero velocity never reaches the target: the time limit ends the episode (400 steps)."""
    outcome = record_gif(
        TASK_SUITES["mode-change"].env_id,
        lambda env: ZeroPolicy(),
        mode_change_episode.reset_options(),
        tmp_path / "zero.gif",
        frame_every=50,
    )
    assert outcome == {
        "steps": 400,
        "reason": "time_limit",
        "success": False,
        "position_error_mm": pytest.approx(outcome["position_error_mm"]),
    }
    assert outcome["position_error_mm"] > 2.0
    first = imageio.mimread(tmp_path / "zero.gif", memtest=False)[0]
    assert first.shape[:2] == (GIF_SIZE[1], GIF_SIZE[0])
    with pytest.raises(ValueError, match="frame_every"):
        record_gif("Planar3P-v0", lambda env: ZeroPolicy(), {}, tmp_path / "x.gif", frame_every=0)


def test_benchmark_of_a_task_suite_alone_writes_its_plots(tmp_path, bench):
    """A run with only a task suite (no reach suite, so no trajectory map) completes and writes
    its success and error plots (it used to fail drawing an empty trajectory figure)."""
    out = tmp_path / "mc"
    argv = ["--suites", "mode-change", "--policies", "planner,zero", "--episodes", "2"]
    assert bench.main([*argv, "--out", str(out), "--no-progress"]) == 0
    rows = list(csv.DictReader((out / "episodes.csv").open()))
    assert [(r["policy"], r["success"]) for r in rows] == [("planner", "True")] * 2 + [
        ("zero", "False")
    ] * 2
    summary = json.loads((out / "summary.json").read_text())
    assert len(summary["summaries"]) == 2
    assert (out / "success_rate.png").stat().st_size > 1000
    assert not (out / "trajectories.png").exists()


def test_demo_refuses_an_unknown_policy(tmp_path, capsys):
    code = command("demo").main(
        ["--out", str(tmp_path), "--mode-change-policy", "pretrained:no_such"]
    )
    assert code == 2
    assert "unknown pretrained model" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())  # nothing written


def test_demo_default_policies_are_named_and_fit_their_ids():
    """The demo names its learned policies (not the first shipped file by sort order, which
    changes as policies are shipped) and each loads on the id its part plays."""
    for spec, env_id in (
        (demo.REACH_POLICY, demo.REACH_ENV),
        (demo.MODE_CHANGE_POLICY, TASK_SUITES[demo.MODE_CHANGE].env_id),
    ):
        env = gym.make(env_id)
        policy = load_policy(spec, env=env)
        obs, _ = env.reset(seed=0)
        action, _ = policy.predict(obs, deterministic=True)
        assert env.action_space.contains(action.astype(env.action_space.dtype))


def test_demo_compares_the_reach_policy_with_the_strongest_baseline_and_the_paper():
    """The reach part plays the learned policy, the strongest reach baseline (one of the
    benchmark's) and the paper's controller; the GIFs show the first two."""
    assert demo.REACH_BASELINE in STRONGEST_REACH_BASELINES
    reach = demo.parts(Path("out"), demo.REACH_POLICY, demo.MODE_CHANGE_POLICY, 0)[0]
    assert reach.policies == [demo.REACH_POLICY, demo.REACH_BASELINE, demo.ANALYTIC]


def _summary(policy: str, suite: str, rate: float) -> dict:
    return {
        "policy": policy,
        "suite": suite,
        "episodes": 20,
        "success_rate": rate,
        "success_ci": (max(0.0, rate - 0.2), min(1.0, rate + 0.1)),
        "median_time_over_bound": 11.64,
        "p90_time_over_bound": 12.5,
        "median_time_to_success": 6.04,
        "singularity_crossings": 12,
    }


@pytest.mark.parametrize("task", [False, True])
def test_demo_tables_fit_an_80_column_terminal(task):
    """The demo's policies on its suites: every line of the table and its legend is under 80
    columns (the full benchmark table, 264 characters wide, wrapped in a terminal)."""
    policies = (
        [demo.MODE_CHANGE_POLICY, demo.ANALYTIC, "planner"]
        if task
        else [demo.REACH_POLICY, demo.REACH_BASELINE, demo.ANALYTIC]
    )
    suites = ["mode-change"] if task else ["standard", "hard", "far"]
    rows = [_summary(p, s, r) for p in policies for s in suites for r in (0.1, 1.0)]
    table = demo.brief_table(rows, task=task)
    assert max(len(line) for line in table.splitlines()) < 80
    assert all(p in table for p in policies) and "100 [80, 100]" in table


def test_demo_keeps_the_loaders_notes_about_its_own_models_to_itself(tmp_path, capsys):
    """The shipped reach policy was trained with environment arguments; the benchmark's loader
    notes that on stderr ("warning: ..."), which the demo's user has nothing to do about: the
    notes go to the demo's ``warn``, and nothing is printed."""
    from planar3p_agents.commands import benchmark

    notes = []
    job = benchmark.prepare(
        [demo.REACH_POLICY, demo.REACH_BASELINE],
        ["standard"],
        episodes=1,
        seed=0,
        out=tmp_path / "b",
        command="test",
        warn=notes.append,
    )
    job.close()
    assert notes and "warning" not in capsys.readouterr().err
