"""``travel_goal=True``: the goal in joint space appended to the reach observation, and the
benchmark playing a model trained with it in an environment that has it."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

from planar3p_agents.policies.play_envs import PlayEnvs, observation_kwargs
from planar3p_gym.envs.core import Planar3PEnv
from planar3p_gym.machine import kinematics
from planar3p_gym.tasks.observation import FINE_ERROR_SCALE, OBS_SIZE, TRAVEL_GOAL_SIZE


def _tail_expected(env, obs):
    """The joint-space block recomputed from the episode's target and the observed travels."""
    base = env.unwrapped
    target_rho = kinematics.inverse(base.design, base.target, base.working_mode).rho
    fine = np.tanh((target_rho - obs[:3].astype(np.float64)) / FINE_ERROR_SCALE)
    return np.concatenate([target_rho, fine]).astype(np.float32)


@pytest.mark.parametrize("env_id", ["Planar3P-v0", "Planar3P-v0"])
@pytest.mark.parametrize("seed", [0, 3])
def test_observation_is_the_plain_one_plus_the_joint_space_goal(env_id, seed):
    """Same seed, same actions: the first 31 entries are the plain environment's, bit for bit
    (the fused step of v1 and the general step of v0); the last six are the target's travels
    and ``tanh`` of the travel errors over 1 cm.  Rewards and flags are unchanged."""
    plain = gym.make(env_id)
    goal = gym.make(env_id, travel_goal=True)
    assert goal.observation_space.shape == (OBS_SIZE + TRAVEL_GOAL_SIZE,)
    assert goal.observation_space.contains(goal.reset(seed=seed)[0])
    o_plain, _ = plain.reset(seed=seed)
    o_goal, _ = goal.reset(seed=seed)
    actions = np.random.default_rng(seed).uniform(-1, 1, (60, 3)).astype(np.float32)
    for k, a in enumerate([None, *actions]):
        if a is not None:
            o_plain, r_p, te_p, tr_p, _ = plain.step(a)
            o_goal, r_g, te_g, tr_g, _ = goal.step(a)
            assert (r_p, te_p, tr_p) == (r_g, te_g, tr_g)
        np.testing.assert_array_equal(o_goal[:OBS_SIZE], o_plain)
        np.testing.assert_array_equal(o_goal[OBS_SIZE:], _tail_expected(goal, o_goal))
        assert goal.observation_space.contains(o_goal), k
        if a is not None and (te_p or tr_p):
            break


@pytest.mark.parametrize("mode", [(1, 1, -1), (1, -1, 1), (-1, 1, 1)])
def test_target_travels_close_the_loop_at_the_target_in_the_episode_mode(mode):
    """The observed target travels put the platform at the target pose: loop residual zero
    to float32 rounding of the travels (1e-7 m on travels below 1 m, times a leg's
    sensitivity of at most a few), in the episode's working mode."""
    env = gym.make("Planar3P-v0", travel_goal=True, working_mode=mode)
    obs, info = env.reset(seed=11)
    target = info["episode_spec"]["target"]
    target_rho = obs[OBS_SIZE : OBS_SIZE + 3].astype(np.float64)
    assert np.abs(kinematics.loop_residual(env.unwrapped.design, target, target_rho)).max() < 1e-6
    assert tuple(kinematics.working_mode(env.unwrapped.design, target, target_rho)) == mode


def test_fine_travel_error_vanishes_at_the_target():
    """Started at the target itself (``reset(options=...)``), the travels are the target's:
    the fine travel error is zero to float32 rounding of the travels over 1 cm (1e-5)."""
    env = gym.make("Planar3P-v0", travel_goal=True)
    _, info = env.reset(seed=2)
    start = info["episode_spec"]["start"]
    obs, _ = env.reset(seed=2, options={"start": start, "target": start})
    assert np.abs(obs[OBS_SIZE + 3 :]).max() < 1e-5
    np.testing.assert_allclose(obs[OBS_SIZE : OBS_SIZE + 3], obs[:3], atol=1e-6)


@pytest.mark.parametrize(
    ("env_id", "value", "match"),
    [
        ("Planar3P-v0", "yes", "travel_goal must be True or False"),
        ("Planar3P-v0", 1, "travel_goal must be True or False"),
        ("Planar3PModeChange-v0", True, "reach task"),
        ("Planar3PTrack-v0", True, "reach task"),
    ],
)
def test_bad_travel_goal_is_rejected(env_id, value, match):
    with pytest.raises(ValueError, match=match):
        gym.make(env_id, travel_goal=value)


def test_native_vector_env_gives_the_single_envs_joint_space_goal():
    """Both batch modes: the appended block of every env equals its single env's."""
    for batch in ("scalar", "numpy"):
        venv = gym.make_vec("Planar3P-v0", num_envs=3, batch=batch, travel_goal=True)
        assert venv.observation_space.shape == (3, OBS_SIZE + TRAVEL_GOAL_SIZE)
        obs, _ = venv.reset(seed=4)
        for _ in range(5):
            obs, *_ = venv.step(np.full((3, 3), 0.5, dtype=np.float32))
        for i, env in enumerate(venv.envs):
            np.testing.assert_array_equal(obs[i], env.episode.obs)
            np.testing.assert_array_equal(obs[i, OBS_SIZE:], _tail_expected(env, obs[i]))
        venv.close()


# ------------------------------------------------------------------ playing such a model
def test_play_envs_make_one_variant_per_observation_argument():
    base = gym.make("Planar3P-v0")
    envs = PlayEnvs()
    assert observation_kwargs({"task_config": {}, "travel_goal": True}) == {"travel_goal": True}
    assert observation_kwargs(None) == {}
    assert envs.get(base, None) is base
    assert envs.get(base, {"task_config": {"position_tolerance": 0.001}}) is base
    variant = envs.get(base, {"travel_goal": True})
    assert variant is envs.get(base, {"travel_goal": True, "seed": 1})
    assert variant.unwrapped.travel_goal and variant.spec.id == "Planar3P-v0"
    assert variant.unwrapped.projection  # the registration's own arguments are kept
    assert envs.get(variant, {"travel_goal": True}) is variant
    assert envs.get(variant, {"travel_goal": False}).observation_space.shape == (OBS_SIZE,)
    envs.close()
    with pytest.raises(ValueError, match="not made by gym"):
        PlayEnvs().get(Planar3PEnv(), {"travel_goal": True})


def test_benchmark_plays_a_travel_goal_model_in_an_env_that_has_it(tmp_path, bench, capsys):
    """A model trained with ``travel_goal=True`` (recorded in its run's ``config.json``)
    loads and plays next to the analytic controller; the summary records its arguments."""
    from stable_baselines3 import PPO

    run = tmp_path / "run"
    run.mkdir()
    model = PPO(
        "MlpPolicy", gym.make("Planar3P-v0", travel_goal=True), n_steps=32, batch_size=32, seed=0
    )
    model.save(run / "model.zip")
    kwargs = {"travel_goal": True, "task_config": {"position_tolerance": 0.001}}
    (run / "config.json").write_text(json.dumps({"config": {"env_kwargs": kwargs}}))
    out = tmp_path / "bench"
    args = [
        "--policies",
        f"analytic-simultaneous,ppo:{run / 'model.zip'}:stats=none",
        "--suites",
        "standard",
        "--episodes",
        "1",
        "--out",
        str(out),
        "--no-progress",
        "--no-plots",
    ]
    assert bench.main(args) == 0
    captured = capsys.readouterr()
    assert "with the model's interface arguments {'travel_goal': True}" in captured.err
    assert "| run/model | standard | 1 |" in captured.out
    summary = json.loads((out / "summary.json").read_text())
    assert summary["settings"]["policy_env_kwargs"]["run/model"] == kwargs
    assert summary["settings"]["env"]["travel_goal"] is False  # the suite's own environment


def test_a_travel_goal_model_in_a_plain_env_is_refused_with_the_fix(tmp_path):
    """Loaded against an environment without ``travel_goal``, the model is refused and the
    message names the argument it was trained with."""
    from stable_baselines3 import PPO

    from planar3p_agents.policies.factory import PolicyError, load_policy

    env = gym.make("Planar3P-v0", travel_goal=True)
    PPO("MlpPolicy", env, n_steps=32, batch_size=32, seed=0).save(tmp_path / "model.zip")
    kwargs = {"travel_goal": True}
    (tmp_path / "config.json").write_text(json.dumps({"config": {"env_kwargs": kwargs}}))
    with pytest.raises(PolicyError, match=r"trained with \{'travel_goal': True\}"):
        load_policy(f"ppo:{tmp_path / 'model.zip'}:stats=none", env=gym.make("Planar3P-v0"))
    assert load_policy(f"ppo:{tmp_path / 'model.zip'}:stats=none", env=env).env_kwargs == kwargs


def test_library_benchmark_makes_and_closes_its_own_play_envs(tmp_path):
    """Called as a library without ``play_envs``, loading and playing each make the variant
    they need (and close it): the travel-goal model plays its episode."""
    from stable_baselines3 import PPO

    from planar3p_agents.evaluation import benchmark as bm

    model = PPO("MlpPolicy", gym.make("Planar3P-v0", travel_goal=True), n_steps=32, seed=0)
    model.save(tmp_path / "model.zip")
    (tmp_path / "config.json").write_text(
        json.dumps({"config": {"env_kwargs": {"travel_goal": True}}})
    )
    env = gym.make("Planar3P-v0")
    envs = {"standard": env}
    per_suite, _ = bm.load_suite_policies(
        [f"ppo:{tmp_path / 'model.zip'}:stats=none"], ["standard"], envs, warn=lambda _t: None
    )
    suites = bm.build_suites(["standard"], 1, 0, env.unwrapped.design, envs=envs)
    run = bm.run_benchmark(
        env, {}, suites, tmp_path / "out", settings={"command": "test"}, plots=False,
        envs=envs, suite_policies=per_suite,
    )  # fmt: skip
    assert run.status == 0 and len(run.results) == 1
