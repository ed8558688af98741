"""Fitting the pose correction on simulated episodes of the machine as built."""

from __future__ import annotations

import json

import numpy as np
import pytest

from planar3p_agents.controllers.pose_correction import PoseCorrection
from planar3p_agents.training import pose_correction as fit


def test_samples_are_the_readings_and_their_bias() -> None:
    obs, bias = fit.collect_samples(episodes=2, seed=3, every=50)
    assert obs.shape[0] == bias.shape[0] >= 2 and bias.shape[1] == 3
    # The machine as built is read through the nominal model: the bias is not zero.
    assert np.abs(bias[:, :2]).max() > 0.0
    again = fit.collect_samples(episodes=2, seed=3, every=50)
    np.testing.assert_array_equal(again[1], bias)  # seeded: the same episodes


def test_an_assembly_change_suite_is_driven_by_its_first_baseline() -> None:
    """On ``real-assembly-change`` the samples are episodes of its environment (36-entry
    observations) driven by ``analytic-simultaneous``; an unknown suite is refused."""
    obs, bias = fit.collect_samples("real-assembly-change", episodes=1, seed=4, every=40)
    assert obs.shape[1] == 36 and bias.shape == (obs.shape[0], 3)
    assert 0.0 < np.abs(bias[:, :2]).max() < 0.01  # millimetres of manufacturing error
    with pytest.raises(ValueError, match="suite must be one of"):
        fit.collect_samples("assembly-change", episodes=1)
    with pytest.raises(ValueError, match="driver must be one of"):
        fit.collect_samples("real-assembly-change", episodes=1, driver="planner")


def test_the_mode_change_is_driven_by_the_planner_and_the_record_says_so(tmp_path) -> None:
    """``--driver planner`` drives the mode change's episodes (the simple motions fail it) and
    the written record names the driver."""
    out = tmp_path / "c.json"
    argv = ["--suite", "real-mode-change", "--driver", "planner", "--episodes", "2"]
    assert fit.main([*argv, "--seed", "5", "--every", "5", "--out", str(out)]) == 0
    record = json.loads(out.read_text())
    assert record["driver"] == "planner" and record["suite"] == "real-mode-change"
    assert PoseCorrection(out).weights.shape == (14, 3)


def test_command_line_writes_a_correction(tmp_path) -> None:
    out = tmp_path / "c.json"
    assert fit.main(["--episodes", "3", "--seed", "2", "--every", "10", "--out", str(out)]) == 0
    record = json.loads(out.read_text())
    assert record["episodes"] == 3 and record["seed"] == 2
    assert record["suite"] == "real-on-off" and record["env_id"] == "Planar3PRealOnOff-v0"
    assert PoseCorrection(out).weights.shape == (14, 3)


@pytest.mark.parametrize("flag", ["--episodes", "--every"])
def test_command_line_refuses_a_bad_count(tmp_path, flag: str) -> None:
    with pytest.raises(SystemExit) as exc:
        fit.main([flag, "0", "--out", str(tmp_path / "c.json")])
    assert exc.value.code == 2
    assert not (tmp_path / "c.json").exists()


@pytest.mark.parametrize(
    ("args", "flag"),
    [
        (["--seed", "-1"], "--seed"),
        (["--suite", "real-reach-true-state"], "--suite"),  # its pose is read exactly
        (["--suite", "real-mode-change", "--driver", "certified-line"], "--driver"),  # not its id's
        (["--out", "{tmp}/missing/c.json"], "--out"),  # its folder does not exist
    ],
)
def test_command_line_refuses_bad_flags_before_any_work(tmp_path, capsys, args, flag) -> None:
    argv = [a.replace("{tmp}", str(tmp_path)) for a in args]
    if "--out" not in argv:
        argv += ["--out", str(tmp_path / "c.json")]
    with pytest.raises(SystemExit) as exc:
        fit.main(argv)
    assert exc.value.code == 2
    assert flag in capsys.readouterr().err.strip().splitlines()[-1]
    assert list(tmp_path.rglob("*")) == []
