"""A snapshot's contents are checked before ``set_state`` uses them
(:mod:`planar3p_gym.envs.snapshot`): an edited, truncated or mixed snapshot is refused with
``ValueError`` and the environment goes on exactly as it would have."""

from __future__ import annotations

import copy
import dataclasses

import gymnasium as gym
import numpy as np
import pytest

import planar3p_gym  # noqa: F401

ENV_ID = "Planar3P-v0"


def _env(seed: int, steps: int) -> gym.Env:
    env = gym.make(ENV_ID).unwrapped
    env.reset(seed=seed)
    env.action_space.seed(seed)
    for _ in range(steps):
        env.step(env.action_space.sample())
    return env


def _future(env: gym.Env, steps: int = 15) -> list:
    """Observations and rewards of ``steps`` seeded random steps, then of a reset."""
    env.action_space.seed(99)
    out = []
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        out += [obs.tobytes(), reward, info["pose"]]
        if terminated or truncated:
            break
    obs, info = env.reset()
    return [*out, obs.tobytes(), info["episode_spec"]]


def _edits(s: dict, other: dict) -> dict:
    """Snapshots that are not ones, by what is wrong with them (``other``: a snapshot of another
    episode of the same environment)."""
    ep = s["episode"]
    rec, machine = ep["record"], ep["machine"]

    def record(**changes) -> dict:
        return {**s, "episode": {**ep, "record": dataclasses.replace(rec, **changes)}}

    def built(**changes) -> dict:
        return {**s, "episode": {**ep, "machine": dataclasses.replace(machine, **changes)}}

    return {
        "record not an episode": {**s, "episode": {**ep, "record": {"steps": "x"}}},
        "episode emptied": {**s, "episode": {}},
        "steps a string": record(steps="x"),
        "steps negative": record(steps=-1),
        "steps a bool": record(steps=True),
        "target a nan": record(target=(float("nan"), 0.1, 0.0)),
        "target short": record(target=(0.1, 0.1)),
        "target_rho short": record(target_rho=np.zeros(2)),
        "mode not one": record(mode=(1, 1, 2)),
        "obs of another shape": record(obs=np.zeros(5, np.float32)),
        "obs float64": record(obs=rec.obs.astype(np.float64)),
        "machine a dict": built(machine={}),
        "delays a string": built(delays="12"),
        "encoders without sensors": built(encoders=(0.0,)),
        "an extra field": {**s, "episode": {**ep, "extra": 1}},
        "another episode's simulation": {**s, "sim": other["sim"]},
        "no simulation": {**s, "sim": None},
        "sim not one": {**s, "sim": "x"},
        "np_random not a state": {**s, "np_random": {"state": 1}},
        "np_random of no bit generator": {**s, "np_random": {"bit_generator": "dict"}},
        "np_random_seed a string": {**s, "np_random_seed": "x"},
    }


CASES = list(_edits(_env(0, 3).get_state(), _env(1, 7).get_state()))


@pytest.mark.parametrize("case", CASES)
def test_a_snapshot_that_is_not_one_is_refused_and_changes_nothing(case):
    """``{**s, "episode": {"_steps": "x"}}`` was accepted (the next step raised TypeError) and
    ``{**s, "episode": {}}`` mixed the snapshot's simulation with the current episode."""
    env, ref = _env(2, 5), _env(2, 5)
    bad = _edits(_env(0, 3).get_state(), _env(1, 7).get_state())[case]
    before = copy.deepcopy(env.get_state())
    with pytest.raises(ValueError, match="snapshot"):
        env.set_state(bad)
    after = env.get_state()
    assert after["episode"]["record"].steps == before["episode"]["record"].steps
    assert after["np_random"] == before["np_random"] and after["sim"] == before["sim"]
    assert _future(env) == _future(ref)


def test_a_snapshot_still_restores_bit_for_bit():
    """The checks accept every real snapshot, before the first reset and during an episode."""
    fresh = gym.make(ENV_ID).unwrapped
    fresh.set_state(gym.make(ENV_ID).unwrapped.get_state())
    env, ref = _env(3, 4), _env(3, 4)
    other = _env(4, 9)
    other.set_state(env.get_state())
    assert _future(other) == _future(ref)
