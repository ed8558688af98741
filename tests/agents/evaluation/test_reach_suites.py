"""Evaluation suites (agents/evaluation/reach_suites.py, agents/evaluation/path_diagnostics.py,
agents/evaluation/region_maps.py): seeded, prefix-stable, valid reset options of the kind each suite
promises, saved and loaded."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from planar3p_agents.evaluation import reach_suites as su
from planar3p_gym import Design
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.statics import holding_forces

ROOT = Path(__file__).resolve().parents[3]
DESIGN = Design.fig8()


def test_suites_identical_for_the_same_seed(suites):
    again = {name: su.make_suite(name, 4, seed=7) for name in su.SUITE_NAMES}
    for name in su.SUITE_NAMES:
        assert again[name].to_dict() == suites[name].to_dict()
    other = su.make_suite("standard", 4, seed=8)
    assert other.to_dict()["episodes"] != suites["standard"].to_dict()["episodes"]


def test_shorter_suite_is_a_prefix(suites):
    for name in ("standard", "far"):
        short = su.make_suite(name, 2, seed=7)
        assert [e.to_dict() for e in short.episodes] == [
            e.to_dict() for e in suites[name].episodes[:2]
        ]


def test_suites_do_not_touch_global_random_state():
    before = np.random.get_state()[1].copy()  # noqa: NPY002
    su.make_suite("standard", 2, seed=0)
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
    su.save_suites(path, suites, DESIGN)
    loaded, design = su.load_suites(path)
    assert design == DESIGN
    assert {k: v.to_dict() for k, v in loaded.items()} == {
        k: json.loads(json.dumps(v.to_dict())) for k, v in suites.items()
    }
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(ValueError, match="cannot read"):
        su.load_suites(tmp_path / "bad.json")
    with pytest.raises(ValueError, match="not found"):
        su.load_suites(tmp_path / "missing.json")


def test_suite_hold_force_fraction_replaces_the_task_limit():
    """A suite's ``hold_force_fraction`` decides how hard its ends may be to hold, above the
    environment's own sampling limit (0.75 of max_force) too: the crossing stress suite."""
    mode = (1, 1, 1)
    loose = su.make_suite(
        "hard", 20, 0, working_mode=mode, end_parallel_margin=0.02, hold_force_fraction=1.0
    )
    ends = np.array([p for e in loose.episodes for p in (e.start, e.target)])
    forces = np.abs(holding_forces(DESIGN, ends, mode)).max(axis=-1)
    assert (forces <= DESIGN.max_force).all()
    assert (forces > 0.75 * DESIGN.max_force).any()
    strict = su.make_suite(
        "hard", 5, 0, working_mode=mode, end_parallel_margin=0.02, hold_force_fraction=0.5
    )
    ends = np.array([p for e in strict.episodes for p in (e.start, e.target)])
    assert (np.abs(holding_forces(DESIGN, ends, mode)).max(axis=-1) <= 0.5 * DESIGN.max_force).all()


def test_unknown_suite():
    with pytest.raises(ValueError, match="unknown suite"):
        su.make_suite("easy", 3, 0)
    with pytest.raises(ValueError, match="unknown suite"):
        su.make_suites(["standard", "easy"], 3, 0)


def test_holding_forces_match_the_simulation(env, suites):
    spec = suites["standard"].episodes[0]
    env.reset(options=spec.reset_options())
    for _ in range(5):
        _, _, _, _, info = env.step(np.zeros(3))
    f = np.abs(holding_forces(DESIGN, np.array(info["pose"]), spec.working_mode))
    np.testing.assert_allclose(f, info["actuator_forces"], rtol=0.05, atol=0.05)


def test_the_published_suites_are_episodes_of_todays_rules():
    """docs/benchmark/suites.json holds the suites the benchmark drew from seed 0 with the
    sampler before its proposal region (planar3p_gym.tasks.pose_proposal), which changed the
    episodes a seed gives: every published figure replays on its directory's suites.json
    (``--suite-file``).  Those episodes are ones today's rules accept: acceptable ends of one
    assembly mode, and the path diagnostics the file records are today's, to the 6 decimals
    it keeps; today's generation from a seed is deterministic."""
    from planar3p_agents.evaluation.path_diagnostics import path_dict, path_profiles
    from planar3p_gym.tasks import sampling as task

    saved, design = su.load_suites(ROOT / "docs" / "benchmark" / "suites.json")
    assert design == DESIGN
    cfg = task.TaskConfig()
    for name in ("standard", "far"):
        for e in saved[name].episodes[:3]:
            ends = np.array([e.start, e.target])
            mode = np.asarray(e.working_mode, dtype=float)
            ok, det = task._acceptable(DESIGN, ends, mode, cfg)
            assert ok.all() and det[0] == det[1]
            recorded = e.to_dict()["path"]
            prof = path_profiles(DESIGN, ends[0], ends[1], e.working_mode, cfg=cfg)
            for key, value in path_dict(prof, 0).items():
                if isinstance(value, float):
                    assert value == pytest.approx(recorded[key], abs=1e-6), key
                else:
                    assert value == recorded[key], key
        fresh = [e.to_dict() for e in su.make_suite(name, 3, seed=0).episodes]
        assert fresh == [e.to_dict() for e in su.make_suite(name, 3, seed=0).episodes]
