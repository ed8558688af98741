"""The optional travel term of the mode- and assembly-change rewards (``travel_shaping``)."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import planar3p_gym  # noqa: F401
from planar3p_gym.envs.assembly_change import Planar3PAssemblyChangeEnv
from planar3p_gym.envs.mode_change import Planar3PModeChangeEnv
from planar3p_gym.machine import kinematics
from planar3p_gym.tasks.travel_shaping import travel_rows, travel_term

IDS = ("Planar3PModeChange-v0", "Planar3PAssemblyChange-v0")


def _target_mode(spec: dict) -> tuple[int, int, int]:
    return tuple(spec.get("target_working_mode", spec["working_mode"]))  # type: ignore[return-value]


@pytest.mark.parametrize("env_id", IDS)
def test_travel_shaping_adds_only_the_travel_term(env_id):
    """``travel_shaping=w``: the reward gains ``-w sum_i |rho_i - rho_i^t| / L`` (target travels
    by inverse kinematics in the target's working mode) and nothing else changes (same
    observations, the other terms bit for bit); 0 adds no term."""
    plain, shaped = gym.make(env_id), gym.make(env_id, travel_shaping=2.0)
    design = plain.unwrapped.design
    rng = np.random.default_rng(5)
    _, info0 = plain.reset(seed=11)
    _, info1 = shaped.reset(seed=11)
    spec = info1["episode_spec"]
    assert spec == info0["episode_spec"]
    target_rho = kinematics.inverse(design, np.asarray(spec["target"]), _target_mode(spec)).rho
    for _ in range(40):
        action = rng.uniform(-1.0, 1.0, 3)
        obs0, r0, *_, info0 = plain.step(action)
        obs1, r1, *_, info1 = shaped.step(action)
        np.testing.assert_array_equal(obs0, obs1)
        assert "travel" not in info0["reward_terms"]
        others = {k: v for k, v in info1["reward_terms"].items() if k != "travel"}
        assert others == info0["reward_terms"]
        expected = -2.0 * np.abs(np.asarray(info1["rho"]) - target_rho).sum()
        expected /= design.characteristic_length
        assert info1["reward_terms"]["travel"] == pytest.approx(expected, rel=1e-12, abs=1e-15)
        assert r1 - info1["reward_terms"]["travel"] == pytest.approx(r0, rel=1e-12, abs=1e-12)
    assert shaped.unwrapped.config()["task_arguments"]["travel_shaping"] == 2.0
    assert "travel_shaping" not in plain.unwrapped.config()["task_arguments"]


@pytest.mark.parametrize("make", [Planar3PModeChangeEnv, Planar3PAssemblyChangeEnv])
@pytest.mark.parametrize("bad", [-1.0, math.nan, math.inf, "2", 1e7])
def test_travel_shaping_rejects_bad_weights(make, bad):
    with pytest.raises(ValueError, match="travel_shaping"):
        make(travel_shaping=bad)


@settings(max_examples=200, deadline=None)
@given(
    w=st.floats(0.0, 10.0),
    r=st.tuples(*[st.floats(-1.0, 1.0)] * 3),
    t=st.tuples(*[st.floats(-1.0, 1.0)] * 3),
    length=st.floats(0.01, 10.0),
)
def test_the_compiled_travel_term_is_the_formula_bit_for_bit(w, r, t, length):
    """:func:`travel_term` (what the single env's hook and the batched steps compute) gives
    ``-w sum_i |r_i - t_i| / L`` as Python evaluates it, bit for bit, and
    :func:`travel_rows` adds it to each row's reward after the other terms."""
    want = -w * sum(abs(a - b) for a, b in zip(r, t, strict=True)) / length
    got = travel_term(w, *r, *t, length)
    assert (got, math.copysign(1.0, got)) == (want, math.copysign(1.0, want))  # (-0.0 too)
    states = np.zeros((23, 2))
    states[0:3, 1] = r
    res = np.zeros((3, 2))
    res[0] = [0.25, 0.5]
    target = np.zeros((4, 3))
    target[3] = t
    out = np.zeros(2)
    travel_rows(np.array([0, 3]), states, res, w, target, length, out)
    assert out[1] == got and res[0, 1] == 0.5 + got
    assert out[0] == travel_term(w, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, length)
