"""One argument check for the whole package.

Every argument, reset option, action and goal is checked by :mod:`planar3p_gym.checks`: Python
and NumPy numbers alike, booleans, complex numbers and strings rejected, ``ValueError`` (never
another exception type) with a message naming the argument; accepted reset options keep the
observation inside ``observation_space``; the native vector env checks exactly as the single
env, rejects atomically and pickles; a time-out has one name, ``"time_limit"``.
"""

from __future__ import annotations

import copy
import math
import pickle

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import planar3p_gym
from planar3p_gym import checks
from planar3p_gym.envs.end_reason import END_REASONS, EndReason, end_reason, restore_state
from planar3p_gym.envs.vector import Planar3PVectorEnv
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks.goal import goal_of_pose

IDS = [row.id for row in planar3p_gym.ENV_SPECS]
FLAT_IDS = [i for i in IDS if "Goal" not in i]

BIG = 10**400
#: Values no numeric, integer or flag argument accepts.
NOT_NUMBERS = [
    True,
    np.bool_(False),
    1 + 2j,
    np.complex128(0.5),
    "0.5",
    b"1",
    [0.5],
    {"x": 1},
    object(),
    float("nan"),
    float("inf"),
    np.float64("-inf"),
    BIG,
]


def _named(exc: pytest.ExceptionInfo, name: str) -> None:
    assert exc.type is ValueError
    assert name in str(exc.value), (name, str(exc.value))


# ------------------------------------------------------------------ the check module itself
_REALS = st.one_of(
    st.integers(-(2**31), 2**31),
    st.floats(-1e6, 1e6, allow_nan=False),
)


@settings(derandomize=True, deadline=None, max_examples=150)
@given(
    x=_REALS,
    kind=st.sampled_from(["py", "f64", "f32", "i64", "0d"]),
    low=st.sampled_from([None, -1.0, 0.0]),
)
def test_python_and_numpy_numbers_are_accepted_alike(x, kind, low):
    """``checks.number`` gives the same answer for a value as a Python number, a NumPy
    scalar of any real dtype or a 0-d array (float32 rounding aside)."""
    if kind == "f32":
        x = float(np.float32(x))
    value = {
        "py": x,
        "f64": np.float64(x),
        "f32": np.float32(x),
        "i64": np.int64(int(x)) if float(x).is_integer() else np.float64(x),
        "0d": np.array(x),
    }[kind]
    try:
        expected = checks.number(float(x), "arg", low=low)
    except ValueError:
        with pytest.raises(ValueError, match="arg"):
            checks.number(value, "arg", low=low)
    else:
        assert checks.number(value, "arg", low=low) == expected
    n = int(x)
    assert checks.integer(np.int64(n), "n") == checks.integer(n, "n") == n


@pytest.mark.parametrize("value", NOT_NUMBERS, ids=lambda v: type(v).__name__)
def test_non_numbers_raise_value_errors_naming_the_argument(value):
    for check in (
        lambda v: checks.number(v, "the_arg"),
        lambda v: checks.integer(v, "the_arg") if v is not BIG else 1 / 0,  # (an int)
        lambda v: checks.mode_from(v, "the_arg"),
        lambda v: checks.numbers(v, 3, "the_arg"),
        lambda v: checks.flag(v, "the_arg") if not isinstance(v, (bool, np.bool_)) else 1 / 0,
    ):
        try:
            check(value)
        except ZeroDivisionError:
            continue  # (a bool is a flag, a big int an integer)
        except Exception as exc:
            assert type(exc) is ValueError and "the_arg" in str(exc), (value, exc)
        else:
            raise AssertionError(f"accepted {value!r}")


@settings(derandomize=True, deadline=None, max_examples=100)
@given(
    entries=st.lists(
        st.one_of(
            st.sampled_from([1, -1, 1.0, -1.0, np.int8(1), np.int64(-1), np.float32(1.0)]),
            st.sampled_from([0, 2, 0.5, True, False, np.bool_(True), math.inf, math.nan, "1"]),
            st.sampled_from([10**400, 1j, None]),
        ),
        min_size=0,
        max_size=4,
    )
)
def test_working_modes_are_three_signs_and_nothing_else(entries):
    """Item 6: ``(1, 1, inf)`` raised OverflowError, ``(True, True, -1)`` was accepted."""
    ok = len(entries) == 3 and all(
        not isinstance(v, (bool, np.bool_, str)) and v is not None and v in (1, -1) for v in entries
    )
    if ok:
        assert checks.mode_from(entries) == tuple(int(v) for v in entries)
    else:
        with pytest.raises(ValueError, match="working_mode"):
            checks.mode_from(entries)
        with pytest.raises(ValueError, match="working_mode"):
            checks.mode_from(tuple(entries))


# ------------------------------------------------------------------ constructor arguments
#: (id, argument, a valid NumPy value, the Python value it equals).
NUMPY_ARGUMENTS = [
    ("Planar3P-v0", "control_frequency", np.float32(50.0), 50.0),
    ("Planar3P-v0", "substeps", np.int32(4), 4),
    ("Planar3P-v0", "breakdown_threshold", np.float64(0.02), 0.02),
    ("Planar3P-v0", "travel_goal", np.bool_(True), True),
    ("Planar3PTrack-v0", "speed_fraction", np.float32(0.5), 0.5),
    ("Planar3PTrack-v0", "duration", np.int64(5), 5.0),
    ("Planar3PModeChange-v0", "flips", np.int64(1), 1),
    ("Planar3PModeChange-v0", "travel_shaping", np.float32(0.25), 0.25),
    ("Planar3PAssemblyChange-v0", "travel_shaping", np.int16(1), 1.0),
]


@pytest.mark.parametrize(("env_id", "name", "value", "plain"), NUMPY_ARGUMENTS)
def test_numpy_numbers_are_accepted_as_arguments(env_id, name, value, plain):
    """Item 6: Track rejected ``speed_fraction=np.float32(0.5)``, ModeChange ``flips=
    np.int64(1)``; NumPy numbers now configure an environment as Python numbers do."""
    a = gym.make(env_id, **{name: value}).unwrapped
    b = gym.make(env_id, **{name: plain}).unwrapped
    assert a.config() == b.config()


#: (id, argument) pairs that take a number, an integer or a flag.
SCALAR_ARGUMENTS = [
    ("Planar3P-v0", "control_frequency"),
    ("Planar3P-v0", "substeps"),
    ("Planar3P-v0", "solver_iterations"),
    ("Planar3P-v0", "breakdown_threshold"),
    ("Planar3P-v0", "projection"),
    ("Planar3P-v0", "travel_goal"),
    ("Planar3PTrack-v0", "speed_fraction"),
    ("Planar3PTrack-v0", "duration"),
    ("Planar3PModeChange-v0", "flips"),
    ("Planar3PModeChange-v0", "travel_shaping"),
    ("Planar3PAssemblyChange-v0", "travel_shaping"),
    ("Planar3PGoal-v0", "control_frequency"),
]


@settings(derandomize=True, deadline=None, max_examples=60)
@given(
    target=st.sampled_from(SCALAR_ARGUMENTS),
    value=st.sampled_from(NOT_NUMBERS + [1 + 0j, np.float32("nan"), -(10**400)]),
)
def test_bad_scalar_arguments_raise_value_errors_naming_them(target, value):
    """Item 6: ``speed_fraction=True`` was accepted; every scalar argument now rejects
    booleans (where it is not a flag), complex numbers, strings and non-finite numbers with a
    ``ValueError`` naming it."""
    env_id, name = target
    flag = name in ("projection", "travel_goal")
    if flag and isinstance(value, (bool, np.bool_)):
        return
    with pytest.raises(Exception) as exc:  # (the type is asserted below)
        gym.make(env_id, **{name: value})
    _named(exc, name)


@pytest.mark.parametrize(
    ("env_id", "kwargs", "name"),
    [
        ("Planar3PModeChange-v0", {"path_limits": {"bogus": 1}}, "path_limits"),
        ("Planar3PModeChange-v0", {"path_limits": {"points": 2.5}}, "points"),
        ("Planar3PModeChange-v0", {"path_limits": {"max_holding_force": True}}, "max_holding"),
        ("Planar3PModeChange-v0", {"path_limits": "strict"}, "path_limits"),
        ("Planar3PAssemblyChange-v0", {"crossing_limits": {"bogus": 1}}, "crossing_limits"),
        ("Planar3PAssemblyChange-v0", {"crossing_limits": {"verify": 1}}, "verify"),
        ("Planar3PAssemblyChange-v0", {"crossing_limits": {"speed_fraction": 2j}}, "speed"),
        ("Planar3P-v0", {"working_mode": (1, 1, math.inf)}, "working_mode"),
        ("Planar3P-v0", {"working_mode": (True, True, -1)}, "working_mode"),
        ("Planar3PAssemblyChange-v0", {"working_mode": (1, 1, 10**400)}, "working_mode"),
        ("Planar3P-v0", {"task_config": {"bogus": 1}}, "task_config"),
        ("Planar3P-v0", {"task_config": {"rest_speed": 1j}}, "rest_speed"),
        ("Planar3P-v0", {"reward_weights": {"pose": "1"}}, "pose"),
        ("Planar3P-v0", {"render_size": (640.0, 480)}, "render_size"),
        ("Planar3PTrack-v0", {"reference": 3}, "reference"),
        ("Planar3PGoal-v0", {"reward_type": None}, "reward_type"),
        ("Planar3P-v0", {"design": {"stroke": True}}, "stroke"),
        ("Planar3P-v0", {"design": 8}, "design"),
    ],
)
def test_structured_arguments_raise_value_errors_naming_the_field(env_id, kwargs, name):
    """Item 6: ``path_limits={"bogus": 1}`` and ``crossing_limits={...}`` raised TypeError and
    ``working_mode=(1, 1, inf)`` OverflowError."""
    with pytest.raises(Exception) as exc:
        gym.make(env_id, **kwargs)
    _named(exc, name)


def test_render_arguments_are_checked():
    from planar3p_gym.envs.core import Planar3PEnv

    for kwargs, name in (
        ({"render_mode": ["human"]}, "render_mode"),
        ({"render_mode": "video"}, "render_mode"),
        ({"render_size": (640, True)}, "render_size"),
        ({"render_size": (np.int64(640), np.uint16(480))}, None),
    ):
        if name is None:
            assert Planar3PEnv(**kwargs).render_size == (640, 480)
            continue
        with pytest.raises(Exception) as exc:
            Planar3PEnv(**kwargs)
        _named(exc, name)


@pytest.mark.parametrize(
    "changes",
    [
        {"leg_lengths": (1e150, 1e150, 1e150), "spacings": (1e149, 1e149, 1e149)},
        {"stroke": 1e150},
        {"max_speed": 1e300},
        {"max_force": 1e-12},
        {"rail_origins": (0.0, 0.0, 1e200)},
    ],
)
def test_extreme_designs_are_rejected(changes):
    """Item 6: a design with 1e150 m legs was accepted and gave infinite bounds and
    observations; the environments accept designs within :data:`checks.DESIGN_LIMITS`."""
    try:
        design = Design.fig8().with_(**changes)
    except ValueError:
        return  # (some are no design at all)
    field = next(iter(changes))
    for env_id in ("Planar3P-v0", "Planar3PTrack-v0"):
        with pytest.raises(ValueError, match=f"design.{field}"):
            gym.make(env_id, design=design)


def test_accepted_designs_have_finite_spaces():
    for design in (Design.fig8(), Design.fig7(), Design.fig8(gravity=0.0)):
        space = gym.make("Planar3P-v0", design=design).observation_space
        assert np.isfinite(space.low).all() and np.isfinite(space.high).all()


# ------------------------------------------------------------------ actions
#: Actions the single environment rejects, of every kind the issue's fuzz found.
BAD_ACTIONS = [
    "abc",
    ["1", "0", "0"],
    [True, False, True],
    np.array([True, False, True]),
    [1 + 1j, 0, 0],
    np.array([0.5j, 0, 0]),
    [0.0, math.nan, 0.0],
    [math.inf, 0.0, 0.0],
    [10**400, 0, 0],
    [0.0, 0.0],
    [[0.0, 0.0, 0.0]],
    None,
    {"a": 1},
]


@pytest.mark.parametrize("action", BAD_ACTIONS, ids=lambda a: type(a).__name__)
def test_the_single_env_rejects_bad_actions_with_value_errors(action):
    env = gym.make("Planar3P-v0")
    env.reset(seed=0)
    before = env.unwrapped.get_state()
    with pytest.raises(ValueError, match="action"):
        env.step(action)
    assert pickle.dumps(env.unwrapped.get_state()) == pickle.dumps(before)


def test_torch_tensors_are_actions_or_value_errors():
    """Item 6: a tensor that requires grad raised RuntimeError."""
    torch = pytest.importorskip("torch")
    env = gym.make("Planar3P-v0")
    env.reset(seed=0)
    env.step(torch.zeros(3))
    env.step(torch.zeros(3, dtype=torch.float64))
    with pytest.raises(ValueError, match="action"):
        env.step(torch.zeros(3, requires_grad=True))
    with pytest.raises(ValueError, match="action"):
        env.step(torch.zeros(3, dtype=torch.complex64))


@settings(derandomize=True, deadline=None, max_examples=40)
@given(
    kind=st.sampled_from(BAD_ACTIONS[:10]),
    row=st.integers(0, 1),
    batch=st.sampled_from(["scalar", "numpy"]),
)
def test_the_vector_env_checks_actions_as_the_single_env(kind, row, batch):
    """Item 7: the native vector env accepted string, bool and complex actions that the single
    env rejects; now a batch with one bad row raises ``ValueError`` and no environment steps."""
    venv = Planar3PVectorEnv(num_envs=2, batch=batch)
    venv.reset(seed=1)
    before = pickle.dumps(venv.get_state())
    actions: list = [[0.1, 0.2, 0.3], [0.1, 0.2, 0.3]]
    if isinstance(kind, (list, tuple)) and len(kind) == 3:
        actions[row] = kind
    elif isinstance(kind, np.ndarray):
        actions = np.stack([kind, kind])
    else:
        actions = kind
    with pytest.raises(ValueError, match="action"):
        venv.step(actions)
    assert pickle.dumps(venv.get_state()) == before
    for good in ([[0.1, 0.2, 0.3]] * 2, np.zeros((2, 3), np.float32), [(1, 0, -1), (0, 0, 0)]):
        venv.step(good)


# ------------------------------------------------------------------ goals (item 5)
def test_goals_outside_the_goal_space_are_rejected():
    """Item 5: a desired goal with speed 50 m/s, or (cos, sin) scaled by 1.3, was accepted and
    left the observation outside ``observation_space``."""
    env = gym.make("Planar3PGoal-v0")
    _, info = env.reset(seed=3)
    x, y, th = info["episode_spec"]["target"]
    c, s = math.cos(th), math.sin(th)
    with pytest.raises(ValueError, match="speed"):
        env.reset(options={"desired_goal": [x, y, c, s, 50.0]})
    with pytest.raises(ValueError, match="desired_goal"):
        env.reset(options={"desired_goal": [x, y, 1.3 * c, 1.3 * s, 0.0]})
    with pytest.raises(ValueError, match="desired_goal"):
        env.reset(options={"desired_goal": [x, y, c, s, 1j]})
    obs, _ = env.reset(options={"desired_goal": [x, y, c, s, 0.05]})
    assert env.observation_space.contains(obs)


@settings(derandomize=True, deadline=None, max_examples=60)
@given(
    scale=st.floats(0.3, 2.5),
    speed=st.floats(-1.0, 100.0),
    shift=st.floats(-0.05, 0.05),
)
def test_every_accepted_goal_keeps_the_observation_in_its_space(goal_case, scale, speed, shift):
    env, (x, y, th) = goal_case
    goal = [x + shift, y, scale * math.cos(th), scale * math.sin(th), speed]
    try:
        obs, _ = env.reset(options={"desired_goal": goal})
    except ValueError as exc:
        assert "desired_goal" in str(exc)
        return
    assert env.observation_space.contains(obs)
    obs, *_ = env.step(np.zeros(3, np.float32))
    assert env.observation_space.contains(obs)


@pytest.fixture(scope="module")
def goal_case():
    """A goal env and the target pose of one of its episodes."""
    env = gym.make("Planar3PGoal-v0")
    _, info = env.reset(seed=5)
    return env, tuple(info["episode_spec"]["target"])


@pytest.fixture(scope="module")
def goal_env(goal_case):
    return goal_case[0]


@pytest.mark.parametrize(
    "bad",
    [
        np.array([0.1, 0.2, 1.0, 0.0, 0.0]) + 1j,
        [0.1, 0.2, 1.0, 0.0, True],
        ["0.1", 0.2, 1.0, 0.0, 0.0],
        [0.1, 0.2, 1.0, 0.0],
        np.zeros((2, 4)),
        [0.1, 0.2, 1.0, 0.0, math.nan],
    ],
    ids=["complex", "bool", "str", "four", "four-batch", "nan"],
)
def test_goal_functions_check_their_goals(goal_env, bad):
    """Item 6: ``compute_reward`` accepted complex goals (and said goals have 4 entries);
    ``compute_truncated`` checked nothing."""
    env = goal_env.unwrapped
    good = goal_of_pose((0.1, 0.2, 0.0))
    for fn in (env.compute_reward, env.compute_terminated, env.compute_truncated):
        with pytest.raises(ValueError, match="goal") as exc:
            fn(bad, good, {})
        if np.shape(bad)[-1:] == (4,):
            assert "5" in str(exc.value)
        with pytest.raises(ValueError, match="goal"):
            fn(good, bad, {})
    assert "(5,)" in type(env).compute_reward.__doc__
    with pytest.raises(ValueError, match="info"):
        env.compute_truncated(good, good, ["not a dict"])
    assert env.compute_truncated(good, good, {}) is False
    assert env.compute_truncated(np.stack([good] * 3), np.stack([good] * 3), None).shape == (3,)


# ------------------------------------------------------------------ the native vector env
def test_a_rejected_vector_reset_changes_no_environment():
    """Item 7: ``reset(seed=11, options={"start": s})`` under ``working_mode="random"`` reset
    env 0 and then failed on env 1 (whose drawn mode cannot reach ``s``)."""
    single = gym.make("Planar3P-v0", working_mode="random").unwrapped
    _, info = single.reset(seed=11)
    start = info["episode_spec"]["start"]
    for batch in ("scalar", "numpy"):
        venv = Planar3PVectorEnv(num_envs=2, working_mode="random", batch=batch)
        venv.reset(seed=3)
        venv.step(np.full((2, 3), 0.5, np.float32))
        before = pickle.dumps(venv.get_state())
        with pytest.raises(ValueError, match="not reachable"):
            venv.reset(seed=11, options={"start": start})
        assert pickle.dumps(venv.get_state()) == before
        with pytest.raises(ValueError, match="seed"):
            venv.reset(seed=[1, "2"])
        with pytest.raises(ValueError, match="seed"):
            venv.reset(seed=True)
        assert pickle.dumps(venv.get_state()) == before


def _run(venv, actions):
    out = []
    for a in actions:
        obs, rew, term, trunc, _ = venv.step(a)
        out.append((obs.tobytes(), rew.tobytes(), term.tobytes(), trunc.tobytes()))
    return out


@pytest.mark.parametrize(
    ("env_id", "batch"),
    [
        ("Planar3P-v0", "scalar"),
        ("Planar3P-v0", "numpy"),
        ("Planar3P-v0", "per-env"),
        ("Planar3PTrack-v0", "auto"),
    ],
)
def test_native_vector_envs_pickle_and_deep_copy(env_id, batch):
    """Item 7: the native vector env failed ``deepcopy`` and ``pickle`` (a cffi handle); the
    copies now continue bit for bit, time limit and autoresets included."""
    kwargs = {"projection": False} if batch == "per-env" else {"batch": batch}
    venv = gym.make_vec(env_id, num_envs=3, max_episode_steps=15, **kwargs)
    venv.reset(seed=2)
    actions = np.random.default_rng(0).uniform(-1, 1, (40, 3, 3)).astype(np.float32)
    _run(venv, actions[:7])
    copies = [copy.deepcopy(venv), pickle.loads(pickle.dumps(venv))]
    expected = _run(venv, actions[7:])
    for twin in copies:
        assert _run(twin, actions[7:]) == expected


def test_restore_state_sets_the_time_limit_counter_of_a_made_env():
    """Item 7: ``set_state`` did not restore the ``TimeLimit`` step counter of a made env, so a
    restored episode was truncated at another step than the original."""
    env = gym.make("Planar3P-v0", max_episode_steps=30)
    env.reset(seed=4)
    for _ in range(10):
        env.step(np.zeros(3, np.float32))
    snap = env.unwrapped.get_state()
    twin = gym.make("Planar3P-v0", max_episode_steps=30)
    twin.reset(seed=9)
    for _ in range(25):  # (its own counter far ahead of the snapshot's)
        twin.step(np.zeros(3, np.float32))
    restore_state(twin, pickle.loads(pickle.dumps(snap)))
    ends = []
    for e in (env, twin):
        for k in range(1, 40):
            *_, terminated, truncated, _ = e.step(np.zeros(3, np.float32))
            if terminated or truncated:
                ends.append((k, terminated, truncated))
                break
    assert ends[0] == ends[1] == (20, False, True)
    # the same through the opt-in wrapper, and a bad snapshot changes nothing
    wrapped = EndReason(gym.make("Planar3P-v0", max_episode_steps=30))
    wrapped.reset()
    wrapped.set_state(snap)
    with pytest.raises(ValueError, match="snapshot"):
        wrapped.set_state({"sim": None})


# ------------------------------------------------------------------ end names (item 9)
def test_a_time_out_has_one_name():
    """Item 9: ``info["termination_reason"]`` was ``None`` on a time-out while the training
    metrics said ``time_limit`` and the benchmark ``timeout``/``timeouts``.  The names are
    :data:`END_REASONS`; :func:`end_reason` names a time-out ``"time_limit"`` and the
    :class:`EndReason` wrapper puts it in ``info``."""
    assert END_REASONS == ("success", "singularity_crossing", "physics_breakdown", "time_limit")
    for env_id in IDS:
        env = EndReason(gym.make(env_id, max_episode_steps=3))
        env.reset(seed=0)
        for _ in range(3):
            _, _, terminated, truncated, info = env.step(env.action_space.sample() * 0)
        assert truncated and not terminated, env_id
        assert info["termination_reason"] == "time_limit"
        assert end_reason(terminated, truncated, {"termination_reason": None}) == "time_limit"
    assert end_reason(True, False, {"termination_reason": "success"}) == "success"
    assert end_reason(False, False, {"termination_reason": None}) is None
