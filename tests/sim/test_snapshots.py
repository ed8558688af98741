"""State snapshots: ``Planar3PSim.get_state/set_state`` and
``Planar3PEnv.get_state/set_state`` restore bit for bit; ``copy.deepcopy`` and ``pickle`` of
a simulation or an (unwrapped) environment work through them."""

from __future__ import annotations

import copy
import pickle

import gymnasium as gym
import numpy as np
import pytest

import planar3p_gym  # noqa: F401  (registers the ids)
from planar3p_gym import Design
from planar3p_gym.sim import physics
from planar3p_gym.sim.physics import Planar3PSim, SimSnapshot
from planar3p_gym.tasks import sampling as task

DESIGN = Design.fig8()
MODE = (1, 1, -1)
MODELS = {
    "v0": {},
    "v1": {
        "projection": True,
        "substeps": physics.PROJECTED_SUBSTEPS,
        "iterations": physics.PROJECTED_ITERATIONS,
    },
}


def start(i: int = 0) -> np.ndarray:
    poses, _ = task.sample_poses(DESIGN, MODE, np.random.default_rng(1), task.TaskConfig())
    return poses[i]


@pytest.mark.parametrize("model", sorted(MODELS))
def test_restored_simulations_continue_bit_identically(model):
    """After 60 random steps (saturating the servos at times), a restored copy, made by
    ``set_state`` on another simulation, ``from_state``, ``copy.deepcopy`` and a pickle round
    trip, goes through exactly the same states as the original for 60 more steps."""
    rng = np.random.default_rng(0)
    sim = Planar3PSim(DESIGN, start(), MODE, **MODELS[model])
    for c in rng.uniform(-1.0, 1.0, (60, 3)) * DESIGN.max_speed:
        sim.step(c)
    snap = sim.get_state()
    assert isinstance(snap, SimSnapshot) and snap.steps == 60
    other = Planar3PSim(DESIGN, start(1), MODE, **MODELS[model])
    other.set_state(snap)
    copies = [
        other,
        Planar3PSim.from_state(pickle.loads(pickle.dumps(snap))),
        copy.deepcopy(sim),
        pickle.loads(pickle.dumps(sim)),
    ]
    assert all(c.state == sim.state for c in copies)
    for c in rng.uniform(-1.0, 1.0, (60, 3)) * DESIGN.max_speed:
        expected = sim.step(c)
        assert all(copy_.step(c) == expected for copy_ in copies)


def test_bad_snapshots_are_rejected():
    sim = Planar3PSim(DESIGN, start(), MODE)
    before = sim.state
    with pytest.raises(ValueError, match="SimSnapshot"):
        sim.set_state({"pose": (0, 0, 0)})
    snap = sim.get_state()
    broken = SimSnapshot(snap.design, snap.pose, snap.working_mode, snap.settings, (0.1, 0.2))
    with pytest.raises(ValueError, match="three per step"):
        sim.set_state(broken)
    assert sim.state == before


def run(env, actions, episode: int = 150) -> list:
    """Observations, rewards and ends of ``actions``, resetting as episodes end (and every
    ``episode`` steps: unwrapped envs have no time limit)."""
    out = []
    for n, a in enumerate(actions, 1):
        obs, reward, terminated, truncated, info = env.step(a)
        out.append((obs.tobytes(), reward, terminated, truncated, info["closure_error"]))
        if terminated or truncated or n % episode == 0:
            obs, _ = env.reset()
            out.append(obs.tobytes())
    return out


@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [("Planar3P-v0", {"working_mode": "random"}), ("Planar3P-v0", {})],
)
def test_restored_environments_continue_bit_identically(env_id, kwargs):
    """An environment restored from ``get_state`` (into a fresh one, by ``copy.deepcopy`` and
    by pickling the unwrapped env) replays the original's next 400 steps exactly, resets
    included (the random generator and the task's episode state are part of the snapshot)."""
    env = gym.make(env_id, **kwargs).unwrapped
    env.reset(seed=11)
    rng = np.random.default_rng(2)
    run(env, rng.uniform(-1.0, 1.0, (40, 3)))
    snap = env.get_state()
    fresh = gym.make(env_id, **kwargs).unwrapped
    fresh.set_state(pickle.loads(pickle.dumps(snap)))
    copies = [fresh, copy.deepcopy(env), pickle.loads(pickle.dumps(env))]
    actions = rng.uniform(-1.0, 1.0, (400, 3))
    expected = run(env, actions)
    assert sum(1 for r in expected if isinstance(r, bytes)) >= 1  # a reset happened
    for c in copies:
        assert run(c, actions) == expected


def test_wrapped_environments_can_be_deep_copied():
    env = gym.make("Planar3P-v0")
    env.reset(seed=0)
    twin = copy.deepcopy(env)
    actions = np.random.default_rng(3).uniform(-1.0, 1.0, (300, 3))
    assert run(twin, actions) == run(env, actions)


def test_snapshots_from_other_settings_are_rejected_without_change():
    env = gym.make("Planar3P-v0").unwrapped
    env.reset(seed=0)
    snap = env.get_state()
    other = gym.make("Planar3P-v0", design="fig7").unwrapped
    other.reset(seed=0)
    before = other.get_state()
    with pytest.raises(ValueError, match="other settings"):
        other.set_state(snap)
    with pytest.raises(ValueError, match="get_state"):
        other.set_state({"sim": None})
    assert pickle.dumps(other.get_state()) == pickle.dumps(before)


def test_snapshot_before_reset_restores_an_unreset_environment():
    env = gym.make("Planar3P-v0").unwrapped
    snap = env.get_state()
    assert snap["sim"] is None
    used = gym.make("Planar3P-v0").unwrapped
    used.reset(seed=4)
    used.set_state(snap)
    with pytest.raises(RuntimeError, match="reset"):
        used.sim  # noqa: B018
