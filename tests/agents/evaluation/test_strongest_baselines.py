"""The strongest baselines: the slider line, the certified planner, the tuned analytic
controllers; the speed bound of an episode; the normalized scores and their score matrix."""

from __future__ import annotations

import csv
import json
import math
from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest
from reach_helpers import HARD, MODE, STANDARD

import planar3p_gym
from planar3p_agents.controllers.certified import CertifiedPlanner
from planar3p_agents.controllers.registry import BASELINES
from planar3p_agents.controllers.slider_line import SliderLineController, line_rates
from planar3p_agents.evaluation import normalized_scores as ns
from planar3p_agents.evaluation import tuning
from planar3p_agents.evaluation.episodes import run_episode, speed_bound
from planar3p_agents.policies.factory import load_policy
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.slider_line import slider_line_reaches


@pytest.fixture(scope="module")
def env():
    e = gym.make(planar3p_gym.ENV_ID)
    yield e
    e.close()


def test_line_rates_are_one_synchronised_saturating_motion():
    err = np.array([[0.10, -0.05, 0.02], [0.001, -0.0005, 0.0]])
    rates = line_rates(err, gain=15.0, max_speed=0.2)
    # far: the largest travel saturates, the others in proportion (a straight line)
    assert rates[0] == pytest.approx(err[0] * 0.2 / 0.10)
    # near: the proportional gain
    assert rates[1] == pytest.approx(15.0 * err[1])
    assert np.all(line_rates(np.full((1, 3), np.nan), 15.0, 0.2) == 0.0)


def test_slider_line_solves_what_slider_line_predicts(env):
    design = env.unwrapped.design
    assert slider_line_reaches(design, STANDARD.start, [STANDARD.target], MODE)[0]
    policy = load_policy("slider-line", env)
    assert isinstance(policy, SliderLineController) and policy.gain == 15.0
    res = run_episode(env, policy, STANDARD, policy_name="slider-line")
    assert res.success
    assert math.isfinite(res.speed_bound) and res.speed_bound > 0
    assert res.time_over_bound == pytest.approx(res.time_to_success / res.speed_bound)
    assert load_policy("slider-line:gain=8", env).gain == 8.0


def test_certified_planner_chooses_what_is_certified_and_succeeds(env):
    planner = load_policy("certified", env)
    assert isinstance(planner, CertifiedPlanner)
    res = run_episode(env, planner, STANDARD, policy_name="certified")
    assert planner.choices == ["line"] and res.success
    design = env.unwrapped.design
    assert not slider_line_reaches(design, HARD.start, [HARD.target], MODE)[0]
    res = run_episode(env, planner, HARD, policy_name="certified")
    assert planner.choices == ["detour"] and res.success
    assert not res.working_mode_changed


def test_baselines_registered_for_the_reach_ids():
    for name in ("slider-line", "certified", "analytic-tuned"):
        assert planar3p_gym.ENV_ID in BASELINES[name].ids
        assert planar3p_gym.TRACK_ENV_ID not in BASELINES[name].ids
    assert BASELINES["analytic-feedforward-tuned"].ids == (planar3p_gym.TRACK_ENV_ID,)
    assert BASELINES["analytic-tuned"].per_suite


def test_tuned_gains_are_read_per_suite(env):
    data = json.loads(tuning.TUNED_GAINS_FILE.read_text())
    assert data["seed"] != 0  # a separate draw from the benchmark's seed 0
    assert data["command"].startswith("python -m planar3p_agents.evaluation.tuning")
    for name, (_, suites, default) in tuning.TUNED_BASELINES.items():
        for suite in suites:
            assert tuning.tuned_gain(name, suite) == data["gains"][name][suite]
        assert tuning.tuned_gain(name) == data["gains"][name][default]
    hard = load_policy("analytic-tuned", env, suite="hard")
    assert hard.position_gain == tuning.tuned_gain("analytic-tuned", "hard")
    track = gym.make(planar3p_gym.TRACK_ENV_ID)
    ff = load_policy("analytic-feedforward-tuned", track, suite="track-figure-eight")
    track.close()
    assert ff.position_gain == tuning.tuned_gain("analytic-feedforward-tuned", "track-figure-eight")


def test_tune_gain_picks_by_success_then_time():
    gain, rows = tuning.tune_gain("standard", seed=7, episodes=2, gains=(2.0, 12.0))
    assert [r["gain"] for r in rows] == [2.0, 12.0]
    best = min(rows, key=lambda r: (-r["success_rate"], r["median_time_to_success"]))
    assert gain == best["gain"]
    with pytest.raises(ValueError, match="no tuned baseline"):
        tuning.tune_gain("mode-change", episodes=1)


def test_tuning_counts_only_the_environments_failures():
    """A time-out (``time_limit``, the one name of that end) is not a failure of the tuning's
    score; a singularity crossing or a breakdown is."""
    results = [
        SimpleNamespace(
            termination_reason=reason,
            success=reason == "success",
            time_to_success=0.5,
            task_metrics={},
        )
        for reason in ("success", "time_limit", "singularity_crossing", "physics_breakdown")
    ]
    score = tuning._score("standard", results)
    assert score["failures"] == 2 and score["success_rate"] == 0.25


def test_speed_bound_is_the_largest_travel_over_the_speed_limit():
    from planar3p_gym.machine.design import Design

    design = Design.fig8()
    r0 = kinematics.inverse(design, np.array(STANDARD.start), MODE).rho
    r1 = kinematics.inverse(design, np.array(STANDARD.target), MODE).rho
    expected = np.abs(r1 - r0).max() / design.max_speed
    assert speed_bound(design, STANDARD.start, STANDARD.target, MODE) == pytest.approx(expected)
    assert math.isnan(speed_bound(design, STANDARD.start, (5.0, 5.0, 0.0), MODE))


def test_speed_bound_of_the_built_machine_is_its_drawn_machine_s(tmp_path):
    """On the machine as built the bound is the drawn machine's (its travels and speed limit,
    from ``info["machine"]`` at reset), not the nominal design's; on the nominal id it is the
    nominal one's."""
    from planar3p_agents.evaluation.benchmark import build_suites
    from planar3p_gym.machine.design import Design

    real = gym.make(planar3p_gym.REAL_ENV_ID)
    spec = build_suites(["real-reach"], 1, 0, real.unwrapped.design)["real-reach"].episodes[0]
    _, info = real.reset(seed=spec.index, options=spec.reset_options())
    drawn = Design.from_dict(info["machine"]["design"])
    assert drawn != real.unwrapped.design
    res = run_episode(real, load_policy("analytic-simultaneous", real), spec, policy_name="a")
    expected = speed_bound(drawn, spec.start, spec.target, spec.working_mode)
    nominal = speed_bound(real.unwrapped.design, spec.start, spec.target, spec.working_mode)
    assert res.speed_bound == expected and abs(expected - nominal) > 1e-6
    real.close()


def _rows():
    rows = []
    for policy, seed, ok, t in (
        ("random", "", False, ""),
        ("certified", "", True, 0.5),
        ("slider-line", "", True, 0.8),
        ("runs/ppo-s1/model", 1, True, 1.0),
        ("runs/ppo-s2/model", 2, False, ""),
    ):
        for suite in ("standard", "hard"):
            rows.append(
                {
                    "policy": policy,
                    "training_seed": seed,
                    "suite": suite,
                    "success": ok,
                    "time_to_success": t,
                    "speed_bound": 0.4,
                    "episode_return": -10.0 if ok else -100.0,
                }
            )
    return rows


def test_normalized_scores_between_random_and_best_baseline(tmp_path):
    refs = ns.make_references(_rows())
    assert refs["standard"]["success"] == {"random": 0.0, "best": 1.0, "best_policy": "slider-line"}
    assert refs["standard"]["time"]["best_policy"] == "certified"
    assert refs["standard"]["time"]["best"] == pytest.approx(0.8)
    assert ns.get_normalized_score("standard", 0.0, "success", refs) == 0.0
    assert ns.get_normalized_score("standard", 1.0, "success", refs) == 100.0
    assert ns.get_normalized_score("hard", 0.4, "time", refs) == pytest.approx(50.0)
    assert ns.get_normalized_score("hard", -55.0, "return", refs) == pytest.approx(50.0)
    with pytest.raises(ValueError, match="unknown metric"):
        ns.get_normalized_score("standard", 1.0, "speed", refs)
    with pytest.raises(ValueError, match="no reference"):
        ns.get_normalized_score("far", 1.0, "success", refs)
    text = ns.write_scores(tmp_path, _rows(), references=refs, n_resamples=50)
    assert "runs/ppo/model | 2 |" in text
    with (tmp_path / "scores.csv").open() as fh:
        matrix = list(csv.DictReader(fh))
    assert len(matrix) == 10  # 5 runs x 2 suites
    ppo = [r for r in matrix if r["policy"] == "runs/ppo-s1/model" and r["suite"] == "hard"]
    assert float(ppo[0]["score_time"]) == pytest.approx(50.0)
    for name in ns.SCORE_FILES:
        assert (tmp_path / name).is_file()


def test_task_suites_score_against_their_own_best_baseline():
    rows = []
    for policy, ok, ret in (
        ("random", False, -300.0),
        ("planner", True, -20.0),
        ("zero", False, -50.0),
    ):
        for suite in ("mode-change", "track-segments"):
            rows.append(
                {
                    "policy": policy,
                    "training_seed": "",
                    "suite": suite,
                    "success": ok and suite == "mode-change",  # tracking has no success test
                    "time_to_success": 1.0 if ok and suite == "mode-change" else "",
                    "speed_bound": "",  # no speed bound on these suites
                    "episode_return": ret,
                }
            )
    rows += [dict(r, policy="analytic-feedforward-tuned", episode_return=-10.0) for r in rows[:1]]
    rows[-1]["suite"] = "track-segments"
    refs = ns.make_references(rows)
    assert ns.best_baselines("mode-change") == ("planner",)
    assert refs["mode-change"]["success"] == {"random": 0.0, "best": 1.0, "best_policy": "planner"}
    assert refs["mode-change"]["return"]["best"] == -20.0  # not zero's: not a best baseline
    assert set(refs["mode-change"]) == {"success", "return"}  # no speed bound: no time score
    assert set(refs["track-segments"]) == {"return"}  # no success test either
    assert refs["track-segments"]["return"]["best_policy"] == "analytic-feedforward-tuned"
    assert ns.get_normalized_score("track-segments", -155.0, "return", refs) == pytest.approx(50.0)
    with pytest.raises(ValueError, match="no reference for the success score"):
        ns.get_normalized_score("track-segments", 1.0, "success", refs)
    matrix = ns.score_matrix(rows, refs)
    track = next(r for r in matrix if r["suite"] == "track-segments" and r["policy"] == "zero")
    assert math.isnan(track["score_success"]) and track["score_return"] == pytest.approx(
        100.0 * (-50.0 + 300.0) / 290.0, abs=1e-3
    )


def test_scores_of_suites_without_a_time_score_are_written_with_their_figures(tmp_path):
    """A benchmark of the mode-change suite alone (no speed bound, so no time score: the
    demo's second part) writes its scores and figures; the figures used to fail on the empty
    time metric ("need at least one array to concatenate") and the report lost its section."""
    rows = [
        {
            "policy": policy,
            "training_seed": "",
            "suite": "mode-change",
            "success": ok,
            "time_to_success": 1.0 if ok else "",
            "speed_bound": "",
            "episode_return": ret,
        }
        for policy, ok, ret in (
            ("random", False, -300.0),
            ("planner", True, -20.0),
            ("zero", False, -50.0),
        )
    ]
    text = ns.write_scores(tmp_path, rows, references=ns.make_references(rows), n_resamples=50)
    assert text.startswith("## Normalized scores")
    assert "| planner | 1 |" in text
    for name in ns.SCORE_FILES:
        assert (tmp_path / name).is_file()


def test_probability_of_improvement():
    a, b = np.array([[2.0, 2.0]]), np.array([[1.0, 1.0]])
    assert ns.probability_of_improvement(a, b)[0] == 1.0
    assert ns.probability_of_improvement(b, a)[0] == 0.0
    assert ns.probability_of_improvement(a, a)[0] == 0.5


def test_reference_file_covers_the_reach_and_task_suites():
    refs = json.loads(ns.REFERENCE_FILE.read_text())
    assert set(refs["suites"]) >= {"standard", "hard", "far", "goal", "mode-change"}
    for suite, entry in refs["suites"].items():
        assert refs["best_of"][suite] == list(ns.best_baselines(suite))
        assert all(m["best_policy"] in ns.best_baselines(suite) for m in entry.values())
    assert ns.get_normalized_score("standard", refs["suites"]["standard"]["success"]["best"]) == (
        pytest.approx(100.0)
    )


def test_report_section_follows_the_reference_file(tmp_path):
    """``replace_report_section`` swaps the normalized-scores section of a report for a new one
    and leaves the sections around it; without the report or the section it writes nothing."""
    report = tmp_path / "report.md"
    assert not ns.replace_report_section(report, "## Normalized scores\n\nnew\n")
    head, tail = "# Run\n\n## Results\n\nrows\n\n", "## Definitions\n\nterms\n"
    report.write_text(head + "## Normalized scores\n\nold table\n\n![fig](a.png)\n\n" + tail)
    assert ns.replace_report_section(report, "## Normalized scores\n\nnew table\n")
    assert report.read_text() == head + "## Normalized scores\n\nnew table\n\n" + tail
    plain = tmp_path / "plain.md"
    plain.write_text(head + tail)
    assert not ns.replace_report_section(plain, "## Normalized scores\n\nnew\n")
    assert plain.read_text() == head + tail
