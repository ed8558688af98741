"""Resets that never fail on valid settings, and bad input rejected with ValueError.

Each test reproduces a reported failure (the seeds below hit the former failure paths) and
checks that it now behaves.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import planar3p_gym  # noqa: F401
from planar3p_gym import Design
from planar3p_gym.machine import kinematics
from planar3p_gym.sim.physics import Planar3PSim
from planar3p_gym.tasks import sampling as task
from planar3p_gym.tasks.rewards import MAX_WEIGHT, RewardWeights

ENV_ID = "Planar3P-v0"
CFG = task.TaskConfig()


def _assembly(design: Design, pose: np.ndarray, mode) -> float:
    return float(kinematics.assembly_mode(design, pose, kinematics.inverse(design, pose, mode).rho))


def _check_pair(design: Design, start, target, mode) -> None:
    """A sampled pair meets the task's rules (same assembly mode, far enough apart)."""
    assert _assembly(design, start, mode) == _assembly(design, target, mode)
    dist = task.pose_distance(start, target, design.characteristic_length)
    assert dist >= CFG.min_distance


# ------------------------------------------------------------------ item 1: resets never raise
def test_a_start_in_a_rare_assembly_mode_is_redrawn():
    """Planar3P-v0 raised 'no pose of assembly mode -1 in working mode (1, 1, -1)' about once in
    36k resets (seed 0, reset 7683): a start of the rare assembly mode found no partner in 50
    pool refills.  Force that start to the front of the pool: the sampler now draws another."""
    design, mode = Design.fig8(), (1, 1, -1)
    rare = np.array([0.3485301646947768, 0.1959996218501728, -3.0429443299153456])
    ok, det = task._acceptable(design, rare[None, :], np.asarray(mode, dtype=float), CFG)
    assert ok[0] and det[0] == -1.0  # an acceptable pose, in the rare assembly mode
    sampler = task.PoseSampler(design, mode, CFG)
    rng = np.random.default_rng(0)
    sampler._refill(rng)
    assert all(d == 1.0 for _, d in sampler.pooled())  # no partner for it in the pool
    assert len(sampler.draw_many(np.random.default_rng(1), -1.0, 8)) == 0  # formerly raised
    sampler.push_front(rare, -1.0)
    start, target = task.sample_pair(design, mode, rng, CFG, sampler=sampler)
    assert not np.array_equal(start, rare)
    _check_pair(design, start, target, mode)


@pytest.mark.parametrize(
    ("kwargs", "seed", "resets"),
    [
        # 'no pose of working mode (1, 1, -1) meets the task's margins' was raised where a pool
        # refill found no pose in its 200 batches: at the first reset of seed 26 and at reset
        # 25 of seed 2 (the reproduction), with the random streams before the proposal
        # region (tasks/pose_proposal.py); with today's, at reset 6 of seed 13 and reset 27 of
        # seed 11
        ({"design": "fig7", "working_mode": (1, 1, -1)}, 13, 6),
        ({"design": "fig7", "working_mode": (1, 1, -1)}, 11, 27),
        # ... with working_mode='random', at reset 8 of seed 14
        ({"design": "fig7", "working_mode": "random"}, 14, 9),
    ],
)
def test_reported_fig7_reset_failures_now_succeed(kwargs, seed, resets, monkeypatch):
    env = gym.make(ENV_ID, **kwargs)
    calls = []
    check_mode = task.check_mode
    monkeypatch.setattr(task, "check_mode", lambda *a: calls.append(a) or check_mode(*a))
    _, info = env.reset(seed=seed)
    for _ in range(resets - 1):
        _, info = env.reset()
    u = env.unwrapped
    _check_pair(u.design, np.asarray(info["pose"]), np.asarray(u.target), u.working_mode)
    if kwargs["working_mode"] != "random":  # a failure point of the old code
        assert calls  # a pool refill ran out of its 200 batches and went on drawing


@pytest.mark.parametrize("design", ["fig8", "fig7"])
def test_many_resets_in_every_usable_mode(design):
    """Every usable working mode of both presets resets many times without raising."""
    env = gym.make(ENV_ID, design=design, working_mode="random")
    modes = env.unwrapped.modes
    assert modes  # the presets have usable modes
    resets = 60 if design == "fig8" else 15
    for mode in modes:
        env.reset(seed=3, options={"working_mode": mode})
        for _ in range(resets):
            _, info = env.reset(options={"working_mode": mode})
            assert info["working_mode"] == mode
            assert np.isfinite(info["position_error"])


def test_random_mode_list_of_the_default_design_is_unchanged():
    """Planar3P-v0 with working_mode='random' draws from all eight modes, in order (the list
    feeds the random stream, which the regression hashes pin)."""
    env = gym.make(ENV_ID, working_mode="random")
    assert env.unwrapped.modes == [tuple(m) for m in kinematics.ALL_MODES.tolist()]


def test_a_mode_without_poses_is_rejected_at_construction():
    # (its check finds two acceptable poses, too close together for a pair)
    with pytest.raises(
        ValueError, match=r"working mode \(1, 1, 1\) .* has no (pose|start/target pair)"
    ):
        gym.make(ENV_ID, design="fig7", working_mode=(1, 1, 1))
    # fig7's random list leaves out the four empty modes.
    assert (1, 1, 1) not in gym.make(ENV_ID, design="fig7", working_mode="random").unwrapped.modes


def test_a_mode_without_pairs_is_rejected_at_construction():
    """Poses exist, but no two are min_distance (5 m) apart: rejected at make, not at reset."""
    with pytest.raises(ValueError, match="no start/target pair"):
        gym.make(ENV_ID, task_config={"min_distance": 5.0})
    with pytest.raises(ValueError, match="no start/target pair"):
        far = task.TaskConfig(min_distance=5.0)
        task.sample_pair(Design.fig8(), (1, 1, -1), np.random.default_rng(0), far)


# ------------------------------------------------------------------ item 6: bad input
def test_numpy_scalars_are_accepted_and_booleans_rejected_in_configs():
    env = gym.make(
        ENV_ID,
        reward_weights={"pose": np.float32(2.0), "success": np.int64(5)},
        task_config={"path_points": np.int64(30), "position_tolerance": np.float32(0.003)},
    )
    u = env.unwrapped
    assert u.reward_weights.pose == 2.0 and type(u.reward_weights.pose) is float
    assert u.task_config.path_points == 30 and type(u.task_config.path_points) is int
    env.reset(seed=0)
    with pytest.raises(ValueError, match="reward weight pose must be a finite number"):
        gym.make(ENV_ID, reward_weights={"pose": True})
    with pytest.raises(ValueError, match="rest_speed must be a finite number"):
        gym.make(ENV_ID, task_config={"rest_speed": np.bool_(True)})
    with pytest.raises(ValueError, match="path_points must be an integer"):
        gym.make(ENV_ID, task_config={"path_points": True})
    with pytest.raises(ValueError, match=r"path_points must be an integer in \[2, 1000\]"):
        gym.make(ENV_ID, task_config={"path_points": 10**7})


def test_reward_weights_are_bounded_so_rewards_stay_finite():
    with pytest.raises(ValueError, match="must be <= 1e"):
        RewardWeights(failure=1e308)
    with pytest.raises(ValueError, match="finite number"):
        RewardWeights(pose=10**400)
    # The largest weights allowed: rewards are finite, even as float32, and still sum the terms.
    heavy = {name: MAX_WEIGHT for name in ("pose", "precision", "singularity", "action", "failure")}
    env = gym.make(ENV_ID, reward_weights=heavy)
    env.reset(seed=4)
    rng = np.random.default_rng(4)
    for _ in range(60):
        _, reward, terminated, truncated, info = env.step(rng.uniform(-1, 1, 3))
        assert math.isfinite(reward) and np.isfinite(np.float32(reward))
        assert reward == pytest.approx(sum(info["reward_terms"].values()), rel=1e-12)
        if terminated or truncated:
            break


@pytest.mark.parametrize(
    "action",
    [
        ["0.1", "0.2", "0.3"],
        "abc",
        [True, False, True],
        np.array([True, False, True]),
        [1j, 0, 0],
        np.array([0.1, 0.2, 0.3], dtype=complex),
        [10**400, 0, 0],
        [-(10**400), 0.0, 0],
        [None, 0, 0],
    ],
    ids=repr,
)
def test_non_real_actions_raise_value_error_and_change_nothing(action):
    env = gym.make(ENV_ID)
    env.reset(seed=0)
    before = env.unwrapped.sim.state
    with pytest.raises(ValueError, match="action must"):
        env.step(action)
    assert env.unwrapped.sim.state == before


def test_numpy_integer_and_float_actions_are_accepted():
    env = gym.make(ENV_ID)
    env.reset(seed=0)
    for action in ([0, 1, -1], np.array([0, 1, -1], dtype=np.int64), np.float32([0.5, 0, 0])):
        obs, reward, *_ = env.step(action)
        assert np.isfinite(obs).all() and math.isfinite(reward)


@pytest.mark.parametrize("options", [[1, 2], "start", 3, ("start",)], ids=repr)
def test_reset_options_that_are_not_a_dict_raise_value_error(options):
    with pytest.raises(ValueError, match="reset options must be a dict"):
        gym.make(ENV_ID).reset(seed=0, options=options)


@pytest.mark.parametrize(
    "options",
    [
        {"start": (5.0, 5.0, 0.0)},  # unreachable
        {"target": (float("nan"), 0.1, 0.0)},
        {"working_mode": (1, 2, 1)},
        {"nonsense": 1},
    ],
    ids=repr,
)
def test_a_rejected_reset_does_not_consume_the_seed(options):
    """After reset(seed=7, options=bad) raises, the environment draws as if it never ran."""
    env, ref = gym.make(ENV_ID), gym.make(ENV_ID)
    env.reset(seed=3)
    ref.reset(seed=3)
    with pytest.raises(ValueError):
        env.reset(seed=7, options=options)
    _, info = env.reset()
    _, want = ref.reset()
    assert info["pose"] == want["pose"] and env.unwrapped.target == ref.unwrapped.target


@pytest.mark.parametrize("seed", [7, None])
def test_a_reset_rejected_after_the_mode_is_drawn_leaves_the_stream_as_it_was(seed):
    """Under ``working_mode="random"`` a given pose can only be checked once the episode's
    mode is drawn, after seeding; the random stream and the sampler pools are put back."""
    env, ref = gym.make(ENV_ID, working_mode="random"), gym.make(ENV_ID, working_mode="random")
    env.reset(seed=3)
    ref.reset(seed=3)
    with pytest.raises(ValueError, match="start"):
        env.reset(seed=seed, options={"start": (5.0, 5.0, 0.0)})
    for _ in range(3):
        _, info = env.reset()
        _, want = ref.reset()
        assert info["episode_spec"] == want["episode_spec"]


def test_a_nan_state_reports_a_nan_closure_error():
    design = Design.fig8()
    start, _ = task.sample_pair(design, (1, 1, -1), np.random.default_rng(0), CFG)
    sim = Planar3PSim(design, start, (1, 1, -1))
    assert 0.0 <= sim.state.closure_error < 1e-6
    for index in (0, 1):  # the platform, then the first slider
        fresh = Planar3PSim(design, start, (1, 1, -1))
        body = fresh._bodies[index]
        body.position = (math.nan, body.position.y)
        state = fresh._read()
        assert math.isnan(state.closure_error) and not state.finite


# ------------------------------------------------------------------ item 8: ecosystem interop
def test_record_video_writes_a_file(tmp_path):
    pytest.importorskip("moviepy")  # the 'video' extra
    from gymnasium.wrappers import RecordVideo

    env = gym.make(ENV_ID, render_mode="rgb_array", render_size=(160, 120))
    env = RecordVideo(env, str(tmp_path), episode_trigger=lambda _: True, disable_logger=True)
    env.reset(seed=0)
    for _ in range(10):
        env.step(np.zeros(3, dtype=np.float32))
    env.close()
    videos = list(tmp_path.glob("*.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 0


def test_keyboard_mapping_drives_the_sliders():
    from planar3p_gym.envs.actuation import KEYBOARD_KEYS, KEYBOARD_SPEED

    mapping = gym.make(ENV_ID).unwrapped.get_keys_to_action()
    assert len(mapping) == 26  # each slider still, +x or -x; all still is the no-op
    assert all(keys == tuple(sorted(keys)) for keys in mapping)
    np.testing.assert_array_equal(mapping[("q",)], [KEYBOARD_SPEED, 0, 0])
    np.testing.assert_array_equal(mapping[("d", "s")], [0, -KEYBOARD_SPEED, -KEYBOARD_SPEED])
    assert {k for pair in KEYBOARD_KEYS for k in pair} == {k for keys in mapping for k in keys}


def test_gymnasium_play_runs_with_the_env_mapping(monkeypatch):
    """gymnasium.utils.play.play finds the mapping on the env: pressing 'q' drives slider 1."""
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    pygame = pytest.importorskip("pygame")
    import matplotlib

    backend = matplotlib.get_backend()
    from gymnasium.utils.play import play

    # Importing gymnasium.utils.play switches matplotlib to TkAgg for the whole process: the
    # tests that run after this one in the same worker get their backend back.
    matplotlib.use(backend)

    actions = []

    def callback(obs_t, obs_tp1, action, rew, terminated, truncated, info):
        actions.append(np.array(action, dtype=np.float64))
        if len(actions) == 1:  # press 'q' (slider 1 towards +x)
            pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=ord("q")))
        if len(actions) == 3:
            pygame.event.post(pygame.event.Event(pygame.QUIT))

    env = gym.make(ENV_ID, render_mode="rgb_array", render_size=(160, 120))
    play(env, fps=1000, seed=0, noop=np.zeros(3, dtype=np.float32), callback=callback)
    assert len(actions) >= 3
    np.testing.assert_array_equal(actions[0], [0, 0, 0])
    assert actions[-1][0] > 0 and actions[-1][1] == 0 and actions[-1][2] == 0
