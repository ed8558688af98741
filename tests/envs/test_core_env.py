"""Tests of the ``Planar3P-v0`` environment: API conformance, singularity detection,
determinism and vectorisation, input validation, reward bookkeeping and observations."""

from __future__ import annotations

import functools
import itertools
import math
import warnings

import gymnasium as gym
import numpy as np
import pytest

import planar3p_gym
from planar3p_gym import ENV_ID, MAX_EPISODE_STEPS
from planar3p_gym.envs.end_reason import TERMINATION_REASONS
from planar3p_gym.machine import kinematics
from planar3p_gym.tasks import motions
from planar3p_gym.tasks import sampling as task
from planar3p_gym.tasks.observation import OBS_FIELDS, OBS_SIZE, SLICES
from planar3p_gym.tasks.rewards import BARRIER_CAP, RewardWeights, barrier

FAILURES = ("singularity_crossing", "physics_breakdown")

#: A start and an end pose of working mode (1, 1, 1) of the default design whose straight path
#: crosses det A = 0 once, with every travel inside the stroke and legs away from serial
#: singularities (found by a seeded search; ``test_crossing_path_preconditions`` re-checks it).
CROSSING_MODE = (1, 1, 1)
CROSSING_START = np.array([0.20891875, 0.2787513, -1.65693655])
CROSSING_END = np.array([0.25793576, 0.17352912, -1.38718248])


def make(**kwargs) -> gym.Env:
    return gym.make(ENV_ID, **kwargs)


def wrap(a):
    return (np.asarray(a) + math.pi) % (2.0 * math.pi) - math.pi


def random_actions(n: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1.0, 1.0, size=(n, 3)).astype(np.float32)


def rollout(env: gym.Env, seed: int, actions: np.ndarray, options=None) -> list:
    """``[(obs, reward, terminated, truncated, info)]`` of ``actions``, resetting as episodes
    end (the reset's observation and info are recorded with reward ``None``)."""
    obs, info = env.reset(seed=seed, options=options)
    out = [(obs, None, False, False, info)]
    for a in actions:
        obs, reward, terminated, truncated, info = env.step(a)
        out.append((obs, reward, terminated, truncated, info))
        if terminated or truncated:
            obs, info = env.reset()
            out.append((obs, None, False, False, info))
    return out


def min_jerk_actions(env: gym.Env, peak: float = 0.8) -> np.ndarray:
    """Open-loop normalised actions moving the episode's start to its target along the
    straight pose path (minimum-jerk time law, resolved rates from the simple motions), peak
    ``peak`` of the max speed."""
    u = env.unwrapped
    d = u.design
    cmds = motions.min_jerk_commands(
        d, u.working_mode, u.sim.state.pose, u.target, u.dt, peak * d.max_speed
    )
    return (cmds / d.max_speed).astype(np.float32)


def crossing_actions(env: gym.Env, peak: float = 0.8) -> np.ndarray:
    """Open-loop actions that drive the slider travels along the exact IK of the straight path
    ``CROSSING_START -> CROSSING_END`` at constant path speed (largest command ``peak``)."""
    u = env.unwrapped
    d = u.design
    fine = task.interpolate(CROSSING_START, CROSSING_END, 401)
    rho = kinematics.inverse(d, fine, CROSSING_MODE).rho
    rate_per_path = np.abs(np.diff(rho, axis=0)).max() * 400  # m per unit path parameter
    n = int(math.ceil(rate_per_path / (peak * d.max_speed * u.dt)))
    path = task.interpolate(CROSSING_START, CROSSING_END, n + 1)
    rho = kinematics.inverse(d, path, CROSSING_MODE).rho
    return (np.diff(rho, axis=0) / (u.dt * d.max_speed)).astype(np.float32)


def sim_snapshot(env: gym.Env):
    sim = env.unwrapped.sim
    bodies = (sim.platform, *sim.sliders, *sim.legs, *sim.drives)
    return (
        sim.state,
        tuple((tuple(b.position), tuple(b.velocity), b.angle, b.angular_velocity) for b in bodies),
    )


# ---------------------------------------------------------------------------- API checkers
RELEVANT = (UserWarning, RuntimeWarning)


@pytest.mark.parametrize("kwargs", [{}, {"render_mode": "rgb_array"}, {"working_mode": "random"}])
def test_gymnasium_check_env(kwargs):
    from gymnasium.utils.env_checker import check_env

    env = make(**kwargs)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped)
    relevant = [str(w.message) for w in caught if issubclass(w.category, RELEVANT)]
    assert not relevant
    env.close()


def test_sb3_check_env():
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    env = make()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sb3_checker.check_env(env, warn=True)
    relevant = [str(w.message) for w in caught if issubclass(w.category, RELEVANT)]
    assert not relevant


def test_registration_and_spaces():
    assert ENV_ID in gym.registry
    env = make()
    assert env.spec.max_episode_steps == MAX_EPISODE_STEPS
    assert env.action_space == gym.spaces.Box(-1.0, 1.0, (3,), np.float32)
    assert env.observation_space.shape == (OBS_SIZE,) == (31,)
    assert env.observation_space.dtype == np.float32
    assert np.isfinite(env.observation_space.low).all()
    assert np.isfinite(env.observation_space.high).all()
    # The documented slices tile the vector in order.
    start = 0
    for name, size, _ in OBS_FIELDS:
        assert SLICES[name] == slice(start, start + size)
        start += size
    assert start == OBS_SIZE


# ---------------------------------------------------------------------------- singularities
def test_crossing_path_preconditions():
    d = planar3p_gym.Design.fig8()
    path = task.interpolate(CROSSING_START, CROSSING_END, 401)
    rho, reachable = kinematics.inverse(d, path, CROSSING_MODE)
    assert reachable.all()
    assert rho.min() > 0.03 * d.stroke and rho.max() < 0.97 * d.stroke
    assert kinematics.serial_margin(d, path, rho).min() > 0.2
    det = kinematics.assembly_mode(d, path, rho)
    assert det[0] == -det[-1] and np.count_nonzero(np.diff(det)) == 1
    assert kinematics.parallel_margin(d, path[0], rho[0]) > 0.04  # a valid task start


@pytest.fixture(scope="module")
def crossing_episode():
    # The unprojected model: driving the travels open-loop through a parallel singularity
    # carries its platform across (the solver's slack); the exact machine's platform stays on
    # its branch of the direct kinematics (a fold), so no open-loop travel command crosses.
    env = make(working_mode=CROSSING_MODE, projection=False)
    obs, info = env.reset(seed=0, options={"start": CROSSING_START})
    records = [(obs, None, False, False, info)]
    actions = crossing_actions(env)
    assert np.abs(actions).max() <= 1.0
    for a in [*actions, *np.zeros((30, 3), np.float32)]:
        obs, reward, terminated, truncated, info = env.step(a)
        records.append((obs, reward, terminated, truncated, info))
        if terminated or truncated:
            break
    return env, records, len(actions)


def test_singularity_crossing_is_detected(crossing_episode):
    env, records, n_path = crossing_episode
    _, reward, terminated, truncated, info = records[-1]
    assert terminated and not truncated
    assert info["termination_reason"] in FAILURES
    assert len(records) - 1 <= n_path + 30
    assert records[0][4]["assembly_mode"] == env.unwrapped.assembly_mode
    if info["termination_reason"] == "singularity_crossing":
        assert info["assembly_mode"] == -env.unwrapped.assembly_mode
        # The terminal observation and the reward describe the state after the step.
        obs = records[-1][0]
        np.testing.assert_allclose(obs[SLICES["position"]], info["pose"][:2], atol=1e-6)
        length = env.unwrapped.design.characteristic_length
        expected = (
            -env.unwrapped.reward_weights.pose
            * (info["position_error"] + length * abs(info["orientation_error"]))
            / length
        )
        assert info["reward_terms"]["pose"] == pytest.approx(expected, rel=1e-12)
    # The approach is visible in the margin before the episode ends.
    assert min(r[4]["parallel_margin"] for r in records) < 0.01
    assert info["reward_terms"]["failure"] == -env.unwrapped.reward_weights.failure
    assert reward == pytest.approx(sum(info["reward_terms"].values()), abs=1e-12)


def test_observations_stay_finite_through_the_singularity(crossing_episode):
    env, records, _ = crossing_episode
    for obs, *_ in records:
        assert np.isfinite(obs).all()
        assert env.observation_space.contains(obs)


def test_singularity_term_grows_as_the_margin_shrinks(crossing_episode):
    env, records, _ = crossing_episode
    w = env.unwrapped.reward_weights
    pairs = []
    for *_, info in records[1:]:
        pm, sm = info["parallel_margin"], info["serial_margin"]
        expected = -w.singularity * (
            barrier(pm, w.parallel_margin_ref) + barrier(sm, w.serial_margin_ref)
        )
        assert info["reward_terms"]["singularity"] == pytest.approx(expected, rel=1e-12)
        if sm >= w.serial_margin_ref:
            pairs.append((pm, info["reward_terms"]["singularity"]))
    pairs.sort()
    terms = [t for _, t in pairs]
    assert all(a <= b for a, b in itertools.pairwise(terms))  # less margin, more cost
    assert terms[0] < 0.0  # the approach did enter the penalised zone


def test_singularity_barrier_function():
    ref = 0.03
    margins = np.linspace(1.0, 0.0, 2001)
    pen = [barrier(m, ref) for m in margins]
    assert all(b >= a for a, b in itertools.pairwise(pen))
    assert pen[0] == 0.0 and pen[-1] == BARRIER_CAP
    assert barrier(ref, ref) == 0.0
    assert barrier(ref / 2, ref) == pytest.approx(1.0)
    assert barrier(0.05, 0.1) == pytest.approx(1.0)
    assert barrier(0.0, ref) == BARRIER_CAP


# ---------------------------------------------------------------------------- determinism
def _assert_same(a: list, b: list) -> None:
    assert len(a) == len(b)
    for (o1, r1, te1, tr1, i1), (o2, r2, te2, tr2, i2) in zip(a, b, strict=True):
        assert o1.dtype == o2.dtype and o1.tobytes() == o2.tobytes()
        assert r1 == r2 and te1 == te2 and tr1 == tr2
        assert i1 == i2


def test_same_seed_and_actions_give_identical_trajectories():
    actions = random_actions(400, seed=11)
    a = rollout(make(), 123, actions)
    b = rollout(make(), 123, actions)
    _assert_same(a, b)
    assert sum(r[1] is None for r in a) >= 2  # at least one episode ended and was reset
    # Re-seeding the same instance replays the first episode.
    env = make()
    rollout(env, 5, actions[:50])
    _assert_same(rollout(env, 123, actions), a)


@pytest.mark.parametrize("seed", [True, np.bool_(False), 3.0, np.float64(3.0), -1, "3"], ids=repr)
def test_single_and_vector_envs_refuse_the_same_seeds(seed):
    """The single env accepted ``seed=True`` (as 1) and refused ``np.int64(3)`` with Gymnasium's
    own error; the vector env the opposite.  Both refuse bools, floats, negative numbers and
    strings with ``ValueError`` naming the seed, and draw nothing."""
    from planar3p_gym.envs.vector import Planar3PVectorEnv

    env, ref = make(), make()
    env.reset(seed=5)
    ref.reset(seed=5)
    with pytest.raises(ValueError, match="seed"):
        env.reset(seed=seed)
    assert env.reset()[1]["episode_spec"] == ref.reset()[1]["episode_spec"]
    venv = Planar3PVectorEnv(num_envs=2)
    for bad in (seed, [seed, 1]):
        with pytest.raises(ValueError, match="seed"):
            venv.reset(seed=bad)


@pytest.mark.parametrize("seed", [3, np.int64(3), np.uint8(3), np.array(3)], ids=repr)
def test_single_and_vector_envs_take_numpy_integer_seeds_as_ints(seed):
    from planar3p_gym.envs.vector import Planar3PVectorEnv

    obs, info = make().reset(seed=seed)
    assert info["episode_spec"] == make().reset(seed=3)[1]["episode_spec"]
    vobs, _ = Planar3PVectorEnv(num_envs=2).reset(seed=seed)
    want, _ = Planar3PVectorEnv(num_envs=2).reset(seed=[3, np.int64(4)])
    assert vobs.tobytes() == want.tobytes() and vobs[0].tobytes() == obs.tobytes()


def test_random_working_mode_is_seeded():
    actions = random_actions(60, seed=2)
    a = rollout(make(working_mode="random"), 9, actions)
    b = rollout(make(working_mode="random"), 9, actions)
    _assert_same(a, b)
    modes = set()
    env = make(working_mode="random")
    env.reset(seed=0)
    for _ in range(12):
        _, info = env.reset()
        modes.add(info["working_mode"])
    assert len(modes) > 1


def test_different_seeds_give_different_tasks():
    env = make()
    _, i1 = env.reset(seed=1)
    t1 = env.unwrapped.target
    _, i2 = env.reset(seed=2)
    assert (i1["pose"], t1) != (i2["pose"], env.unwrapped.target)


def _make_registered() -> gym.Env:  # module level: picklable into spawned workers
    return gym.make(ENV_ID)


def _vector_rollout(venv, seeds, actions):
    obs, _ = venv.reset(seed=seeds)
    out = [obs.copy()]
    for a in actions:
        obs, reward, terminated, truncated, _ = venv.step(a)
        out.append((obs.copy(), reward.copy(), terminated.copy(), truncated.copy()))
    venv.close()
    return out


def test_async_vector_env_with_spawned_workers():
    actions = [random_actions(2, seed=s) for s in range(5)]
    seeds = [3, 4]
    ref = _vector_rollout(gym.vector.SyncVectorEnv([_make_registered] * 2), seeds, actions)
    spawned = _vector_rollout(
        gym.vector.AsyncVectorEnv([_make_registered] * 2, context="spawn"), seeds, actions
    )
    assert ref[0].tobytes() == spawned[0].tobytes()
    for (o1, r1, te1, tr1), (o2, r2, te2, tr2) in zip(ref[1:], spawned[1:], strict=True):
        assert o1.tobytes() == o2.tobytes() and r1.tobytes() == r2.tobytes()
        assert (te1 == te2).all() and (tr1 == tr2).all()
    # The registered id alone also works (make_vec builds the workers from the spec).
    venv = gym.make_vec(
        ENV_ID, num_envs=2, vectorization_mode="async", vector_kwargs={"context": "spawn"}
    )
    made = _vector_rollout(venv, seeds, actions)
    assert made[0].tobytes() == ref[0].tobytes()
    assert made[-1][0].tobytes() == ref[-1][0].tobytes()


def test_sb3_subproc_vec_env_with_spawn():
    vec_env = pytest.importorskip("stable_baselines3.common.vec_env")
    fns = [functools.partial(gym.make, ENV_ID)] * 2
    actions = [random_actions(2, seed=s) for s in range(4)]
    results = []
    for venv in (
        vec_env.DummyVecEnv(fns),
        vec_env.SubprocVecEnv([_make_registered] * 2, start_method="spawn"),
    ):
        venv.seed(7)
        obs = venv.reset()
        out = [obs.copy()]
        for a in actions:
            obs, reward, done, _ = venv.step(a)
            out.append((obs.copy(), reward.copy(), done.copy()))
        venv.close()
        results.append(out)
    ref, sub = results
    assert ref[0].tobytes() == sub[0].tobytes()
    for (o1, r1, d1), (o2, r2, d2) in zip(ref[1:], sub[1:], strict=True):
        assert o1.tobytes() == o2.tobytes()
        # DummyVecEnv stores rewards as float32, SubprocVecEnv returns them as float64.
        assert np.array_equal(r1, r2.astype(r1.dtype))
        assert (d1 == d2).all()


# ---------------------------------------------------------------------------- bad input
BAD_ACTIONS = [
    np.array([np.nan, 0.0, 0.0], np.float32),
    np.array([0.0, np.inf, 0.0], np.float32),
    np.array([0.0, 0.0, -np.inf]),
    np.zeros(2, np.float32),
    np.zeros(4, np.float32),
    np.zeros((1, 3), np.float32),
    np.float32(0.5),
    ["a", "b", "c"],
    None,
]


@pytest.mark.parametrize("action", BAD_ACTIONS, ids=lambda a: repr(a)[:30])
def test_bad_action_raises_without_changing_the_state(action):
    env, ref = make(), make()
    env.reset(seed=4)
    ref.reset(seed=4)
    good = random_actions(3, seed=1)
    for a in good[:2]:
        env.step(a)
        ref.step(a)
    before = sim_snapshot(env)
    with pytest.raises(ValueError):
        env.step(action)  # through the gym.make wrappers
    assert sim_snapshot(env) == before
    # The episode goes on exactly as if the bad call had not happened.
    o1, r1, *_, i1 = env.step(good[2])
    o2, r2, *_, i2 = ref.step(good[2])
    assert o1.tobytes() == o2.tobytes() and r1 == r2 and i1 == i2


def test_out_of_range_actions_are_clipped():
    a, b = make(), make()
    a.reset(seed=8)
    b.reset(seed=8)
    o1, r1, *_ = a.step(np.array([3.0, -7.0, 0.5], np.float32))
    o2, r2, *_ = b.step(np.array([1.0, -1.0, 0.5], np.float32))
    assert o1.tobytes() == o2.tobytes()
    assert r1 == r2  # the effort term is computed from the clipped action too


@pytest.fixture(scope="module")
def task_poses():
    env = make()
    _, info = env.reset(seed=0)
    return np.array(info["pose"]), np.array(env.unwrapped.target)


def _bad_reset_options(start, target):
    return {
        "unknown key": {"foo": 1},
        "start shape": {"start": start[:2]},
        "start 2-D": {"start": start[None, :]},
        "start NaN": {"start": [np.nan, start[1], start[2]]},
        "start inf": {"start": [start[0], np.inf, start[2]]},
        "start text": {"start": "abc"},
        "start unreachable": {"start": [5.0, 5.0, 0.0]},
        "target shape": {"target": [0.1, 0.2, 0.3, 0.4]},
        "target NaN": {"target": [np.nan, 0.1, 0.0]},
        "target unreachable": {"target": [start[0], 0.5, 0.0]},
        "start at a parallel singularity": {"start": _singular_pose()},
        "working mode 0": {"working_mode": (1, 0, 1)},
        "working mode length": {"working_mode": (1, 1)},
        "working mode text": {"working_mode": "random"},
        "working mode fraction": {"working_mode": (1.5, 1, 1)},
        "start in another working mode": {"start": start, "working_mode": (-1, -1, -1)},
        "different assembly modes": {
            "start": CROSSING_START,
            "target": CROSSING_END,
            "working_mode": CROSSING_MODE,
        },
    }


def _singular_pose() -> np.ndarray:
    """A pose of working mode ``CROSSING_MODE`` at det A = 0 (bisection on the sign of det A along a
    segment between poses of opposite assembly modes)."""
    d = planar3p_gym.Design.fig8()
    mode = np.array(CROSSING_MODE)
    a, b = CROSSING_START.copy(), CROSSING_END.copy()
    sa = kinematics.assembly_mode(d, a, kinematics.inverse(d, a, mode).rho)
    for _ in range(80):
        m = 0.5 * (a + b)
        sm = kinematics.assembly_mode(d, m, kinematics.inverse(d, m, mode).rho)
        if sm == sa:
            a = m
        else:
            b = m
    return a


def test_singular_pose_helper():
    d = planar3p_gym.Design.fig8()
    p = _singular_pose()
    rho, ok = kinematics.inverse(d, p, CROSSING_MODE)
    assert ok and kinematics.parallel_margin(d, p, rho) < 1e-9


#: The reason each bad option must be rejected for (a fragment of the error message).
BAD_RESET_REASONS = {
    "unknown key": "unknown reset options",
    "start unreachable": "not reachable",
    "target unreachable": "not reachable",
    "start in another working mode": "not reachable",
    "start at a parallel singularity": "parallel singularity",
    "different assembly modes": "assembly mode",
    "working mode 0": "working_mode",
    "working mode length": "working_mode",
    "working mode text": "working_mode",
    "working mode fraction": "working_mode",
}


@pytest.mark.parametrize("name", list(_bad_reset_options(np.zeros(3), np.zeros(3))))
def test_bad_reset_options_raise(name, task_poses):
    start, target = task_poses
    options = _bad_reset_options(start, target)[name]
    if name == "start at a parallel singularity":
        env = make(working_mode=CROSSING_MODE)
    else:
        env = make()
    env.reset(seed=0)
    with pytest.raises(ValueError, match=BAD_RESET_REASONS.get(name)):
        env.reset(seed=1, options=options)
    # The env remains usable.
    obs, _ = env.reset(seed=2)
    assert env.observation_space.contains(obs)


def test_valid_reset_options_are_honoured(task_poses):
    start, target = task_poses
    env = make()
    _, info = env.reset(seed=5, options={"start": start, "target": target})
    np.testing.assert_allclose(info["pose"], start, atol=1e-12)
    assert env.unwrapped.target == tuple(target)
    _, info = env.reset(seed=5, options={"start": start})
    np.testing.assert_allclose(info["pose"], start, atol=1e-12)
    _, info = env.reset(seed=5, options={"working_mode": (1, 1, 1)})
    assert info["working_mode"] == (1, 1, 1)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"design": {"legs": (1, 1, 1)}},
        {"design": {"leg_lengths": (0.17, -0.18, 0.19)}},
        {"design": {"stroke": float("nan")}},
        {"design": {"leg_lengths": (0.01, 0.01, 0.01), "rail_origins": (0.0, 5.0, 10.0)}},
        {"design": "fig9"},
        {"design": 42},
        {"working_mode": (1, 1, 0)},
        {"working_mode": "rand"},
        {"working_mode": (1, 1)},
        {"control_frequency": 0},
        {"control_frequency": -50.0},
        {"control_frequency": float("nan")},
        {"control_frequency": float("inf")},
        {"control_frequency": "50"},
        {"substeps": 0},
        {"substeps": 2.5},
        {"substeps": "4"},
        {"solver_iterations": 0},
        {"reward_weights": {"pose": -1.0}},
        {"reward_weights": {"success": float("nan")}},
        {"reward_weights": {"parallel_margin_ref": 0.0}},
        {"reward_weights": {"posee": 1.0}},
        {"reward_weights": "heavy"},
        {"task_config": {"position_tolerance": -1.0}},
        {"task_config": {"tolerance": 1.0}},
        {"breakdown_threshold": 0.0},
        {"breakdown_threshold": float("nan")},
        {"render_mode": "rgb"},
        {"render_size": (0, 0)},
        {"render_size": (-640, 480)},
        {"render_size": "big"},
    ],
    ids=lambda kw: repr(kw)[:60],
)
def test_invalid_constructor_arguments_raise_at_make(kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # gym.make's own render_mode warning
        with pytest.raises(ValueError):
            make(**kwargs)


# ---------------------------------------------------------------------------- rewards
def _check_reward_bookkeeping(records, weights: RewardWeights) -> None:
    for _, reward, terminated, _, info in records:
        if reward is None:
            continue
        terms = info["reward_terms"]
        assert {"pose", "singularity", "action", "success", "failure"} <= set(terms)
        assert all(math.isfinite(v) for v in terms.values())
        assert reward == pytest.approx(sum(terms.values()), rel=1e-12, abs=1e-12)
        success = info["termination_reason"] == "success"
        assert info["is_success"] == success
        assert (terms["success"] == weights.success) == success
        assert (terms["success"] == 0.0) == (not success)
        failed = info["termination_reason"] in FAILURES
        assert (terms["failure"] == -weights.failure) == failed
        assert (terms["failure"] == 0.0) == (not failed)
        assert terminated == (info["termination_reason"] is not None)
        assert info["termination_reason"] in (None, *TERMINATION_REASONS)
        # Every per-step term is a cost; only the success bonus is positive.
        assert all(v <= 0.0 for k, v in terms.items() if k != "success")


def test_reward_terms_sum_on_random_episodes():
    env = make()
    records = rollout(env, 21, random_actions(300, seed=21))
    _check_reward_bookkeeping(records, env.unwrapped.reward_weights)


def test_reward_terms_on_a_success_step():
    env = make()
    env.reset(seed=0)
    records = []
    for a in [*min_jerk_actions(env), *np.zeros((40, 3), np.float32)]:
        obs, reward, terminated, truncated, info = env.step(a)
        records.append((obs, reward, terminated, truncated, info))
        if terminated or truncated:
            break
    assert records[-1][4]["termination_reason"] == "success"
    assert records[-1][4]["is_success"]
    assert records[-1][4]["position_error"] <= env.unwrapped.task_config.position_tolerance
    _check_reward_bookkeeping(records, env.unwrapped.reward_weights)
    assert sum(r[4]["reward_terms"]["success"] != 0 for r in records) == 1


def test_reward_terms_on_a_failure_step(crossing_episode):
    env, records, _ = crossing_episode
    _check_reward_bookkeeping(records, env.unwrapped.reward_weights)


def test_reward_weights_are_applied():
    weights = {"pose": 2.0, "singularity": 0.0, "action": 0.5, "success": 1.0, "failure": 3.0}
    env, ref = make(reward_weights=weights), make()
    env.reset(seed=3)
    ref.reset(seed=3)
    a = np.array([0.5, -0.5, 0.25], np.float32)
    *_, info = env.step(a)
    *_, ref_info = ref.step(a)
    t, rt = info["reward_terms"], ref_info["reward_terms"]
    assert t["pose"] == pytest.approx(2.0 * rt["pose"], rel=1e-12)
    assert t["action"] == pytest.approx(50.0 * rt["action"], rel=1e-12)
    assert t["action"] == pytest.approx(-0.5 * float(np.mean(a.astype(float) ** 2)), rel=1e-6)
    assert t["singularity"] == 0.0


# ---------------------------------------------------------------------------- observations
@pytest.mark.parametrize("working_mode", [(1, 1, -1), "random"])
def test_observations_in_space_and_consistent_with_state(working_mode):
    env = make(working_mode=working_mode)
    u = env.unwrapped
    obs, info = env.reset(seed=17)
    actions = random_actions(400, seed=17)
    checked = 0
    for a in [None, *actions]:
        if a is not None:
            obs, _, terminated, truncated, info = env.step(a)
        assert obs.dtype == np.float32 and obs.shape == (OBS_SIZE,)
        assert np.isfinite(obs).all() and env.observation_space.contains(obs)
        if info.get("termination_reason") != "physics_breakdown":
            st = u.sim.state
            f32 = np.float32
            assert np.array_equal(obs[SLICES["position"]], np.asarray(info["pose"][:2], f32))
            assert np.array_equal(obs[SLICES["rho"]], np.asarray(info["rho"], f32))
            assert np.array_equal(obs[SLICES["rho_dot"]], np.asarray(info["rho_dot"], f32))
            th = info["pose"][2]
            assert np.allclose(obs[SLICES["orientation"]], [math.cos(th), math.sin(th)], atol=1e-7)
            assert np.array_equal(obs[SLICES["velocity"]], np.asarray(st.twist[:2], f32))
            assert obs[SLICES["angular_velocity"]][0] == f32(st.twist[2])
            legs = np.array([[math.cos(x), math.sin(x)] for x in st.leg_angles]).ravel()
            assert np.allclose(obs[SLICES["legs"]], legs, atol=1e-7)
            # The leg directions are those of C_i - B_i (up to the joint separation).
            u_vec = kinematics.leg_vectors(u.design, np.array(st.pose), np.array(st.rho))
            geo = (u_vec / np.linalg.norm(u_vec, axis=-1, keepdims=True)).ravel()
            tol = 2.0 * st.closure_error / u.design.shortest_leg + 1e-6
            assert np.abs(obs[SLICES["legs"]] - geo).max() <= tol
            tx, ty, tth = u.target
            assert np.array_equal(obs[SLICES["target_position"]], np.asarray([tx, ty], f32))
            assert np.allclose(
                obs[SLICES["target_orientation"]], [math.cos(tth), math.sin(tth)], atol=1e-7
            )
            err = np.array([tx - info["pose"][0], ty - info["pose"][1]])
            assert np.allclose(obs[SLICES["position_error"]], err, atol=1e-7)
            assert math.hypot(*err) == pytest.approx(info["position_error"], abs=1e-12)
            assert obs[SLICES["orientation_error"]][0] == pytest.approx(wrap(tth - th), abs=1e-6)
            assert obs[SLICES["parallel_margin"]][0] == f32(info["parallel_margin"])
            assert obs[SLICES["serial_margin"]][0] == f32(info["serial_margin"])
            checked += 1
        if a is not None and (terminated or truncated):
            obs, info = env.reset()
    assert checked > 300


def test_time_limit_truncates():
    env = make()
    env.reset(seed=0)
    steps = 0
    while True:
        _, _, terminated, truncated, info = env.step(np.zeros(3, np.float32))
        steps += 1
        assert not terminated
        if truncated or steps > MAX_EPISODE_STEPS:
            break
    assert truncated and steps == MAX_EPISODE_STEPS
    assert info["time"] == pytest.approx(MAX_EPISODE_STEPS / 50.0)


def test_reset_starts_at_rest_on_a_valid_task():
    env = make()
    cfg = env.unwrapped.task_config
    for seed in range(5):
        _, info = env.reset(seed=seed)
        assert info["termination_reason"] is None and not info["is_success"]
        assert info["rho_dot"] == (0.0, 0.0, 0.0) and info["time"] == 0.0
        assert info["parallel_margin"] >= cfg.min_parallel_margin
        assert info["serial_margin"] >= cfg.min_serial_margin
        assert info["closure_error"] <= 1e-12
        assert info["reward_terms"] == {}


def test_working_mode_change_is_reported_not_terminal():
    """Driving one slider until its leg passes the perpendicular flips that leg's working-mode
    sign: info says so, and the episode goes on (a serial singularity is crossable)."""
    env = gym.make("Planar3P-v0")
    obs, info = env.reset(seed=0)
    assert info["working_mode_changed"] is False
    mode = info["working_mode"]
    seen_flip = False
    for _ in range(200):
        # Move every slider so that its leg's horizontal component shrinks (towards the
        # perpendicular): sigma_i = +1 means C_i is right of B_i, so push the slider right.
        action = np.array([0.5 * m for m in mode], dtype=np.float32)
        obs, _reward, terminated, truncated, info = env.step(action)
        legs = obs[SLICES["legs"]].reshape(3, 2)
        flipped = any((c >= 0) != (m > 0) for (c, _), m in zip(legs, mode, strict=True))
        assert info["working_mode_changed"] == flipped
        seen_flip |= flipped
        if flipped:
            assert not terminated  # a working-mode change alone does not end the episode
            break
        assert not (terminated or truncated)
    assert seen_flip  # with seed 0 leg 1 passes the perpendicular after 68 steps


def test_fine_error_block_is_the_pose_error_on_a_millimetre_scale():
    from planar3p_gym.tasks.observation import FINE_ERROR_SCALE

    env = gym.make("Planar3P-v0")
    obs, _info = env.reset(seed=3)
    length = env.unwrapped.design.characteristic_length
    for _ in range(20):
        fine = obs[SLICES["fine_error"]].astype(float)
        dx, dy = obs[SLICES["position_error"]].astype(float)
        dth = float(obs[SLICES["orientation_error"]][0])
        expected = np.tanh(np.array([dx, dy, length * dth]) / FINE_ERROR_SCALE)
        np.testing.assert_allclose(fine, expected, atol=1e-5)
        assert np.all(np.abs(fine) <= 1.0)
        obs, *_ = env.step(env.action_space.sample())
    # Within a few millimetres the block is nearly linear: 1 mm reads as about 0.1.
    assert math.tanh(0.001 / FINE_ERROR_SCALE) == pytest.approx(0.0997, abs=1e-4)


def test_core_package_imports_without_torch_or_sb3():
    """The environment must be usable with the core dependencies only."""
    import subprocess
    import sys

    code = (
        "import sys\n"
        "import gymnasium as gym, planar3p_gym\n"
        "import planar3p_gym.analysis.workspace, planar3p_gym.sim.render\n"
        "env = gym.make('Planar3P-v0'); env.reset(seed=0); env.step(env.action_space.sample())\n"
        "assert 'torch' not in sys.modules and 'stable_baselines3' not in sys.modules\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


@pytest.mark.parametrize("env_id", ["Planar3P-v0", "Planar3PReal-v0"])
def test_a_breakdown_step_returns_no_object_of_the_reset(env_id):
    """A broken-down first step keeps the reset's last good entries (its ``episode_spec``
    included) as copies: nothing it returns is an object the reset returned, as Gymnasium's
    checker asks."""
    from gymnasium.utils.passive_env_checker import data_shares_objects

    env = gym.make(env_id).unwrapped
    obs, info = env.reset(seed=4)
    next(iter(env.sim.space.bodies)).position = (math.nan, 0.0)
    obs2, _, terminated, _, info2 = env.step(np.zeros(3, np.float32))
    assert terminated and info2["termination_reason"] == "physics_breakdown"
    assert info2["episode_spec"] == info["episode_spec"]
    assert not data_shares_objects(info, info2) and not data_shares_objects(obs, obs2)
