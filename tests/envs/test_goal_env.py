"""Tests of the goal-conditioned reach (``Planar3PGoal-v0``, ``Planar3PGoalDense-v0``): API
conformance, exact relabelling, replay from episode specs, input validation, HER training."""

from __future__ import annotations

import json
import warnings

import gymnasium as gym
import numpy as np
import pytest

import planar3p_gym
from planar3p_agents.policies.factory import load_policy
from planar3p_gym.envs.goal import ROBOT_INDEX, flat_observation
from planar3p_gym.tasks.goal import goal_of_pose, pose_of_goal, poses_of_goals
from planar3p_gym.tasks.observation import OBS_SIZE, SLICES

IDS = (planar3p_gym.GOAL_ENV_ID, planar3p_gym.GOAL_DENSE_ENV_ID)


def analytic_episode(env: gym.Env, seed: int | None = None, options=None):
    """Run the analytic controller (through the goal adapter) to the end of an episode:
    ``(actions, [(obs, reward, terminated, truncated, info)])``."""
    obs, _ = env.reset(seed=seed, options=options)
    ctrl = load_policy("analytic-simultaneous", env)
    actions, steps = [], []
    while True:
        a, _ = ctrl.predict(obs)
        obs, reward, terminated, truncated, info = env.step(a)
        actions.append(a)
        steps.append((obs, reward, terminated, truncated, info))
        if terminated or truncated:
            return actions, steps


@pytest.mark.parametrize("env_id", IDS)
def test_check_env_gymnasium_and_sb3(env_id):
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = gym.make(env_id)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check_env(env.unwrapped, skip_render_check=True)
        sb3_check_env(env.unwrapped, warn=False)


def test_observe_working_mode_adds_the_mode_and_changes_nothing_else():
    """``observe_working_mode=True`` adds ``working_mode``, the signs of ``cos alpha_i``, equal
    to the kinematics' working mode of every state of an episode (the episode's mode: it never
    changes along a reach); every other entry, the reward and the episode are unchanged; the
    env still passes Gymnasium's and SB3's checks; a non-bool is refused."""
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    from planar3p_gym.machine.kinematics import working_mode

    plain = gym.make(IDS[0])
    seen = gym.make(IDS[0], observe_working_mode=True)
    assert "working_mode" not in plain.observation_space.spaces
    a, _ = plain.reset(seed=11)
    b, info = seen.reset(seed=11)
    episode_mode = tuple(info["episode_spec"]["working_mode"])
    rng = np.random.default_rng(2)
    for _ in range(25):
        assert set(b) == set(a) | {"working_mode"}
        for key in a:
            assert np.array_equal(a[key], b[key])
        assert seen.observation_space.contains(b)
        mode = working_mode(seen.unwrapped.design, info["pose"], info["rho"])
        assert np.array_equal(b["working_mode"], mode.astype(np.float32))
        assert tuple(mode) == episode_mode
        action = rng.uniform(-1.0, 1.0, 3)
        a, ra, ta, ua, _ = plain.step(action)
        b, rb, tb, ub, info = seen.step(action)
        assert (ra, ta, ua) == (rb, tb, ub)
        if ta or ua:
            break
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check_env(seen.unwrapped, skip_render_check=True)
        sb3_check_env(seen.unwrapped, warn=False)
    with pytest.raises(ValueError, match="observe_working_mode must be True or False"):
        gym.make(IDS[0], observe_working_mode="yes")


def test_observation_has_no_goal():
    """The ``observation`` entry is the robot blocks of the flat observation: the same start
    with two different goals gives the same ``observation``, different ``desired_goal``."""
    env = gym.make(IDS[0])
    obs, info = env.reset(seed=3)
    spec = info["episode_spec"]
    other = env.reset(seed=4)[1]["episode_spec"]
    obs2, info2 = env.reset(options={"start": spec["start"], "target": other["target"]})
    assert info2["episode_spec"]["target"] == other["target"]
    assert np.array_equal(obs["observation"], obs2["observation"])
    assert np.array_equal(obs["achieved_goal"], obs2["achieved_goal"])
    assert not np.array_equal(obs["desired_goal"], obs2["desired_goal"])
    assert ROBOT_INDEX.size == obs["observation"].size == 21
    assert obs["achieved_goal"][4] == 0.0 == obs["desired_goal"][4]  # starts at rest
    for name in ("target_position", "target_orientation", "position_error", "fine_error"):
        assert not set(range(OBS_SIZE)[SLICES[name]]) & set(ROBOT_INDEX.tolist())


@pytest.mark.parametrize("env_id", IDS)
def test_reward_equals_compute_reward_single_and_batched(env_id):
    env = gym.make(env_id)
    _, steps = analytic_episode(env, seed=1)
    assert steps[-1][4]["termination_reason"] == "success"
    u = env.unwrapped
    ach = np.array([s[0]["achieved_goal"] for s in steps])
    des = np.array([s[0]["desired_goal"] for s in steps])
    infos = np.array([s[4] for s in steps], dtype=object)
    batch = u.compute_reward(ach, des, infos)
    assert batch.shape == (len(steps),)
    for i, (obs, reward, terminated, _, info) in enumerate(steps):
        assert reward == u.compute_reward(obs["achieved_goal"], obs["desired_goal"], info)
        assert reward == batch[i]
        assert terminated == u.compute_terminated(obs["achieved_goal"], obs["desired_goal"], info)
        assert u.compute_truncated(obs["achieved_goal"], obs["desired_goal"], info) is False
    if env_id == IDS[0]:
        assert [s[1] for s in steps] == [-1.0] * (len(steps) - 1) + [0.0]


def test_compiled_goal_errors_and_success_match_numpy_formulas():
    """The compiled goal test (:func:`planar3p_gym.tasks.goal.goal_test`, which the step and
    the batched API share) against the module docstring's formulas in numpy: errors to a few
    ulps (libm's and numpy's ``atan2`` may differ in the last bit), success exactly (no pair
    lies within 1e-9 of a tolerance)."""
    from planar3p_gym.tasks.goal import goal_errors, goal_success
    from planar3p_gym.tasks.sampling import TaskConfig

    rng = np.random.default_rng(0)
    n = 400
    d = np.column_stack([rng.uniform(-0.3, 0.3, (n, 2)), np.zeros((n, 3))])
    th = rng.uniform(-np.pi, np.pi, n)
    d[:, 2], d[:, 3] = np.cos(th), np.sin(th)
    a = d.copy()
    a[:, :2] += rng.normal(0.0, 0.002, (n, 2))
    dth = rng.normal(0.0, 0.02, n)
    a[:, 2], a[:, 3] = np.cos(th - dth), np.sin(th - dth)
    a[:, 4] = rng.uniform(0.0, 0.02, n)
    pos, ang = goal_errors(a, d)
    ref_pos = np.hypot(d[:, 0] - a[:, 0], d[:, 1] - a[:, 1])
    ref_ang = np.arctan2(
        a[:, 2] * d[:, 3] - a[:, 3] * d[:, 2], a[:, 2] * d[:, 2] + a[:, 3] * d[:, 3]
    )
    np.testing.assert_allclose(pos, ref_pos, rtol=4e-16, atol=0.0)
    np.testing.assert_allclose(ang, ref_ang, rtol=4e-16, atol=1e-18)
    np.testing.assert_allclose(ang, dth, rtol=1e-9, atol=1e-12)  # the signed angle d - a
    cfg = TaskConfig()
    tol_p, tol_a, rest = cfg.success_tolerances
    for margin in (
        np.abs(ref_pos - tol_p),
        np.abs(np.abs(ref_ang) - tol_a),
        np.abs(a[:, 4] - rest),
    ):
        assert margin.min() > 1e-9
    expected = (ref_pos <= tol_p) & (np.abs(ref_ang) <= tol_a) & (a[:, 4] <= rest)
    assert 0 < expected.sum() < n
    np.testing.assert_array_equal(goal_success(a, d, None, cfg), expected)
    failed = [{"failure": bool(i % 2)} for i in range(n)]
    np.testing.assert_array_equal(
        goal_success(a, d, failed, cfg), expected & (np.arange(n) % 2 == 0)
    )


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("relabel_at", [0.5, 1.0])
def test_relabelled_rewards_match_a_replay_with_that_goal(env_id, relabel_at):
    """Hindsight relabelling is exact: the rewards ``compute_reward`` gives for a relabelled
    goal (an achieved goal of the episode) are bit-identical to those the environment returns
    when the same actions are replayed with that goal as the episode's goal, and the replay
    ends where ``compute_terminated`` says."""
    env = gym.make(env_id)
    u = env.unwrapped
    actions, steps = analytic_episode(env, seed=2)
    spec = env.unwrapped.episode_spec
    k = int(relabel_at * (len(steps) - 1))
    new_goal = steps[k][0]["achieved_goal"]
    relabelled = [u.compute_reward(s[0]["achieved_goal"], new_goal, s[4]) for s in steps]
    ends = [u.compute_terminated(s[0]["achieved_goal"], new_goal, s[4]) for s in steps]
    obs, _ = env.reset(
        options={
            "start": spec["start"],
            "working_mode": spec["working_mode"],
            "desired_goal": new_goal,
        }
    )
    assert np.array_equal(obs["desired_goal"], new_goal)
    for t, a in enumerate(actions):
        obs, reward, terminated, _, info = env.step(a)
        assert np.array_equal(obs["achieved_goal"], steps[t][0]["achieved_goal"])
        assert reward == relabelled[t]
        assert terminated == ends[t]
        if terminated:
            break
    if relabel_at == 1.0:
        assert info["is_success"]  # the last achieved goal was reached at rest


@pytest.mark.parametrize("env_id", IDS)
def test_many_resets_never_raise(env_id):
    env = gym.make(env_id, working_mode="random")
    env.reset(seed=0)
    for _ in range(150):
        obs, info = env.reset()
        assert env.observation_space.contains(obs)
        assert info["episode_spec"]["task"] == "goal"


def test_compute_reward_rejects_bad_input():
    env = gym.make(IDS[0])
    obs, _ = env.reset(seed=0)
    _, _, _, _, info = env.step(np.zeros(3, np.float32))
    u = env.unwrapped
    g = obs["achieved_goal"]
    for bad in (g[:4], np.zeros((2, 4)), np.zeros((2, 2, 5)), "abc", [np.nan, 0, 1, 0, 0]):
        with pytest.raises(ValueError):
            u.compute_reward(bad, g, info)
        with pytest.raises(ValueError):
            u.compute_terminated(g, bad, info)
    with pytest.raises(ValueError, match="same shape"):
        u.compute_reward(np.zeros((2, 5)), np.zeros((3, 5)), info)
    with pytest.raises(ValueError, match="info"):
        u.compute_reward(np.zeros((3, 5)), np.zeros((3, 5)), [info, info])
    with pytest.raises(ValueError, match="info"):
        u.compute_reward(g, g, 3.0)
    with pytest.raises(ValueError, match="number"):
        u.compute_reward(g, g, {"goal_free_reward": "x"})


def test_empty_infos_keep_the_goal_part_exact():
    """SB3's HER passes empty info dicts by default: the goal-dependent reward (everything in
    the sparse env until a failure) is still exact."""
    env = gym.make(IDS[0])
    _, steps = analytic_episode(env, seed=4)
    u = env.unwrapped
    ach = np.array([s[0]["achieved_goal"] for s in steps])
    des = np.array([s[0]["desired_goal"] for s in steps])
    rewards = np.array([s[1] for s in steps])
    assert np.array_equal(u.compute_reward(ach, des, [{} for _ in steps]), rewards)
    assert np.array_equal(u.compute_reward(ach, des, None), rewards)


def test_reset_rejects_bad_goals():
    env = gym.make(IDS[0])
    env.reset(seed=0)
    with pytest.raises(ValueError, match="desired_goal"):
        env.reset(options={"desired_goal": [0.1, 0.1, 1.0, 0.0]})
    with pytest.raises(ValueError, match="unit circle"):
        env.reset(options={"desired_goal": [0.1, 0.1, 0.0, 0.0, 0.0]})
    with pytest.raises(ValueError, match="speed"):
        env.reset(options={"desired_goal": [0.1, 0.1, 1.0, 0.0, -1.0]})
    with pytest.raises(ValueError, match="not reachable"):
        env.reset(options={"desired_goal": [5.0, 5.0, 1.0, 0.0, 0.0]})
    with pytest.raises(ValueError, match="task"):
        env.reset(options={"task": "reach"})
    with pytest.raises(ValueError):
        gym.make(IDS[0], reward_type="shaped")


def test_goal_pose_round_trip():
    pose = (0.1, 0.2, -2.5)
    back = pose_of_goal(goal_of_pose(pose))
    assert back[:2] == pytest.approx(pose[:2], abs=1e-7)
    assert back[2] == pytest.approx(pose[2], abs=1e-6)


def test_batched_poses_of_goals_are_the_scalar_ones():
    """:func:`poses_of_goals` is :func:`pose_of_goal` row by row (angles all around the circle,
    4- and 5-entry goals), and refuses what is not a batch of goals."""
    rng = np.random.default_rng(4)
    poses = np.column_stack([rng.uniform(-0.3, 0.3, (50, 2)), rng.uniform(-np.pi, np.pi, 50)])
    goals = np.stack([goal_of_pose(p) for p in poses])
    batched = poses_of_goals(goals)
    for g, row in zip(goals, batched, strict=True):
        np.testing.assert_allclose(row, pose_of_goal(g), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(poses_of_goals(goals[:, :4]), batched)
    for bad in (goals[0], goals[:, :3], goals[None]):
        with pytest.raises(ValueError, match="goals must have shape"):
            poses_of_goals(bad)


def test_flat_observation_matches_the_flat_env():
    """The adapter's rebuilt observation matches ``Planar3P-v0``'s on the same episode (to
    float32 rounding of the inputs), so the analytic controller acts the same on both."""
    flat_env = gym.make("Planar3P-v0")
    goal_env = gym.make(IDS[0])
    f_obs, info = flat_env.reset(seed=5)
    spec = {k: info["episode_spec"][k] for k in ("start", "target", "working_mode")}
    g_obs, _ = goal_env.reset(options=spec)
    length = goal_env.unwrapped.design.characteristic_length
    np.testing.assert_allclose(flat_observation(g_obs, length), f_obs, atol=2e-6)


@pytest.mark.parametrize("env_id", IDS)
def test_analytic_controller_through_the_adapter_succeeds(env_id):
    env = gym.make(env_id)
    env.reset(seed=100)
    results = [analytic_episode(env)[1][-1][4]["is_success"] for _ in range(5)]
    assert all(results)


@pytest.mark.parametrize("algo", ["SAC", "TQC"])
def test_her_trains_out_of_the_box(algo):
    """SB3's HerReplayBuffer with SAC and sb3-contrib's TQC run on the goal env unchanged."""
    torch = pytest.importorskip("torch")
    from stable_baselines3 import SAC, HerReplayBuffer

    torch.set_num_threads(1)
    if algo == "TQC":
        cls = pytest.importorskip("sb3_contrib").TQC
    else:
        cls = SAC
    env = gym.make(IDS[0])  # the registered time limit, SB3's default learning_starts
    # SAC with SB3's defaults (empty infos), TQC with the infos copied (exact penalties).
    buffer_kwargs = {"n_sampled_goal": 4, "goal_selection_strategy": "future"}
    if algo == "TQC":
        buffer_kwargs["copy_info_dict"] = True
    # buffer_size: room for the 300 steps learned; SB3's default of 10**6 transitions only
    # costs seconds of allocation here (it is a training setting, not the env's interface).
    model = cls(
        "MultiInputPolicy",
        env,
        buffer_size=1_000,
        replay_buffer_class=HerReplayBuffer,
        replay_buffer_kwargs=buffer_kwargs,
        batch_size=32,
        policy_kwargs={"net_arch": [32, 32]},
        seed=0,
        device="cpu",
    )
    model.learn(300)
    assert model.num_timesteps == 300
    obs, _ = env.reset(seed=0)
    action, _ = model.predict(obs, deterministic=True)
    assert env.action_space.contains(action)


def test_spec_of_a_requested_goal_vector_replays_it():
    env = gym.make(IDS[1])
    obs, info = env.reset(seed=6)
    goal = obs["achieved_goal"]  # the start pose as a goal, at rest
    spec = info["episode_spec"]
    opts = {"start": spec["start"], "working_mode": spec["working_mode"], "desired_goal": goal}
    obs1, info1 = env.reset(options=opts)
    replay = json.loads(json.dumps(info1["episode_spec"]))
    assert replay["desired_goal"] == [float(v) for v in goal]
    obs2, _ = env.reset(options=replay)
    assert np.array_equal(obs2["desired_goal"], goal)
    assert all(np.array_equal(obs1[k], obs2[k]) for k in obs1)
    with pytest.raises(ValueError, match="disagrees"):
        env.reset(options={**replay, "target": [0.0, 0.1, 0.0]})
