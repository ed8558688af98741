"""planar3p_agents.zoo.shipping / scripts/ship_policy.py: the one layout of a shipped policy (an
rl-zoo3 log folder per model), the manifest and ``--verify`` (the rl-zoo3 route checked), and
rl-zoo3's enjoy playing a shipped PPO policy; scripts/plot_learning.py on a tiny run."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path
from typing import Any

import pytest
import yaml

pytest.importorskip("stable_baselines3")
pytest.importorskip("rl_zoo3")

from script_loader import ROOT, load_script

from planar3p_agents.policies.factory import (
    PRETRAINED_DIR,
    PolicyError,
    file_sha256,
    list_pretrained,
)
from planar3p_agents.zoo.layout import enjoy_command, shipped_model
from planar3p_agents.zoo.manifest import verify_zoo_folder
from planar3p_agents.zoo.portable import machine_traces
from planar3p_agents.zoo.shipping import ship, zoo_layout

train_script = load_script("train")
ship_script = load_script("ship_policy")


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


def _members(path: Path) -> dict[str, bytes]:
    with zipfile.ZipFile(path) as zf:
        return {name: zf.read(name) for name in zf.namelist()}


def _same_model(shipped: Path, source: Path, run: Path) -> None:
    """The shipped model is the run's: every member byte for byte but ``data``, whose only
    change is the run directory in ``tensorboard_log``, written ``runs/<run>``."""
    got, want = _members(shipped), _members(source)
    assert got.keys() == want.keys()
    for name in want:
        if name != "data":
            assert got[name] == want[name], name
    data, original = json.loads(got["data"]), json.loads(want["data"])
    assert original["tensorboard_log"] == str(run / "tb")  # absolute: a tmp_path run
    assert data.pop("tensorboard_log") == f"runs/{run.name}/tb"
    original.pop("tensorboard_log")
    assert data == original


def test_ship_writes_the_layout_and_the_manifest(tiny_run: Path, tmp_path: Path) -> None:
    out = tmp_path / "pretrained"
    assert ship_script.main([str(tiny_run), "--name", "tiny", "--out", str(out)]) == 0
    shipped = shipped_model("tiny", out)
    exp = out / "tiny" / "ppo" / "Planar3P-v0_1"  # one rl-zoo3 log folder per model
    assert shipped.experiment == exp and shipped.model == exp / "Planar3P-v0.zip"
    _same_model(shipped.model, tiny_run / "best" / "best_model.zip", tiny_run)
    stats = (tiny_run / "best" / "vecnormalize.pkl").read_bytes()
    assert (exp / "Planar3P-v0" / "vecnormalize.pkl").read_bytes() == stats
    record = json.loads((out / "tiny" / "provenance.json").read_text())
    assert record["source_model"] == "best/best_model.zip"
    assert record["run"]["config"]["env_kwargs"] == {"max_episode_steps": 150}
    assert f"--run-dir runs/{tiny_run.name}" in record["run"]["command"]  # not the tmp path
    args = yaml.safe_load((exp / "Planar3P-v0" / "args.yml").read_text())
    assert args["env_kwargs"] == {"max_episode_steps": 150} and args["shipped_name"] == "tiny"
    assert args["env"] == "Planar3P-v0" and args["command"] == record["run"]["command"]
    config = yaml.safe_load((exp / "Planar3P-v0" / "config.yml").read_text())
    assert config["normalize"] is True and config["n_steps"] == 64 and config["n_envs"] == 1
    # every shipped file, stored once, is in the manifest with its checksum
    sums = _manifest(out)
    files = [p for p in out.rglob("*") if p.is_file() and p.name != "SHA256SUMS"]
    assert len(files) == 5 and sorted(files) == sorted(shipped.files())
    for path in files:
        assert sums[path.relative_to(out).as_posix()] == file_sha256(path)
    assert machine_traces(files) == []  # no absolute path, no host name
    # re-shipping the name replaces its folder; another name gets a folder of its own
    assert ship(tiny_run, "tiny", "model", out)[-1] == out / "SHA256SUMS"
    assert json.loads(shipped.provenance.read_text())["source_model"] == "model.zip"
    assert zoo_layout("tiny", out) == exp
    ship(tiny_run, "other", "model", out)
    assert (out / "other" / "ppo" / "Planar3P-v0_1" / "Planar3P-v0.zip").is_file()
    assert list_pretrained(out) == ["other", "tiny"]
    # a checkpoint ships with its own statistics
    ship(tiny_run, "early", "checkpoint:128", out)
    early = shipped_model("early", out)
    ckpt = tiny_run / "checkpoints"
    _same_model(early.model, ckpt / "rl_model_128_steps.zip", tiny_run)
    assert early.stats.read_bytes() == (ckpt / "rl_model_vecnormalize_128_steps.pkl").read_bytes()
    record = json.loads(early.provenance.read_text())
    assert record["source_model"] == "checkpoints/rl_model_128_steps.zip"
    assert sorted(_manifest(out)) == sorted(
        p.relative_to(out).as_posix()
        for p in out.rglob("*")
        if p.name != "SHA256SUMS" and p.is_file()
    )
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no staging left


def test_ship_refuses_a_file_that_would_carry_a_machine_path(
    tiny_run: Path, tmp_path: Path
) -> None:
    """A note naming a place of this machine would be shipped as it is: refused, nothing written."""
    out = tmp_path / "pretrained"
    with pytest.raises(ValueError, match="trace of this machine"):
        ship(tiny_run, "tiny", "model", out, note="compare /home/someone/runs-old/x")
    assert list_pretrained(out) == [] and not list(out.iterdir())


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--name", "bad name!"], "invalid name"),
        (["--name", "x", "--model", "model"], "does not exist"),
        (["--name", "x", "--model", "checkpoint:-5"], "checkpoint:<steps>"),
        (["--name", "x", "--model", "last"], "checkpoint:<steps>"),
        ([], "--name: give the name"),
    ],
)
def test_bad_input_writes_nothing(argv, message, tmp_path: Path, capsys) -> None:
    out = tmp_path / "pretrained"
    assert ship_script.main([str(tmp_path / "no-run"), *argv, "--out", str(out)]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize("name", list_pretrained())
def test_each_shipped_model_is_one_zoo_folder(name: str) -> None:
    """One experiment per folder, its files stored once, rl-zoo3's settings agreeing with the
    provenance, every file in the manifest with its checksum."""
    shipped = shipped_model(name)
    record = json.loads(shipped.provenance.read_text())
    assert record["name"] == name
    assert [p.relative_to(shipped.folder).as_posix() for p in shipped.folder.glob("*/*")] == [
        f"{shipped.algo}/{shipped.env_id}_1"
    ]
    files = sorted(p for p in shipped.folder.rglob("*") if p.is_file())
    assert files == sorted(shipped.files()) and len(files) == 5
    digests = [file_sha256(p) for p in files]
    assert len(set(digests)) == len(digests)  # no file twice (the README names no copies)
    args = yaml.safe_load(shipped.zoo_args.read_text())
    config = record["run"]["config"]
    assert (args["algo"], args["env"], args["shipped_name"]) == (
        shipped.algo,
        config["env_id"],
        name,
    )
    assert args["env_kwargs"] == (config.get("env_kwargs") or None)
    assert args["command"] == record["run"]["command"]
    assert yaml.safe_load(shipped.zoo_config.read_text())["normalize"] is True
    sums = _manifest(PRETRAINED_DIR)
    for path in files:
        assert sums[path.relative_to(PRETRAINED_DIR).as_posix()] == file_sha256(path)
    assert enjoy_command(shipped).endswith(
        f"--env {shipped.env_id} -f agents/zoo/pretrained/{name} --exp-id 1 "
        "--gym-packages planar3p_gym"
    )


def test_rl_zoo3_enjoy_plays_the_shipped_policy() -> None:
    """The documented command, run as a user would (seed 0, deterministic, 1000 steps), after
    the documented check of the folder."""
    assert ship_script.main(["--verify", "ppo_reach_scratch"]) == 0
    cmd = [sys.executable, "-m", "rl_zoo3.enjoy", "--algo", "ppo", "--env", "Planar3P-v0"]
    cmd += ["-f", "agents/zoo/pretrained/ppo_reach_scratch", "--exp-id", "1"]
    cmd += ["--gym-packages", "planar3p_gym", "--no-render", "-n", "1000", "--seed", "0"]
    cmd += ["--num-threads", "1"]
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy", "OMP_NUM_THREADS": "1"}
    done = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    rate = re.search(r"Success rate: ([\d.]+)%", done.stdout)
    episodes = re.search(r"(\d+) Episodes", done.stdout)
    assert rate and episodes, done.stdout[-2000:]
    # the shipped policy succeeds in most episodes (its benchmark: 92 % on standard)
    assert int(episodes.group(1)) >= 3 and float(rate.group(1)) >= 50.0


# ------------------------------------------------- the rl-zoo3 route checked
def _tampered(tmp_path: Path, name: str = "ppo_reach_scratch") -> tuple[Path, Any]:
    copy = tmp_path / "pretrained"
    shutil.copytree(PRETRAINED_DIR, copy)
    return copy, shipped_model(name, copy)


def test_verify_passes_the_shipped_folders(capsys) -> None:
    assert ship_script.main(["--verify"]) == 0
    out = capsys.readouterr().out
    assert all(f"ok pretrained:{name}: 5 files" in out for name in list_pretrained())
    assert ship_script.main(["--verify", "all"]) == 0
    assert ship_script.main(["--verify", f"{PRETRAINED_DIR / 'ppo_goal'}/"]) == 0  # -f folder


@pytest.mark.parametrize("target", ["stats", "zoo_args", "zoo_config", "provenance", "model"])
def test_verify_refuses_a_tampered_copy(tmp_path: Path, capsys, target: str) -> None:
    """One changed byte in any file of a copy of the shipped folder: the check exits 1 naming
    the file, and so does ``--verify`` of every folder (the others pass)."""
    copy, shipped = _tampered(tmp_path)
    assert ship_script.main(["--verify", "ppo_reach_scratch", "--dir", str(copy)]) == 0
    path = getattr(shipped, target)
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0x01
    path.write_bytes(bytes(data))
    capsys.readouterr()
    assert ship_script.main(["--verify", "ppo_reach_scratch", "--dir", str(copy)]) == 1
    err = capsys.readouterr().err
    assert f"checksum mismatch for shipped file {path}" in err
    assert ship_script.main(["--verify", "--dir", str(copy)]) == 1
    captured = capsys.readouterr()
    assert "FAILED pretrained:ppo_reach_scratch" in captured.err
    assert "ok pretrained:ppo_goal" in captured.out
    assert ship_script.main(["--verify", str(shipped.folder)]) == 1  # the folder given to -f
    with pytest.raises(PolicyError, match="checksum mismatch"):
        verify_zoo_folder("ppo_reach_scratch", copy)


def test_verify_refuses_added_and_missing_files(tmp_path: Path, capsys) -> None:
    """rl-zoo3 would also load files the manifest does not list (``--load-best`` reads
    ``best_model.zip``): an added file is refused, and so is a missing one."""
    copy, shipped = _tampered(tmp_path)
    added = shipped.experiment / "best_model.zip"
    shutil.copyfile(shipped.model, added)
    assert ship_script.main(["--verify", "ppo_reach_scratch", "--dir", str(copy)]) == 1
    assert f"{added} is not listed" in capsys.readouterr().err
    added.unlink()
    shipped.zoo_config.unlink()
    assert ship_script.main(["--verify", "ppo_reach_scratch", "--dir", str(copy)]) == 1
    assert f"shipped file {shipped.zoo_config} is missing" in capsys.readouterr().err
    assert ship_script.main(["--verify", "no_such_model", "--dir", str(copy)]) == 1
    assert "no file of" in capsys.readouterr().err
    assert ship_script.main(["--verify", "x", "--name", "y"]) == 2  # usage


def test_learning_curves_of_a_run(tiny_run: Path, tmp_path: Path, capsys) -> None:
    """scripts/plot_learning.py (planar3p_agents.evaluation.learning_curves) on the tiny run."""
    import numpy as np

    from planar3p_agents.evaluation.learning_curves import group_name, load_run

    plot_script = load_script("plot_learning")
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
