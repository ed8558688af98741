"""The one policy factory (:func:`planar3p_agents.policies.factory.load_policy`) and the baseline
registry (:mod:`planar3p_agents.controllers.registry`): every built-in baseline plays every
registered id it lists, is refused on the others with both names, and does what the entry
points it replaced did."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import planar3p_gym
from planar3p_agents.controllers.goal_adapter import GoalAdapter
from planar3p_agents.controllers.layout import (
    REGISTERED_IDS,
    TASK_EXTRA_FIELDS,
    env_id_of,
    observation_layout,
)
from planar3p_agents.controllers.registry import (
    ANALYTIC_POLICIES,
    BASELINES,
    ON_OFF_IDS,
    baselines_for,
)
from planar3p_agents.evaluation.task_suites import TASK_SUITES
from planar3p_agents.policies.factory import PolicyError, load_policy
from planar3p_agents.policies.spec import BUILTIN_POLICIES, parse_policy_spec
from planar3p_gym.envs.registry import ENV_SPECS
from tooling.goal_track_baselines import TRACKING_BASELINES
from tooling.task_baselines import STUDY_POLICIES

#: (specification, id) of every baseline on every id it lists, and of each analytic
#: controller with a retuned gain.
SUPPORTED = [(name, env_id) for name, b in BASELINES.items() for env_id in b.ids] + [
    (f"{name}:gain=12", env_id) for name in ANALYTIC_POLICIES for env_id in BASELINES[name].ids
]
UNSUPPORTED = [
    (name, env_id)
    for name, b in BASELINES.items()
    for env_id in REGISTERED_IDS
    if env_id not in b.ids
]

#: Time limit (control steps) of the short episodes of the every-pair test.
SHORT = 60

_ENVS: dict[tuple[str, int | None], gym.Env] = {}


def _env(env_id: str, steps: int | None = None) -> gym.Env:
    """One environment per id (and time limit, ``None``: the id's) for the whole module
    (making the task envs costs time)."""
    key = (env_id, steps)
    if key not in _ENVS:
        _ENVS[key] = gym.make(env_id, **({} if steps is None else {"max_episode_steps": steps}))
    return _ENVS[key]


@pytest.fixture(scope="module", autouse=True)
def _close_envs():
    yield
    for env in _ENVS.values():
        env.close()
    _ENVS.clear()


def play(env: gym.Env, policy, seed: int) -> dict:
    """One episode from ``reset(seed=seed)`` with SB3's calling convention (``episode_start``
    on the first step, the returned state passed back), every action checked against the
    action space; the last ``info`` with the number of steps."""
    obs, _ = env.reset(seed=seed)
    if callable(getattr(policy, "reset", None)):
        policy.reset()
    state, start, steps = None, True, 0
    while True:
        action, state = policy.predict(obs, state=state, episode_start=np.array([start]))
        start = False
        assert env.action_space.contains(np.asarray(action, dtype=env.action_space.dtype)), action
        obs, _, terminated, truncated, info = env.step(action)
        steps += 1
        if terminated or truncated:
            return {**info, "steps": steps}


# ---------------------------------------------------------------------- the registry as data
def test_registry_is_the_one_list_of_names():
    """The policy specifications know exactly the registry's names; every id has the analytic
    controllers and the floor policies; every task's own baseline lists only its id."""
    assert list(BUILTIN_POLICIES) == list(BASELINES)
    assert set(REGISTERED_IDS) == {row.id for row in ENV_SPECS}
    for name, b in BASELINES.items():
        assert b.name == name and b.description and "\n" not in b.description
        assert b.ids and set(b.ids) <= set(REGISTERED_IDS)
        assert parse_policy_spec(name).kind == "builtin"
    for env_id in REGISTERED_IDS:
        analytic = (
            {"analytic-on-off"}
            if env_id in ON_OFF_IDS
            else {"analytic-simultaneous", "analytic-sequential"}
        )
        assert analytic | {"random", "zero"} <= set(baselines_for(env_id))
    assert ON_OFF_IDS == (planar3p_gym.REAL_ON_OFF_ENV_ID,)
    assert BASELINES["planner"].ids == (planar3p_gym.MODE_CHANGE_ENV_ID,)
    assert BASELINES["crossing"].ids == (planar3p_gym.ASSEMBLY_CHANGE_ENV_ID,)
    assert BASELINES["analytic-feedforward"].ids == (planar3p_gym.TRACK_ENV_ID,)


def test_suites_and_studies_name_registry_baselines_of_their_ids():
    for suite, d in TASK_SUITES.items():
        for name in d.baselines:
            assert d.env_id in BASELINES[name].ids, (suite, name)
    for env_id, names in STUDY_POLICIES.items():
        assert all(env_id in BASELINES[n].ids for n in names), env_id
    assert all(planar3p_gym.TRACK_ENV_ID in BASELINES[n].ids for n in TRACKING_BASELINES.values())


def test_observation_layouts_match_the_envs():
    """The layout of every id (and of ``travel_goal=True``) has the env's observation length,
    and an env made by its constructor (no spec) is recognised by its task."""
    for env_id in REGISTERED_IDS:
        env = _env(env_id)
        layout = observation_layout(env)
        assert layout.env_id == env_id
        if isinstance(env.observation_space, gym.spaces.Dict):
            assert layout.goal and layout.size == 31
        else:
            assert env.observation_space.shape == (layout.size,)
            assert layout.names == tuple(
                n for n, _, _ in TASK_EXTRA_FIELDS[env.unwrapped.task.name]
            )
    travel = gym.make(planar3p_gym.ENV_ID, travel_goal=True)
    assert observation_layout(travel).size == travel.observation_space.shape[0] == 37
    from planar3p_gym.envs.goal import Planar3PGoalEnv
    from planar3p_gym.envs.mode_change import Planar3PModeChangeEnv

    assert env_id_of(Planar3PModeChangeEnv()) == planar3p_gym.MODE_CHANGE_ENV_ID
    assert env_id_of(Planar3PGoalEnv(reward_type="dense")) == planar3p_gym.GOAL_DENSE_ENV_ID
    with pytest.raises(ValueError, match="not an environment of planar3p_gym"):
        observation_layout(gym.make("CartPole-v1"))


# ---------------------------------------------------------------------- every supported pair
@pytest.mark.parametrize(("spec", "env_id"), SUPPORTED)
def test_baseline_plays_every_id_it_supports(spec, env_id):
    """Two seeded episodes (of at most :data:`SHORT` steps), every action in the action space
    (a goal id gets the goal adapter; a retuned gain reaches the controller)."""
    env = _env(env_id, SHORT)
    policy = load_policy(spec, env, seed=3)
    assert isinstance(policy, GoalAdapter) == isinstance(env.observation_space, gym.spaces.Dict)
    if ":gain=" in spec:
        inner = policy.policy if isinstance(policy, GoalAdapter) else policy
        inner = getattr(inner, "inner", inner)  # the on-off controller's analytic one
        if hasattr(inner, "position_gain"):  # the analytic controllers
            assert inner.position_gain == inner.orientation_gain == 12.0
        else:  # the slider line: its travel gain
            assert inner.gain == 12.0
    for seed in (1, 2):
        info = play(env, policy, seed)
        assert 1 <= info["steps"] <= SHORT


def test_analytic_on_the_37_entry_mode_change_observation():
    """The reported failure: ``load_policy("analytic-simultaneous", env=ModeChange)`` refused
    the 37-entry observation.  It now acts on single observations and batches of it, as the
    plain controller acts on their first 31 entries (the entries it reads)."""
    env = gym.make(planar3p_gym.MODE_CHANGE_ENV_ID)
    policy = load_policy("analytic-simultaneous", env=env)
    obs, _ = env.reset(seed=5)
    assert obs.shape == (37,)
    action, _ = policy.predict(obs)
    assert action.shape == (3,) and env.action_space.contains(action)
    plain = load_policy("analytic-simultaneous")  # Planar3P-v0's 31 entries
    np.testing.assert_array_equal(action, plain.predict(obs[:31])[0])
    batch, _ = policy.predict(np.stack([obs, obs]))
    np.testing.assert_array_equal(batch, np.stack([action, action]))
    with pytest.raises(ValueError, match="shape"):
        policy.predict(obs[:31])  # the id's observation, not another's
    env.close()


@pytest.mark.parametrize(("name", "env_id"), UNSUPPORTED)
def test_unsupported_pairs_are_refused_with_both_names(name, env_id):
    with pytest.raises(ValueError) as err:
        load_policy(name, _env(env_id))
    message = str(err.value)
    assert name in message and env_id in message
    assert all(i in message for i in BASELINES[name].ids)


def test_without_an_env_a_baseline_is_built_for_planar3p_v0():
    assert load_policy("analytic-sequential:gain=3").mode == "sequential"
    with pytest.raises(PolicyError, match=r"'crossing' does not apply to Planar3P-v0 \(no env"):
        load_policy("crossing")


# ---------------------------------------------------------------------- same as before
#: Outcomes of the factory's policies per seeded episode, played with :func:`play` on
#: ``gym.make(id)`` from ``reset(seed=s)``.  Per seed: ``(success, termination reason,
#: steps)``; tracking: ``(tracking_rms_error in mm, steps)``.  When the factory replaced the
#: old entry points (``studies.task_baselines.make_baseline``, ``evaluation.task_suites.
#: task_baseline``; main's 0b74451), its policies reproduced their action sequences bit for
#: bit on these seeds and these outcomes were theirs; the seeded episodes changed with the
#: sampler's proposal region (tasks/pose_proposal.py), and the outcomes were recorded again
#: from the same policies.
BEFORE: dict[tuple[str, str], dict[int, tuple]] = {
    ("analytic-simultaneous", planar3p_gym.GOAL_ENV_ID): {
        1: (True, "success", 44),
        2: (True, "success", 34),
    },
    ("analytic-simultaneous", planar3p_gym.GOAL_DENSE_ENV_ID): {
        1: (True, "success", 44),
        2: (True, "success", 34),
    },
    ("analytic-simultaneous", planar3p_gym.MODE_CHANGE_ENV_ID): {
        1: (True, "success", 286),
        2: (False, None, 400),  # the simple motions stop short of the serial singularity
    },
    ("planner", planar3p_gym.MODE_CHANGE_ENV_ID): {
        1: (True, "success", 57),
        2: (True, "success", 106),
    },
    ("analytic-simultaneous", planar3p_gym.ASSEMBLY_CHANGE_ENV_ID): {
        1: (True, "success", 87),
        2: (True, "success", 61),
    },
    ("crossing", planar3p_gym.ASSEMBLY_CHANGE_ENV_ID): {
        1: (True, "success", 234),
        2: (True, "success", 135),
    },
    ("analytic-simultaneous", planar3p_gym.TRACK_ENV_ID): {
        1: (13.918, 500),
        2: (18.504, 500),
    },
    ("analytic-feedforward", planar3p_gym.TRACK_ENV_ID): {
        1: (0.080, 500),
        2: (0.309, 500),
    },
}


@pytest.mark.parametrize(("name", "env_id"), list(BEFORE))
def test_same_outcomes_as_the_replaced_entry_points(name, env_id):
    """Success (and termination reason) per seeded episode as recorded; tracking, which has
    no success test, runs to its time limit with the same RMS error (within 5 %)."""
    env = _env(env_id)
    policy = load_policy(name, env)
    for seed, expected in BEFORE[(name, env_id)].items():
        info = play(env, policy, seed)
        if env_id == planar3p_gym.TRACK_ENV_ID:
            rms_mm, steps = expected
            assert info["termination_reason"] is None and info["steps"] == steps
            assert math.isclose(1000 * info["tracking_rms_error"], rms_mm, rel_tol=0.05), seed
        else:
            success, reason, _ = expected
            assert (info["is_success"], info["termination_reason"]) == (success, reason), seed


# ---------------------------------------------------------------------- models
def test_a_model_is_checked_against_the_env_it_is_to_play(tmp_path, monkeypatch):
    """A model path goes to the SB3 loader with the environment to match (its spaces; a model
    that does not fit the id is refused there: tests/agents/policies/test_goal_policies.py,
    tests/tasks/test_travel_goal.py), on every id alike."""
    from planar3p_agents.policies import factory

    seen = []
    monkeypatch.setattr(factory, "load_sb3_model", lambda *a, **k: seen.append(k) or "model")
    (tmp_path / "m.zip").write_bytes(b"")
    for env_id in REGISTERED_IDS:
        env = _env(env_id)
        assert load_policy(f"ppo:{tmp_path / 'm.zip'}:stats=none", env) == "model"
        assert seen[-1]["check_env"] is env
