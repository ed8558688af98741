"""``scripts/bench_env.py``: bad arguments are rejected before any work (exit 2, one line);
results are written atomically; :mod:`planar3p_agents.evaluation.throughput` measures what it
says."""

from __future__ import annotations

import json

import gymnasium as gym
import pytest
from script_loader import load_script as _load_script

from planar3p_agents.evaluation import throughput


def load_script():
    return _load_script("bench_env")


@pytest.mark.parametrize(
    "argv",
    [
        ["--repeats", "-1"],
        ["--repeats", "0"],
        ["--steps", "0"],
        ["--seed", "-1"],
        ["--duration", "0"],
        ["--duration", "nan"],
        ["--num-envs", "0"],
        ["--ppo-steps", "0"],
        ["--blocks", "0"],
        ["--json", "/nonexistent/dir/out.json"],
        ["--steps", "abc"],
        ["--unknown"],
    ],
)
def test_bad_arguments_exit_2_with_one_line_before_any_work(argv, capsys, monkeypatch):
    def no_work(*args, **kwargs):
        raise AssertionError("measured despite bad arguments")

    monkeypatch.setattr(throughput, "single_env_rates", no_work)
    mod = load_script()
    assert mod.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("planar3p bench-env: error:")


def test_json_directory_is_rejected(tmp_path, capsys):
    mod = load_script()
    assert mod.main(["--json", str(tmp_path)]) == 2


def test_write_json_atomic_replaces_whole_files_only(tmp_path):
    target = tmp_path / "out.json"
    throughput.write_json_atomic(target, {"a": 1})
    assert json.loads(target.read_text()) == {"a": 1}
    with pytest.raises(TypeError):
        throughput.write_json_atomic(target, {"a": object()})  # not serialisable
    assert json.loads(target.read_text()) == {"a": 1}  # the old file survives
    assert [p.name for p in tmp_path.iterdir()] == ["out.json"]  # no temporary left


def test_throughput_measures_run_and_are_positive():
    rates = throughput.single_env_rates(["Planar3P-v0", "Pendulum-v1"], 2, 0.05, 0)
    assert all(len(v) == 2 and min(v) > 0 for v in rates.values())
    assert throughput.paired_ratio([2.0, 4.0], [1.0, 1.0]) == 3.0
    assert throughput.median_step_us("Planar3P-v0", 20, 0) > 0
    assert min(throughput.vector_rates("Planar3P-v0", "native", 2, 5, 1, 0)) > 0
    assert min(throughput.vector_rates("Planar3P-v0", "native-numpy", 2, 5, 1, 0)) > 0
    vec, ref = throughput.vector_rates("Planar3P-v0", "native", 2, 5, 2, 0, "Pendulum-v1")
    assert len(vec) == len(ref) == 2 and min(ref) > 0
    prof = throughput.profile_step("Planar3P-v0", 20, 0)
    assert prof["physics"] > 0 and prof["wrapped_step"] >= prof["physics"]
    assert prof["outputs"] > 0 and set(prof) == {
        "wrapped_step", "env_step", "physics", "outputs", "other"
    }  # fmt: skip
    with pytest.raises(ValueError):
        throughput.vector_rates("Planar3P-v0", "threads", 2, 5, 1, 0)
    best = throughput.best_block_rates(
        {
            "single": lambda: throughput.make_env("Planar3P-v0"),
            "vector": lambda: gym.make_vec("Planar3P-v0", num_envs=2),
        },
        10,
        3,
        0,
    )
    assert set(best) == {"single", "vector"} and min(best.values()) > 0
