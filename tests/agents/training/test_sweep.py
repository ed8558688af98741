"""planar3p_agents.training.sweep / scripts/sweep.py: a tiny sweep on a local Ray, its table, and
bad input."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("ray.tune")

from script_loader import command

from planar3p_agents.training.run import RunOptions
from planar3p_agents.training.sweep import COLUMNS, SweepSpec, run_sweep, search_space, validate

SMOKE = {"n_steps": 64, "batch_size": 64, "n_epochs": 1}
OPTIONS = dict(
    eval_freq=128, eval_episodes=1, final_eval_episodes=2, checkpoint_freq=256, progress_bar=False
)


sweep_script = command("sweep")


@pytest.fixture(scope="module")
def local_ray():
    import ray

    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


def test_two_seed_sweep_runs_each_trial_like_train_py(tmp_path: Path, local_ray) -> None:
    """Two trials (seeds 0 and 1), 256 steps each: one row per trial with its training seed,
    each trial's run directory complete and its metrics those the table reports."""
    out = tmp_path / "sweep"
    spec = SweepSpec(
        algo="ppo",
        seeds=[0, 1],
        timesteps=256,
        grid={"tiny": {"params": SMOKE, "n_envs": 1}},
        options=RunOptions(**OPTIONS),
    )
    rows = run_sweep(spec, out)
    assert [(r["config"], r["training_seed"], r["status"]) for r in rows] == [
        ("tiny", 0, "ok"),
        ("tiny", 1, "ok"),
    ]
    with open(out / "results.csv") as fh:
        table = list(csv.DictReader(fh))
    assert tuple(table[0]) == COLUMNS and [t["training_seed"] for t in table] == ["0", "1"]
    for row in rows:
        run = Path(row["run_dir"])
        assert run.parent == (out / "runs").resolve()
        config = json.loads((run / "config.json").read_text())
        assert config["config"]["seed"] == row["training_seed"]
        assert config["config"]["algo_kwargs"]["n_steps"] == 64  # the grid's settings
        assert config["sweep"]["config"] == "tiny"
        metrics = json.loads((run / "metrics.json").read_text())
        assert metrics["timesteps"] == row["timesteps"] == 256
        assert metrics["final_evaluation"]["success_rate"] == row["final_success_rate"]
        assert row["policy"] == f"ppo:{run / 'model.zip'}:stats={run / 'vecnormalize.pkl'}"
        assert (run / "model.zip").is_file() and (run / "vecnormalize.pkl").is_file()
    # different seeds, different training: the two final models differ
    a, b = ((Path(r["run_dir"]) / "model.zip").read_bytes() for r in rows)
    assert a != b
    md = (out / "results.md").read_text()
    assert "| tiny | 2 |" in md and "tiny-s0" in md and "tiny-s1" in md


def test_optuna_search_samples_within_the_space(tmp_path: Path, local_ray) -> None:
    out = tmp_path / "search"
    spec = SweepSpec(
        algo="ppo",
        seeds=[3],
        timesteps=128,
        grid={"default": {"params": SMOKE, "n_envs": 1}},
        search={"learning_rate": {"loguniform": [1e-5, 1e-3]}, "n_epochs": {"choice": [1, 2]}},
        num_samples=1,  # one trial keeps the suite short; the grid test runs two at once
        options=RunOptions(**OPTIONS),
    )
    rows = run_sweep(spec, out)
    assert len(rows) == 1 and rows[0]["status"] == "ok" and rows[0]["config"].startswith("search")
    for row in rows:
        params = json.loads(row["params"])
        assert 1e-5 <= params["learning_rate"] <= 1e-3 and params["n_epochs"] in (1, 2)
        assert params["n_steps"] == 64 and row["training_seed"] == 3
        saved = json.loads((Path(row["run_dir"]) / "config.json").read_text())["config"]
        assert saved["algo_kwargs"]["n_epochs"] == params["n_epochs"]


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (dict(seeds=[]), "seeds must be distinct"),
        (dict(seeds=[1, 1]), "seeds must be distinct"),
        (dict(seeds=[-1]), "seed must be an integer"),
        (dict(grid={"a b": {}}), "configuration name"),
        (dict(grid={"x": {"nosuch": 1}}), "may hold params"),
        (dict(grid={"x": {"params": {"nosuch": 1}}}), "no hyperparameter nosuch"),
        (dict(search={"learning_rate": {"loguniform": [0, 1]}}), "low > 0"),
        (dict(search={"learning_rate": {"normal": [0, 1]}}), "give one of"),
        (dict(search={"learning_rate": {"uniform": [2, 1]}}), "low < high"),
        (dict(search={"n_epochs": {"choice": [1]}}, seeds=[0, 1]), "one seed"),
        (dict(metric="loss"), "metric"),
        (dict(timesteps=float("inf")), "n_timesteps"),
    ],
)
def test_bad_sweeps_are_refused_before_anything_runs(change, message, tmp_path: Path) -> None:
    spec = SweepSpec(**{"algo": "ppo", "seeds": [0], **change})
    with pytest.raises(ValueError, match=message):
        validate(spec, tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_search_space_domains() -> None:
    space = search_space(
        {
            "learning_rate": {"loguniform": [1e-5, 1e-3]},
            "n_epochs": {"int": [3, 5]},
            "gamma": {"uniform": [0.9, 0.99]},
            "batch_size": {"choice": [64, 128]},
        }
    )
    assert space["n_epochs"].lower == 3 and space["n_epochs"].upper == 6  # both ends included
    assert space["batch_size"].categories == [64, 128]


def test_script_exits_2_on_bad_input_and_keeps_existing_output(tmp_path: Path, capsys) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("precious")
    args = ["--algo", "ppo", "--seeds", "0", "--out", str(out)]
    assert sweep_script.main(args) == 2
    assert "exists and is not empty" in capsys.readouterr().err
    assert (out / "keep.txt").read_text() == "precious"
    bad = tmp_path / "grid.yml"
    bad.write_text("[1, 2]\n")
    args = ["--algo", "ppo", "--seeds", "0", "--grid", str(bad), "--out", str(tmp_path / "o")]
    assert sweep_script.main(args) == 2
    assert "must hold a non-empty mapping" in capsys.readouterr().err


def test_script_passes_the_vector_env_choice_to_every_trial() -> None:
    base = ["--algo", "ppo", "--env", "Planar3P-v0", "--seeds", "0", "--out", "o"]
    from planar3p_agents.cli import parse

    _, args = parse(["sweep", *base, "--vec-env", "native"])
    assert sweep_script.spec_from(args).options.vec_env == "native"
    assert sweep_script.spec_from(parse(["sweep", *base])[1]).options.vec_env == "auto"
