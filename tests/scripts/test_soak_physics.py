"""scripts/soak_physics.py at a tiny size: its counts add up, its JSON holds them, bad flags
exit 2 with one line before any work."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import gymnasium as gym
import pytest

ROOT = Path(__file__).resolve().parents[2]


def load():
    spec = importlib.util.spec_from_file_location("soak_physics", ROOT / "scripts/soak_physics.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


soak_physics = load()


def test_the_soak_counts_every_episode_and_writes_them(tmp_path, capsys):
    out = tmp_path / "soak.json"
    ids = ["Planar3PAssemblyChange-v0", "Planar3PRealOnOff-v0"]
    assert soak_physics.main(["--episodes", "2", "--ids", *ids, "--json", str(out)]) == 0
    text = capsys.readouterr().out
    data = json.loads(out.read_text())
    assert data["settings"]["episodes"] == 2 and data["settings"]["seed"] == 10_000
    results = data["results"]
    assert [(r["id"], r["policy"]) for r in results] == [
        (i, p) for i in ids for p in soak_physics.POLICIES
    ]
    for r in results:
        assert sum(r["end_reasons"].values()) == r["episodes"] == 2
        assert r["steps"] >= 2
        assert r["breakdown_fraction"] == r["end_reasons"]["physics_breakdown"] / 2
        assert len(r["breakdown_seeds"]) == r["end_reasons"]["physics_breakdown"]
        assert r["stroke_violations"] == r["closure_violations"] == 0
        assert r["max_accepted_closure"] <= 1e-9
        assert r["recovered_steps"] >= r["episodes_with_recovery"]
        assert f"{r['id']:<26} {r['policy']:<9}" in text
    # The assembly change's bang-bang episodes lock the chain: their steps are recovered.
    assert results[1]["recovered_steps"] > 0
    # A second run gives the same counts (seeded episodes and actions).
    again = soak_physics.soak("Planar3PAssemblyChange-v0", "bang-bang", 2, 10_000)
    assert {k: v for k, v in again.items()} == results[1]


def test_the_energy_counts_see_a_step_that_makes_energy():
    """``--energy``'s measure: 0 for a step that changes nothing,
    the energy added to a body for one that makes it."""
    env = gym.make("Planar3PGoal-v0")
    env.reset(seed=0)
    sim = env.unwrapped.sim
    before = sim.body_values()
    assert soak_physics.excess_energy(sim, before, before) == 0.0
    after = list(before)
    after[3] += 1.0  # the platform 1 m/s faster along x, the sliders not moved
    made = 0.5 * sim.platform.mass * ((before[3] + 1.0) ** 2 - before[3] ** 2)
    assert soak_physics.excess_energy(sim, before, after) == pytest.approx(made, rel=1e-12)
    r = soak_physics.soak("Planar3PAssemblyChange-v0", "random", 1, 10_000, energy=True)
    assert set(r["energy_steps_over"]) == {"0.001", "0.01", "1.0"}
    assert r["max_excess_energy"] <= 1e-3  # (the simulation recovers the steps that make more)
    env.close()


@pytest.mark.parametrize(
    ("argv", "flag"),
    [
        (["--episodes", "0"], "--episodes"),
        (["--seed", "-1"], "--seed"),
        (["--jobs", "0"], "--jobs"),
        (["--ids", "Planar3P-v9"], "--ids"),
        (["--policies", "greedy"], "--policies"),
        (["--json", "/nonexistent-dir/x.json"], "--json"),
        (["--episodes", "x"], "--episodes"),
    ],
)
def test_bad_flags_exit_2_with_one_line(argv, flag, capsys):
    with pytest.raises(SystemExit) as e:
        soak_physics.main(argv)
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and flag in err, err
