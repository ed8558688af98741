"""The native vector env (planar3p_gym.envs.vector): registered as the ids' vector entry point,
Gymnasium's next-step autoreset, and the same trajectories as ``num_envs`` single envs."""

from __future__ import annotations

import sys
import types
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import planar3p_gym
from planar3p_gym.envs.core import Planar3PEnv
from planar3p_gym.envs.vector import COMMAND_LOG, INFO_KEYS, NUMPY_BATCH_MIN, Planar3PVectorEnv
from planar3p_gym.sim.randomization import REALISTIC_RANDOMIZATION
from planar3p_gym.sim.sensors import REALISTIC_SENSORS
from planar3p_gym.tasks.mode_change import ModeChangeTask

#: The built machine's features (the ids' own: a randomised machine, encoders, one step of
#: action delay).
BUILT = {
    "randomization": REALISTIC_RANDOMIZATION.to_dict(),
    "sensors": REALISTIC_SENSORS.to_dict(),
    "latency": {"action_delay": 1},
}


@pytest.mark.parametrize("env_id", ["Planar3P-v0", "Planar3P-v0"])
def test_make_vec_gives_the_native_vector_env(env_id):
    venv = gym.make_vec(env_id, num_envs=3)
    assert type(venv) is Planar3PVectorEnv
    assert venv.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    assert venv.observation_space.shape == (3, 31)
    assert venv.action_space.shape == (3, 3)
    assert venv.max_episode_steps == planar3p_gym.MAX_EPISODE_STEPS
    assert venv.envs[0].projection == (env_id == "Planar3P-v0")
    venv.close()


@pytest.mark.parametrize(
    ("env_id", "kwargs", "batch"),
    [
        ("Planar3P-v0", {}, "scalar"),
        ("Planar3P-v0", {}, "numpy"),
        ("Planar3P-v0", {"working_mode": "random"}, "numpy"),
        # Every step past a closure of 1e-15 of the shortest leg counts as a physics breakdown:
        # episodes end through the single env's general step, in both batch modes.
        ("Planar3P-v0", {"breakdown_threshold": 1e-15}, "scalar"),
        ("Planar3P-v0", {"breakdown_threshold": 1e-15}, "numpy"),
        # The joint-space goal appended to the observation (travel_goal), through both paths.
        ("Planar3P-v0", {"travel_goal": True}, "numpy"),
        ("Planar3P-v0", {"travel_goal": True, "breakdown_threshold": 1e-15}, "scalar"),
        ("Planar3P-v0", {}, "auto"),
        # The tracking id: its batched step (each episode's reference samples, the reference
        # velocity entries, the running errors), through breakdowns too, and env by env.
        ("Planar3PTrack-v0", {}, "numpy"),
        ("Planar3PTrack-v0", {"reference": "figure_eight"}, "numpy"),
        ("Planar3PTrack-v0", {"breakdown_threshold": 1e-15}, "numpy"),
        ("Planar3PTrack-v0", {}, "scalar"),
        # The mode change's batched step (the success test in the target's working mode, the
        # reward without the serial barrier), through breakdowns too, and env by env.
        ("Planar3PModeChange-v0", {}, "numpy"),
        ("Planar3PModeChange-v0", {"breakdown_threshold": 1e-15}, "numpy"),
        ("Planar3PModeChange-v0", {}, "auto"),
        # The other task ids on the projected physics: environment by environment.
        ("Planar3PAssemblyChange-v0", {}, "numpy"),
        (
            "Planar3PAssemblyChange-v0",
            {"breakdown_threshold": 1e-15, "crossing_limits": {"verify": False}},
            "numpy",
        ),
        ("Planar3PAssemblyChange-v0", {}, "auto"),
        # The machine as built (randomised machine, encoders, delay): environment by environment
        # (3 envs under "auto"), then the batched step, through breakdowns too, with delays of
        # 0 to 2 steps drawn per episode for actions and observations.
        ("Planar3PReal-v0", {}, "auto"),
        ("Planar3PReal-v0", {}, "numpy"),
        ("Planar3PReal-v0", {"breakdown_threshold": 1e-15}, "numpy"),
        (
            "Planar3PReal-v0",
            {"latency": {"action_delay": [0, 2], "observation_delay": [0, 2]}},
            "numpy",
        ),
        # The joint-space goal on the machine as built (the block of the observed travels,
        # before the observation delay), through breakdowns too.
        (
            "Planar3PReal-v0",
            {"travel_goal": True, "latency": {"action_delay": [0, 2], "observation_delay": [0, 2]}},
            "numpy",
        ),
        ("Planar3PReal-v0", {"travel_goal": True, "breakdown_threshold": 1e-15}, "numpy"),
        # The built machine's encoders alone (the nominal machine's physics, no servo lag), and
        # the mode and assembly changes with the built machine's features.
        ("Planar3P-v0", {"sensors": REALISTIC_SENSORS.to_dict()}, "numpy"),
        ("Planar3PModeChange-v0", BUILT, "numpy"),
        ("Planar3PAssemblyChange-v0", BUILT, "numpy"),
        # The travel term (the task's fallback travels through breakdowns too), on the nominal
        # machine and on the machine as built.
        ("Planar3PModeChange-v0", {"travel_shaping": 0.5}, "numpy"),
        (
            "Planar3PAssemblyChange-v0",
            {
                "travel_shaping": 0.5,
                "breakdown_threshold": 1e-15,
                "crossing_limits": {"verify": False},
            },
            "numpy",
        ),
        (
            "Planar3PModeChange-v0",
            {**BUILT, "travel_shaping": 0.5, "breakdown_threshold": 1e-15},
            "numpy",
        ),
        ("Planar3PAssemblyChange-v0", {**BUILT, "travel_shaping": 0.5}, "numpy"),
    ],
)
def test_same_seeds_give_the_same_trajectories_as_single_envs(env_id, kwargs, batch):
    """Bit for bit: observations, rewards, flags and info entries of ``num_envs`` single
    envs made with ``gym.make`` (time limit included), reset with ``seed + i`` and autoreset
    on the next step after an episode ends, as the vector env does.  A short time limit makes
    several episodes end (truncations) and restart within the test; saturating actions in
    some steps drive sliders into their end stops and the servos to their force limit."""
    n, steps, limit = 3, 130, 40
    venv = gym.make_vec(env_id, num_envs=n, max_episode_steps=limit, batch=batch, **kwargs)
    singles = [gym.make(env_id, max_episode_steps=limit, **kwargs) for _ in range(n)]
    actions = np.random.default_rng(7).uniform(-1.0, 1.0, (steps, n, 3)).astype(np.float32)
    actions[60:90] = np.sign(actions[60:90]) * 1.5  # (clipped to +-1: bang-bang)
    obs, infos = venv.reset(seed=21)
    expected = [env.reset(seed=21 + i) for i, env in enumerate(singles)]
    np.testing.assert_array_equal(obs, np.stack([o for o, _ in expected]))
    done = [False] * n
    ends = 0
    for a in actions:
        obs, rewards, terminated, truncated, infos = venv.step(a)
        for i, env in enumerate(singles):
            if done[i]:
                o, info = env.reset()
                r, te, tr = 0.0, False, False
            else:
                o, r, te, tr, info = env.step(a[i])
            done[i] = te or tr
            ends += done[i]
            np.testing.assert_array_equal(obs[i], o)
            assert (rewards[i], terminated[i], truncated[i]) == (r, te, tr)
            for key in INFO_KEYS:
                assert infos[key][i] == info[key], key
                assert infos["_" + key][i]
    assert ends >= n * 2
    # The single envs' own attributes are brought up to date on access.
    for env, single in zip(venv.envs, singles, strict=True):
        assert env.sim.state == single.unwrapped.sim.state
        assert env.sim.get_state() == single.unwrapped.sim.get_state()  # commands included
        np.testing.assert_array_equal(env.episode.obs, single.unwrapped.episode.obs)
        assert env.episode.info.keys() == single.unwrapped.episode.info.keys()
        for key, value in single.unwrapped.episode.info.items():
            if key != "reward_terms":
                assert env.episode.info[key] == value, key
        assert env.episode.info["reward_terms"] == single.unwrapped.episode.info["reward_terms"]
        if "travel_shaping" in kwargs:  # (the fallback travels, which the next step may take)
            assert env.task._shaping_rho == single.unwrapped.task._shaping_rho
    venv.close()


@pytest.mark.parametrize(
    ("env_id", "controller", "kwargs"),
    [
        ("Planar3PModeChange-v0", "planner", {}),
        ("Planar3PAssemblyChange-v0", "crossing", {}),
        # The mode and assembly changes on the machine as built: its batched step.
        ("Planar3PModeChange-v0", "planner", BUILT),
        ("Planar3PAssemblyChange-v0", "crossing", BUILT),
        # The travel term, which changes the rewards and nothing the controllers observe.
        ("Planar3PAssemblyChange-v0", "crossing", {"travel_shaping": 0.5}),
        ("Planar3PModeChange-v0", "planner", {**BUILT, "travel_shaping": 0.5}),
    ],
)
def test_the_mode_and_assembly_change_batches_are_their_single_envs_through_successes(
    env_id, controller, kwargs
):
    """The mode and assembly changes' batched step where episodes succeed (the joint-path
    planner or the crossing controller, one per environment, acting on each single env's
    observation), under success tolerances
    changed after the reset: bit for bit the single envs' observations, rewards, flags and
    infos, the metrics of their last ``info`` included."""
    from planar3p_agents.controllers.crossing import CrossingController
    from planar3p_agents.controllers.planner import JointPathPlanner

    n, limit = NUMPY_BATCH_MIN, 300
    venv = gym.make_vec(env_id, num_envs=n, max_episode_steps=limit, **kwargs)
    assert venv._core is not None and (
        type(venv._core).__name__ == "_BuiltCore" or venv._core.goal is not None
    )
    singles = [gym.make(env_id, max_episode_steps=limit, **kwargs) for _ in range(n)]
    kind = JointPathPlanner if controller == "planner" else CrossingController
    planners = [kind.from_env(env) for env in singles]
    venv.reset(seed=100)
    obs = [env.reset(seed=100 + i)[0] for i, env in enumerate(singles)]
    # Looser success tolerances (a curriculum's change): the batched success test takes them.
    change = {"position_tolerance": 0.01, "orientation_tolerance": 0.05, "rest_speed": 0.05}
    venv.set_task_config(change)
    for env in singles:
        env.unwrapped.set_task_config(change)
    start = [True] * n
    done, successes = [False] * n, 0
    for _ in range(200):
        a = np.zeros((n, 3), np.float32)
        for i in range(n):
            if not done[i]:
                a[i] = planners[i].predict(obs[i], episode_start=np.array([start[i]]))[0]
                start[i] = False
        got, rewards, terminated, truncated, infos = venv.step(a)
        for i, env in enumerate(singles):
            if done[i]:
                o, info = env.reset()
                r, te, tr = 0.0, False, False
                start[i] = True
            else:
                o, r, te, tr, info = env.step(a[i])
                successes += info["is_success"]
            done[i] = te or tr
            obs[i] = o
            np.testing.assert_array_equal(got[i], o)
            assert (rewards[i], terminated[i], truncated[i]) == (r, te, tr)
            for key in INFO_KEYS:
                assert infos[key][i] == info[key], key
    # (the crossing controller on the machine as built succeeds once in these 200 steps)
    assert successes >= (1 if "sensors" in kwargs and controller == "crossing" else 2)
    if env_id == "Planar3PAssemblyChange-v0":
        assert max(env.episode.info["crossings"] for env in venv.envs) >= 1
    for env, single in zip(venv.envs, singles, strict=True):
        for key, value in single.unwrapped.episode.info.items():
            assert env.episode.info[key] == value, key
    venv.close()


def test_batched_commands_reach_the_simulations_records_across_the_log():
    """The batched step logs each env's drive commands and appends them to its simulation's
    record on access (and when :data:`COMMAND_LOG` steps have piled up): every snapshot equals
    the single env's, before and after the log wraps, with episodes ending in between."""
    n, limit = 4, 200
    venv = Planar3PVectorEnv(num_envs=n, max_episode_steps=limit, batch="numpy")
    singles = [gym.make("Planar3P-v0", max_episode_steps=limit) for _ in range(n)]
    venv.reset(seed=5)
    for i, env in enumerate(singles):
        env.reset(seed=5 + i)
    rng = np.random.default_rng(3)
    done = [False] * n
    for step in range(COMMAND_LOG + 80):
        a = rng.uniform(-0.3, 0.3, (n, 3))
        _, _, terminated, truncated, _ = venv.step(a)
        for i, env in enumerate(singles):
            if done[i]:
                env.reset()
                done[i] = False
            else:
                _, _, te, tr, _ = env.step(a[i])
                done[i] = te or tr
        assert [bool(x) for x in terminated | truncated] == done
        if step in (100, COMMAND_LOG + 79):
            for env, single in zip(venv.envs, singles, strict=True):
                assert env.sim.get_state() == single.unwrapped.sim.get_state()
    venv.close()


@pytest.mark.parametrize(
    ("env_id", "kwargs", "batch"),
    [
        ("Planar3P-v0", {}, "scalar"),
        ("Planar3P-v0", {}, "numpy"),
        ("Planar3P-v0", {"breakdown_threshold": 1e-15}, "scalar"),
        ("Planar3P-v0", {"breakdown_threshold": 1e-15}, "numpy"),
        ("Planar3PTrack-v0", {}, "numpy"),
        ("Planar3PTrack-v0", {}, "auto"),
        ("Planar3PReal-v0", {}, "auto"),
        ("Planar3PReal-v0", {}, "numpy"),
    ],
)
def test_same_step_infos_are_the_single_envs_episode_by_episode(env_id, kwargs, batch):
    """``SAME_STEP`` autoreset (what the SB3 adapter uses): the batch info arrays of a step
    are each single env's ``info`` of that step, or of its reset where its episode ended; the
    ended episodes' last observations and infos are ``final_obs`` / ``final_info``, bit for
    bit, episode by episode."""
    n, steps, limit = 3, 100, 30
    venv = gym.make_vec(
        env_id,
        num_envs=n,
        max_episode_steps=limit,
        batch=batch,
        autoreset_mode=AutoresetMode.SAME_STEP,
        **kwargs,
    )
    singles = [gym.make(env_id, max_episode_steps=limit, **kwargs) for _ in range(n)]
    actions = np.random.default_rng(3).uniform(-1.0, 1.0, (steps, n, 3)).astype(np.float32)
    venv.reset(seed=5)
    for i, env in enumerate(singles):
        env.reset(seed=5 + i)
    ends = 0
    for a in actions:
        obs, rewards, terminated, truncated, infos = venv.step(a)
        for i, env in enumerate(singles):
            o, r, te, tr, info = env.step(a[i])
            assert (rewards[i], terminated[i], truncated[i]) == (r, te, tr)
            if te or tr:
                ends += 1
                assert infos["_final_obs"][i] and infos["_final_info"][i]
                np.testing.assert_array_equal(infos["final_obs"][i], o)
                for key in INFO_KEYS:
                    assert infos["final_info"][key][i] == info[key], key
                    assert infos["final_info"]["_" + key][i]
                o, info = env.reset()
            elif "final_obs" in infos:
                assert not infos["_final_obs"][i] and not infos["_final_info"][i]
            np.testing.assert_array_equal(obs[i], o)
            for key in INFO_KEYS:
                assert infos[key][i] == info[key], key
                assert infos["_" + key][i]
    assert ends >= n * 2
    venv.close()


def test_batch_modes_and_their_choice():
    assert gym.make_vec("Planar3P-v0", num_envs=2)._core.numpy is False
    assert gym.make_vec("Planar3P-v0", num_envs=NUMPY_BATCH_MIN)._core.numpy is True
    # The unprojected model has no batched path: per-environment steps.
    assert gym.make_vec("Planar3P-v0", num_envs=2, projection=False)._core is None
    with pytest.raises(ValueError, match="batch"):
        Planar3PVectorEnv(num_envs=2, batch="fast")


def test_reset_accepts_a_list_of_seeds_and_options():
    venv = Planar3PVectorEnv(num_envs=2, max_episode_steps=10)
    obs_a, _ = venv.reset(seed=[5, 9])
    single = gym.make("Planar3P-v0")
    np.testing.assert_array_equal(obs_a[1], single.reset(seed=9)[0])
    start = single.unwrapped.sim.state.pose
    _, info = venv.reset(seed=1, options={"start": start})
    for env in venv.envs:
        np.testing.assert_allclose(env.sim.state.pose, start, atol=1e-12)
    assert info["position_error"].shape == (2,)
    with pytest.raises(ValueError, match="seeds"):
        venv.reset(seed=[1, 2, 3])


@pytest.mark.parametrize(
    "kwargs",
    [{"num_envs": 0}, {"num_envs": 2.5}, {"num_envs": 2, "max_episode_steps": 0}],
)
def test_constructor_rejects_bad_arguments(kwargs):
    with pytest.raises(ValueError):
        Planar3PVectorEnv(**kwargs)


def test_step_rejects_bad_actions_without_stepping():
    venv = Planar3PVectorEnv(num_envs=2)
    venv.reset(seed=0)
    before = [env.sim.state for env in venv.envs]
    for bad in (np.zeros((3, 3)), np.full((2, 3), np.nan)):
        with pytest.raises(ValueError):
            venv.step(bad)
    assert [env.sim.state for env in venv.envs] == before


@pytest.mark.parametrize("batch", ["scalar", "numpy"])
def test_vector_snapshot_restores_the_batch(batch):
    kwargs = {"projection": True, "substeps": 1, "solver_iterations": 4, "batch": batch}
    venv = Planar3PVectorEnv(num_envs=2, max_episode_steps=20, **kwargs)
    venv.reset(seed=3)
    rng = np.random.default_rng(0)
    for _ in range(15):
        venv.step(rng.uniform(-1, 1, (2, 3)))
    snap = venv.get_state()
    twin = Planar3PVectorEnv(num_envs=2, max_episode_steps=20, **kwargs)
    twin.set_state(snap)
    for a in rng.uniform(-1, 1, (30, 2, 3)):
        x, y = venv.step(a), twin.step(a)
        np.testing.assert_array_equal(x[0], y[0])
        np.testing.assert_array_equal(x[1], y[1])


@pytest.mark.parametrize(
    "env_id",
    [
        "Planar3PGoal-v0",
        "Planar3PTrack-v0",
        "Planar3PModeChange-v0",
        "Planar3PAssemblyChange-v0",
    ],
)
def test_task_ids_batch_snapshots_and_copies_continue_bit_for_bit(env_id):
    """The task ids' batched step restored from :meth:`get_state` into another vector env, and
    a ``copy.deepcopy`` (the batch's per-episode arrays rebuilt from the single envs), continue
    as the original does, bit for bit, episodes ending and resetting on the way."""
    import copy

    n = NUMPY_BATCH_MIN
    venv = gym.make_vec(env_id, num_envs=n, max_episode_steps=15)
    assert venv._core is not None and venv._core.goal is not None
    venv.reset(seed=3)
    rng = np.random.default_rng(0)
    for a in rng.uniform(-1, 1, (20, n, 3)):
        venv.step(a)
    twin = gym.make_vec(env_id, num_envs=n, max_episode_steps=15)
    twin.set_state(venv.get_state())
    clone = copy.deepcopy(venv)

    def flat(obs):
        return np.concatenate(list(obs.values()), axis=1) if isinstance(obs, dict) else obs

    for a in rng.uniform(-1, 1, (25, n, 3)):
        x, y, z = venv.step(a), twin.step(a), clone.step(a)
        for other in (y, z):
            np.testing.assert_array_equal(flat(x[0]), flat(other[0]))
            for k in (1, 2, 3):
                np.testing.assert_array_equal(x[k], other[k])
            for key in venv.info_keys:
                np.testing.assert_array_equal(x[4][key], other[4][key])


def test_sb3_adapter_matches_dummy_vec_env():
    """``planar3p_agents.training.vec_adapter.make_native_vec_env`` gives what SB3's ``DummyVecEnv``
    of ``gym.make`` envs gives (same seeds): observations, rewards, dones, terminal observations,
    time-limit flags and success flags; and PPO runs on it."""
    sb3 = pytest.importorskip("stable_baselines3")
    import torch
    from stable_baselines3.common.vec_env import DummyVecEnv

    torch.set_num_threads(1)

    from planar3p_agents.training.vec_adapter import make_native_vec_env

    n, limit = 2, 30
    native = make_native_vec_env("Planar3P-v0", n_envs=n, seed=4, env_kwargs=None)
    native.venv.max_episode_steps = limit
    dummy = DummyVecEnv(
        [lambda: gym.make("Planar3P-v0", max_episode_steps=limit) for _ in range(n)]
    )
    dummy.seed(4)
    np.testing.assert_array_equal(native.reset(), dummy.reset())
    ends = 0
    for a in np.random.default_rng(1).uniform(-1, 1, (75, n, 3)).astype(np.float32):
        x, y = native.step(a), dummy.step(a)
        np.testing.assert_array_equal(x[0], y[0])
        np.testing.assert_array_equal(x[1], y[1])
        np.testing.assert_array_equal(x[2], y[2])
        for i in range(n):
            if x[2][i]:  # the ended episode's last info entries, as the single env's
                ends += 1
                for key in ("TimeLimit.truncated", *INFO_KEYS):
                    assert x[3][i][key] == y[3][i][key], key
                np.testing.assert_array_equal(
                    x[3][i]["terminal_observation"], y[3][i]["terminal_observation"]
                )
                assert x[3][i]["episode"]["l"] == limit
            else:  # no per-env dict: every env's entries are the batch arrays
                assert x[3][i] == {}
                for key in INFO_KEYS:
                    assert native.batch_infos[key][i] == y[3][i][key], key
                    assert native.batch_infos["_" + key][i]
    assert ends >= n * 2
    model = sb3.PPO("MlpPolicy", native, n_steps=32, batch_size=32, n_epochs=1, seed=0)
    model.learn(64)
    native.close()


@pytest.mark.parametrize(
    ("env_id", "batch"),
    [("Planar3P-v0", "scalar"), ("Planar3P-v0", "numpy"), ("Planar3PModeChange-v0", "auto")],
)
def test_render_gives_each_single_envs_frame(env_id, batch):
    """The vector env renders: a frame per environment, each the frame
    the single environment renders after the same seeded reset and actions."""
    kwargs = {"batch": batch} if env_id == "Planar3P-v0" else {}
    venv = gym.make_vec(
        env_id,
        num_envs=2,
        vectorization_mode="vector_entry_point",
        render_mode="rgb_array",
        **kwargs,
    )
    singles = [gym.make(env_id, render_mode="rgb_array") for _ in range(2)]
    actions = np.random.default_rng(3).uniform(-1, 1, (6, 2, 3)).astype(np.float32)
    venv.reset(seed=7)
    for i, env in enumerate(singles):
        env.reset(seed=7 + i)
    for a in actions:
        venv.step(a)
        for i, env in enumerate(singles):
            env.step(a[i])
    frames = venv.render()
    assert isinstance(frames, tuple) and len(frames) == 2
    for frame, env in zip(frames, singles, strict=True):
        assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
        np.testing.assert_array_equal(frame, env.render())
    assert not np.array_equal(frames[0], frames[1])  # different episodes, different frames
    venv.close()
    for env in singles:
        env.close()


def test_render_records_a_tiled_video_through_gymnasiums_vector_wrapper(tmp_path):
    """Gymnasium's vector ``RecordVideo`` tiles the frames into one video (2 x 2 for 4 envs)."""
    from gymnasium.wrappers.vector import RecordVideo

    venv = RecordVideo(
        gym.make_vec(
            "Planar3P-v0",
            num_envs=4,
            vectorization_mode="vector_entry_point",
            render_mode="rgb_array",
            render_size=(64, 48),
        ),
        str(tmp_path / "videos"),
        step_trigger=lambda step: step == 0,
        video_length=5,
    )
    venv.reset(seed=0)
    for _ in range(6):
        venv.step(np.zeros((4, 3), dtype=np.float32))
    venv.close()
    assert (venv.frame_rows, venv.frame_cols) == (2, 2)
    videos = list((tmp_path / "videos").glob("*.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 0


def test_render_without_mode_warns_and_bad_mode_is_rejected():
    venv = Planar3PVectorEnv(num_envs=2)
    venv.reset(seed=0)
    with pytest.warns(UserWarning, match="render_mode"):
        assert venv.render() is None
    with pytest.raises(ValueError, match="render_mode"):
        Planar3PVectorEnv(num_envs=2, render_mode="human")


@pytest.mark.parametrize("action_type", ["on-off", "on-off-discrete"])
@pytest.mark.parametrize("n", [3, NUMPY_BATCH_MIN])
def test_the_on_off_id_has_a_native_vector_env_of_its_single_envs(n, action_type):
    """``Planar3PRealOnOff-v0`` (MultiDiscrete motor commands, or one ``Discrete(27)`` index
    per env): the native vector env gives its single environments' steps, bit for bit,
    autoreset included, environment by environment (3 envs) and in the batched step (from
    :data:`NUMPY_BATCH_MIN`)."""
    limit = 40
    kw = {"max_episode_steps": limit, "action_type": action_type}
    venv = gym.make_vec(planar3p_gym.REAL_ON_OFF_ENV_ID, num_envs=n, **kw)
    assert type(venv) is Planar3PVectorEnv
    assert (venv._core is not None) == (n >= NUMPY_BATCH_MIN)
    singles = [gym.make(planar3p_gym.REAL_ON_OFF_ENV_ID, **kw) for _ in range(n)]
    rng = np.random.default_rng(2)
    if action_type == "on-off":
        actions = rng.integers(0, 3, (100, n, 3))
    else:
        actions = rng.integers(0, 27, (100, n))
    obs, _ = venv.reset(seed=4)
    np.testing.assert_array_equal(
        obs, np.stack([e.reset(seed=4 + i)[0] for i, e in enumerate(singles)])
    )
    done, ends = [False] * n, 0
    for a in actions:
        obs, rewards, terminated, truncated, infos = venv.step(a)
        for i, env in enumerate(singles):
            if done[i]:  # (next-step autoreset: this step resets the environment)
                o, info = env.reset()
                r, te, tr = 0.0, False, False
            else:
                o, r, te, tr, info = env.step(a[i])
            assert (rewards[i], terminated[i], truncated[i]) == (r, te, tr)
            np.testing.assert_array_equal(obs[i], o)
            for key in INFO_KEYS:
                assert infos[key][i] == info[key], key
            done[i] = te or tr
            ends += done[i]
    assert ends >= 2 * n  # (a time limit of 40 steps in 100: autoresets were checked)
    venv.close()


@pytest.mark.parametrize(
    ("env_id", "kwargs", "batch", "options"),
    [
        # Environment by environment (scalar), then the batched step's compiled loops.
        ("Planar3PGoal-v0", {}, "scalar", None),
        ("Planar3PGoal-v0", {}, "numpy", None),
        ("Planar3PGoalDense-v0", {}, "numpy", None),
        ("Planar3PGoalDense-v0", {"observe_working_mode": True}, "auto", None),
        # Every step a physics breakdown: the reference kernel and the goal env's outputs.
        ("Planar3PGoalDense-v0", {"breakdown_threshold": 1e-15}, "numpy", None),
        # A desired goal that is passed at speed: the goal test says success where the reach
        # test (at rest) does not, so the batched step rejudges the reward terms.
        ("Planar3PGoalDense-v0", {}, "numpy", "moving"),
    ],
)
def test_the_goal_ids_native_vector_env_is_their_single_envs(env_id, kwargs, batch, options):
    """``gym.make_vec`` of a goal id gives its native vector env: ``Dict`` observations as a
    dict of batch arrays, bit for bit each single env's (next-step autoreset), the relabelling
    entries among the infos, and ``compute_reward`` of the batch's goals and infos equal to
    the rewards of every env stepped (what hindsight relabelling relies on); the single envs'
    own attributes (simulation, episode record, goal evaluation) equal theirs on access."""
    n, steps, limit = 4, 90, 25
    venv = gym.make_vec(env_id, num_envs=n, max_episode_steps=limit, batch=batch, **kwargs)
    assert type(venv).__name__ == "Planar3PGoalVectorEnv"
    assert (venv._core is not None) == (batch != "scalar")
    singles = [gym.make(env_id, max_episode_steps=limit, **kwargs) for _ in range(n)]
    actions = np.random.default_rng(11).uniform(-1.0, 1.0, (steps, n, 3)).astype(np.float32)
    reset_options = None
    if options == "moving":  # start at the goal pose, which may be passed at up to 0.2 m/s
        probe = gym.make(env_id).unwrapped
        probe.reset(seed=8)
        pose = probe.sim.state.pose
        goal = [pose[0], pose[1], np.cos(pose[2]), np.sin(pose[2]), 0.2]
        reset_options = {"start": pose, "desired_goal": goal}
        actions *= 0.05
    obs, _ = venv.reset(seed=8, options=reset_options)
    expected = [env.reset(seed=8 + i, options=reset_options)[0] for i, env in enumerate(singles)]
    assert venv.observation_space.contains(obs)
    for key in obs:
        np.testing.assert_array_equal(obs[key], np.stack([o[key] for o in expected]))
    done, ends, successes = [False] * n, 0, 0
    for a in actions:
        stepped = [not d for d in done]
        obs, rewards, terminated, truncated, infos = venv.step(a)
        for i, env in enumerate(singles):
            if done[i]:
                o, info = env.reset()
                r, te, tr = 0.0, False, False
            else:
                o, r, te, tr, info = env.step(a[i])
            done[i] = te or tr
            ends += done[i]
            for key in o:
                np.testing.assert_array_equal(obs[key][i], o[key])
            assert (rewards[i], terminated[i], truncated[i]) == (r, te, tr)
            for key in venv.info_keys:
                assert infos[key][i] == info[key], key
            successes += bool(info["is_success"])
        rows = np.flatnonzero(stepped)
        relabelled = venv.compute_reward(
            obs["achieved_goal"][rows],
            obs["desired_goal"][rows],
            {key: infos[key][rows] for key in venv.info_keys},
        )
        np.testing.assert_array_equal(relabelled, rewards[rows])
    assert ends >= n
    assert (successes > 0) == (options == "moving")
    for env, single in zip(venv.envs, singles, strict=True):
        s = single.unwrapped
        assert env.sim.get_state() == s.sim.get_state()
        np.testing.assert_array_equal(env.episode.obs, s.episode.obs)
        for key, value in s.episode.info.items():
            if key != "reward_terms":
                assert env.episode.info[key] == value, key
        np.testing.assert_array_equal(env.goal_task.achieved, s.goal_task.achieved)
        assert env.goal_task.evaluation == s.goal_task.evaluation
    venv.close()


def test_sb3_adapter_serves_the_goal_ids():
    """The SB3 adapter on a goal id: the ``Dict`` observations, rewards and dones of SB3's
    ``DummyVecEnv`` of ``gym.make`` envs, and every env's info carries the relabelling entries
    (``goal_free_reward``, ``failure``) of its single env at every step, as HER stores them."""
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.vec_env import DummyVecEnv

    from planar3p_agents.training.vec_adapter import make_native_vec_env
    from planar3p_gym.tasks.goal import RELABEL_INFO_KEYS

    n, limit = NUMPY_BATCH_MIN, 20  # (the batched step: SAME_STEP resets, final_obs)
    native = make_native_vec_env("Planar3PGoalDense-v0", n_envs=n, seed=6)
    assert native.venv._core is not None
    native.venv.max_episode_steps = limit
    dummy = DummyVecEnv(
        [lambda: gym.make("Planar3PGoalDense-v0", max_episode_steps=limit) for _ in range(n)]
    )
    dummy.seed(6)
    x, y = native.reset(), dummy.reset()
    for key in y:
        np.testing.assert_array_equal(x[key], y[key])
    ends = 0
    for a in np.random.default_rng(2).uniform(-1, 1, (50, n, 3)).astype(np.float32):
        x, y = native.step(a), dummy.step(a)
        for key in y[0]:
            np.testing.assert_array_equal(x[0][key], y[0][key])
        np.testing.assert_array_equal(x[1], y[1])
        np.testing.assert_array_equal(x[2], y[2])
        ends += int(x[2].sum())
        for i in range(n):
            for key in RELABEL_INFO_KEYS:
                assert x[3][i][key] == y[3][i][key], key
            if x[2][i]:  # the ended episode's last Dict observation
                for key, value in y[3][i]["terminal_observation"].items():
                    np.testing.assert_array_equal(x[3][i]["terminal_observation"][key], value)
    assert ends >= n
    native.close()


@pytest.mark.parametrize(
    ("env_id", "kwargs", "batched"),
    [
        ("Planar3PReal-v0", {}, True),
        ("Planar3PRealOnOff-v0", {}, True),
        ("Planar3P-v0", {"latency": {"action_delay": 2}}, True),
        ("Planar3PModeChange-v0", {"sensors": {"slider_noise": 1e-5}}, True),
        ("Planar3PAssemblyChange-v0", {"sensors": {"slider_noise": 1e-5}}, True),
        ("Planar3PRealOnOff-v0", {"action_type": "on-off-discrete"}, True),
        ("Planar3PModeChange-v0", {"sensors": {"slider_noise": 1e-5}, "travel_shaping": 0.5}, True),
        ("Planar3PReal-v0", {"travel_goal": True}, True),
    ],
)
def test_the_built_machine_takes_the_batched_step(env_id, kwargs, batched):
    venv = gym.make_vec(env_id, num_envs=NUMPY_BATCH_MIN, **kwargs)
    assert (type(venv._core).__name__ == "_BuiltCore") == batched
    venv.close()


@pytest.mark.parametrize("env_id", ["Planar3PReal-v0", "Planar3PRealOnOff-v0"])
def test_the_built_machines_batch_snapshots_and_copies_continue_bit_for_bit(env_id):
    """The built machine's batched step restored from :meth:`get_state` into another vector
    env, and a ``copy.deepcopy``, continue as the original does, bit for bit (the drawn
    machines, the delay lines, the encoders' last readings and the generators of the
    encoders' noise taken from the single envs), episodes ending and resetting on the way."""
    import copy

    n = NUMPY_BATCH_MIN
    venv = gym.make_vec(env_id, num_envs=n, max_episode_steps=15)
    assert venv._core is not None
    venv.reset(seed=3)
    rng = np.random.default_rng(0)

    def actions(count):
        if env_id == planar3p_gym.REAL_ON_OFF_ENV_ID:
            return rng.integers(0, 3, (count, n, 3))
        return rng.uniform(-1, 1, (count, n, 3))

    for a in actions(20):
        venv.step(a)
    twin = gym.make_vec(env_id, num_envs=n, max_episode_steps=15)
    twin.set_state(venv.get_state())
    clone = copy.deepcopy(venv)
    for a in actions(25):
        x, y, z = venv.step(a), twin.step(a), clone.step(a)
        for other in (y, z):
            for k in (0, 1, 2, 3):
                np.testing.assert_array_equal(x[k], other[k])
            for key in venv.info_keys:
                np.testing.assert_array_equal(x[4][key], other[4][key])


def test_bad_on_off_actions_are_rejected_before_any_env_steps():
    venv = gym.make_vec(planar3p_gym.REAL_ON_OFF_ENV_ID, num_envs=NUMPY_BATCH_MIN)
    venv.reset(seed=0)
    before = [env.get_state()["sim"] for env in venv.envs]
    bad = np.ones((NUMPY_BATCH_MIN, 3))
    bad[2, 1] = 3  # (motor values are 0, 1 or 2)
    with pytest.raises(ValueError, match="action"):
        venv.step(bad)
    assert [env.get_state()["sim"] for env in venv.envs] == before
    venv.close()


#: Bad batches of ``Discrete(27)`` actions (the first ``n`` of those of four entries): out of
#: ``[0, 27)``, not integral, not finite, bools, three commands per env, too few, a string.
BAD_DISCRETE = (
    [0, 1, 27, 2], [0, 1, -1, 2], [0, 1.5, 2, 3], [0, 1, float("nan"), 2], [True, 0, 1, 2],
    [[0, 1, 2]] * 4, [0, 1], "0123",
)  # fmt: skip


@pytest.mark.parametrize("n", [3, NUMPY_BATCH_MIN])
def test_bad_discrete_on_off_actions_are_rejected_before_any_env_steps(n):
    """``Discrete(27)`` actions out of ``[0, 27)``, not integral, of the wrong count or shape
    raise ``ValueError`` and no environment steps, env by env (3 envs) and batched."""
    venv = gym.make_vec(planar3p_gym.REAL_ON_OFF_ENV_ID, num_envs=n, action_type="on-off-discrete")
    venv.reset(seed=0)
    before = [env.get_state()["sim"] for env in venv.envs]
    for bad in BAD_DISCRETE:
        actions = bad[:n] if isinstance(bad, list) and len(bad) == 4 else bad
        with pytest.raises(ValueError, match="action"):
            venv.step(actions)
        assert [env.get_state()["sim"] for env in venv.envs] == before, bad
    obs, *_ = venv.step(np.arange(n) * 1.0)  # (integral floats are accepted, as by one env)
    assert obs.shape[0] == n
    venv.close()


class _SameModeChange(ModeChangeTask):
    """The mode change with its own hooks (a subclass that adds nothing)."""


class _BonusModeChange(ModeChangeTask):
    """The mode change with a hook of its own: one more reward term."""

    def reward_terms(self, **kwargs: Any) -> dict[str, float]:
        return {**super().reward_terms(**kwargs), "bonus": 1.0}


@pytest.mark.parametrize(("name", "batched"), [("Same", True), ("Bonus", False)])
def test_a_task_subclass_is_batched_exactly_while_its_hooks_are_its_class_s(
    monkeypatch, name, batched
):
    """The batched step runs a task's compiled hooks where its class's hooks are its own
    (:attr:`~planar3p_gym.tasks.base.Task.compiled_family`), and steps a subclass that
    overrides one env by env, through its hook: either way the single envs' numbers."""
    module = types.ModuleType("subclassed_tasks")
    module.Same, module.Bonus = _SameModeChange, _BonusModeChange
    monkeypatch.setitem(sys.modules, "subclassed_tasks", module)
    task = f"subclassed_tasks:{name}"
    venv = Planar3PVectorEnv(num_envs=NUMPY_BATCH_MIN, task=task)
    assert (venv._core is not None) == batched
    singles = [Planar3PEnv(task=task) for _ in range(NUMPY_BATCH_MIN)]
    obs, _ = venv.reset(seed=3)
    assert np.array_equal(obs, [env.reset(seed=3 + i)[0] for i, env in enumerate(singles)])
    rng = np.random.default_rng(0)
    for _ in range(40):
        actions = rng.uniform(-1.0, 1.0, (NUMPY_BATCH_MIN, 3)).astype(np.float32)
        obs, reward, terminated, truncated, _ = venv.step(actions)
        for i, env in enumerate(singles):
            one = env.step(actions[i])
            assert np.array_equal(obs[i], one[0]) and reward[i] == one[1]
            assert (terminated[i], truncated[i]) == (one[2], one[3])
    assert ("bonus" in singles[0].episode.info["reward_terms"]) == (name == "Bonus")
    venv.close()
    for env in singles:
        env.close()
