"""planar3p_agents.zoo.shipping / planar3p ship: both layouts of a shipped policy, the manifest,
and rl-zoo3's enjoy playing the shipped PPO policy; planar3p plot-learning on a tiny run."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

pytest.importorskip("stable_baselines3")
pytest.importorskip("rl_zoo3")

from script_loader import ROOT, command

from planar3p_agents.policies.factory import PRETRAINED_DIR, file_sha256
from planar3p_agents.zoo.shipping import ship, zoo_layout

train_script = command("train")
ship_script = command("ship")


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory) -> Path:
    run = tmp_path_factory.mktemp("runs") / "ppo-tiny-s0"
    args = ["--algo", "ppo", "--timesteps", "128", "--n-envs", "1", "--run-dir", str(run)]
    args += ["--eval-freq", "64", "--eval-episodes", "1", "--final-eval-episodes", "1"]
    args += ["--checkpoint-freq", "128", "--no-progress-bar"]
    args += ["--params", "n_steps=64", "batch_size=64", "n_epochs=1"]
    args += ["--env-kwargs", "max_episode_steps=150"]
    assert train_script.main(args) == 0
    return run


def _manifest(directory: Path) -> dict[str, str]:
    lines = (directory / "SHA256SUMS").read_text().splitlines()
    return {line[66:]: line[:64] for line in lines}


def test_ship_writes_both_layouts_and_the_manifest(tiny_run: Path, tmp_path: Path) -> None:
    out = tmp_path / "pretrained"
    assert ship_script.main([str(tiny_run), "--name", "tiny", "--out", str(out)]) == 0
    assert (out / "tiny.zip").read_bytes() == (tiny_run / "best" / "best_model.zip").read_bytes()
    stats = (tiny_run / "best" / "vecnormalize.pkl").read_bytes()
    assert (out / "tiny_vecnormalize.pkl").read_bytes() == stats
    record = json.loads((out / "tiny.json").read_text())
    assert record["source_model"] == "best/best_model.zip"
    assert record["run"]["config"]["env_kwargs"] == {"max_episode_steps": 150}
    exp = out / "ppo" / "Planar3P-v0_1"
    assert (exp / "Planar3P-v0.zip").read_bytes() == (out / "tiny.zip").read_bytes()
    assert (exp / "Planar3P-v0" / "vecnormalize.pkl").read_bytes() == stats
    args = yaml.safe_load((exp / "Planar3P-v0" / "args.yml").read_text())
    assert args["env_kwargs"] == {"max_episode_steps": 150} and args["shipped_name"] == "tiny"
    config = yaml.safe_load((exp / "Planar3P-v0" / "config.yml").read_text())
    assert config["normalize"] is True and config["n_steps"] == 64 and config["n_envs"] == 1
    # every shipped file, in both layouts, is in the manifest with its checksum
    sums = _manifest(out)
    files = [p for p in out.rglob("*") if p.is_file() and p.name != "SHA256SUMS"]
    assert len(files) == 7
    for path in files:
        assert sums[path.relative_to(out).as_posix()] == file_sha256(path)
    # re-shipping the name keeps its experiment id; another name gets the next one
    assert ship(tiny_run, "tiny", "model", out)
    assert zoo_layout("tiny", out) == exp
    ship(tiny_run, "other", "model", out)
    assert (out / "ppo" / "Planar3P-v0_2" / "Planar3P-v0.zip").is_file()
    # a checkpoint ships with its own statistics
    ship(tiny_run, "early", "checkpoint:128", out)
    ckpt = tiny_run / "checkpoints"
    assert (out / "early.zip").read_bytes() == (ckpt / "rl_model_128_steps.zip").read_bytes()
    assert (out / "early_vecnormalize.pkl").read_bytes() == (
        ckpt / "rl_model_vecnormalize_128_steps.pkl"
    ).read_bytes()
    record = json.loads((out / "early.json").read_text())
    assert record["source_model"] == "checkpoints/rl_model_128_steps.zip"


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--name", "bad name!"], "invalid name"),
        (["--name", "x", "--model", "model"], "does not exist"),
        (["--name", "x", "--model", "checkpoint:-5"], "checkpoint:<steps>"),
        (["--name", "x", "--model", "last"], "checkpoint:<steps>"),
    ],
)
def test_bad_input_writes_nothing(argv, message, tmp_path: Path, capsys) -> None:
    out = tmp_path / "pretrained"
    assert ship_script.main([str(tmp_path / "no-run"), *argv, "--out", str(out)]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_shipped_zoo_layout_matches_the_shipped_policy() -> None:
    exp = PRETRAINED_DIR / "ppo" / "Planar3P-v0_1"
    assert file_sha256(exp / "Planar3P-v0.zip") == file_sha256(PRETRAINED_DIR / "ppo_kickstart.zip")
    assert file_sha256(exp / "Planar3P-v0" / "vecnormalize.pkl") == file_sha256(
        PRETRAINED_DIR / "ppo_kickstart_vecnormalize.pkl"
    )
    sums = _manifest(PRETRAINED_DIR)
    for path in exp.rglob("*"):
        if path.is_file():
            assert sums[path.relative_to(PRETRAINED_DIR).as_posix()] == file_sha256(path)


def test_rl_zoo3_enjoy_plays_the_shipped_policy() -> None:
    """The documented command, run as a user would (seed 0, deterministic, 300 steps)."""
    cmd = [sys.executable, "-m", "rl_zoo3.enjoy", "--algo", "ppo", "--env", "Planar3P-v0"]
    cmd += ["-f", "agents/zoo/pretrained", "--gym-packages", "planar3p_gym", "--no-render"]
    cmd += ["-n", "300", "--seed", "0"]
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy", "OMP_NUM_THREADS": "1"}
    done = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    rate = re.search(r"Success rate: ([\d.]+)%", done.stdout)
    episodes = re.search(r"(\d+) Episodes", done.stdout)
    assert rate and episodes, done.stdout[-2000:]
    # the shipped policy succeeds in most episodes (its benchmark: 95 % on standard)
    assert int(episodes.group(1)) >= 3 and float(rate.group(1)) >= 50.0


def test_learning_curves_of_a_run(tiny_run: Path, tmp_path: Path, capsys) -> None:
    """planar3p plot-learning (planar3p_agents.evaluation.learning_curves) on the same tiny
    run."""
    import numpy as np

    from planar3p_agents.evaluation.learning_curves import group_name, load_run

    plot_script = command("plot-learning")
    run = load_run(tiny_run)
    assert group_name(run) == "ppo-tiny" and run["algo"] == "ppo" and run["seed"] == 0
    saved = np.load(tiny_run / "evaluations.npz")
    np.testing.assert_array_equal(run["timesteps"], saved["timesteps"])
    np.testing.assert_allclose(run["returns"], saved["results"].mean(axis=1))
    out = tmp_path / "curves.png"
    assert plot_script.main([str(tiny_run), "--out", str(out)]) == 0
    assert out.read_bytes()[:4] == b"\x89PNG"
    assert "| ppo-tiny-s0 | PPO | 0 | no |" in capsys.readouterr().out
    assert plot_script.main([str(tmp_path / "nothing"), "--out", str(out)]) == 2
