"""The built machine in the environment: randomised dynamics, encoder observations,
latency and on-off motors; the realistic ids."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import planar3p_gym
from planar3p_gym.envs.actuation import on_off_action
from planar3p_gym.envs.core import Planar3PEnv
from planar3p_gym.sim.randomization import REALISTIC_RANDOMIZATION
from planar3p_gym.sim.sensors import REALISTIC_SENSORS
from planar3p_gym.tasks.observation import SLICES

REAL_IDS = (planar3p_gym.REAL_ENV_ID, planar3p_gym.REAL_ON_OFF_ENV_ID)
#: A nonzero range of every randomised quantity (tests/sim/test_randomization.py has them all).
RANGES = {
    "mass": 0.2,
    "inertia": 0.5,
    "leg_length": 1e-3,
    "joint_position": 1e-3,
    "rail_offset": 1e-3,
    "max_force": 0.2,
    "slider_coulomb": 2.0,
    "slider_viscous": 5.0,
    "joint_coulomb": 0.01,
    "joint_viscous": 0.002,
    "servo_lag": 0.04,
    "gravity_tilt": 0.02,
}


def _stream(env: gym.Env, seed: int = 5, steps: int = 40) -> list:
    """Observations, rewards and true poses of ``steps`` seeded random steps (resets included)."""
    env.action_space.seed(seed)
    obs, info = env.reset(seed=seed)
    out = [obs, info["pose"]]
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        assert np.isfinite(obs).all() and np.isfinite(reward)
        out += [obs, reward, info["pose"], info["rho"]]
        if terminated or truncated:
            obs, info = env.reset()
            out += [obs, info["pose"]]
    return out


def _same(a: list, b: list) -> bool:
    return len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


def test_zero_ranges_and_no_delay_are_the_default_environment_bit_for_bit():
    default = _stream(gym.make("Planar3P-v0"))
    assert _same(default, _stream(gym.make("Planar3P-v0", randomization={}, latency={})))
    assert _same(default, _stream(gym.make("Planar3P-v0", latency={"action_delay": (0, 0)})))


@pytest.mark.parametrize("name", sorted(RANGES))
def test_each_randomised_quantity_changes_the_episode(name):
    # (seed 6: a servo saturates in its 40 steps; the force limit changes an episode only then,
    # and seed 5's episode has no saturation)
    default = _stream(gym.make("Planar3P-v0"), seed=6)
    env = gym.make("Planar3P-v0", randomization={name: RANGES[name]})
    changed = _stream(env, seed=6)
    assert not _same(default, changed)
    # The task's draws come first: the same start and target as the nominal machine.
    assert np.array_equal(
        default[0][SLICES["target_position"]], changed[0][SLICES["target_position"]]
    )
    machine = env.unwrapped.machine.episode.machine
    assert machine.design != env.unwrapped.design or not machine.dynamics.is_ideal
    assert env.unwrapped.sim.design == machine.design  # the projection's geometry is the drawn one


@pytest.mark.parametrize("env_id", REAL_IDS)
def test_the_realistic_ids_pass_both_checkers_and_replay_per_seed(env_id):
    env = gym.make(env_id)
    check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(env.unwrapped)
    assert _same(_stream(gym.make(env_id), steps=60), _stream(gym.make(env_id), steps=60))
    assert not _same(_stream(gym.make(env_id), seed=5), _stream(gym.make(env_id), seed=6))


def test_the_discrete_on_off_variant_passes_both_checkers():
    env = gym.make(planar3p_gym.REAL_ENV_ID, action_type="on-off-discrete")
    assert env.action_space == gym.spaces.Discrete(27)
    check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(env.unwrapped)


def test_with_sensors_the_policy_sees_readings_and_success_is_judged_on_the_true_state():
    env = gym.make(planar3p_gym.REAL_ENV_ID).unwrapped
    obs, info = env.reset(seed=0)
    seen = obs[SLICES["position"]]
    true = np.array(info["pose"][:2])
    # The nominal model's pose is off by the drawn millimetre errors (a few mm at most) ...
    assert 0.0 < np.abs(seen - true).max() < 0.01
    # ... and the errors of info are the true pose's.
    target = np.array(env.target[:2])
    assert info["position_error"] == pytest.approx(np.linalg.norm(target - true), abs=1e-12)


def test_action_delay_executes_each_action_its_steps_later():
    """With a delay of 2 the machine runs exactly as an undelayed one told to stop twice first."""
    late = gym.make("Planar3P-v0", latency={"action_delay": 2}).unwrapped
    plain = gym.make("Planar3P-v0", randomization={"mass": 0.0}).unwrapped
    late.reset(seed=1)
    plain.reset(seed=1)
    rng = np.random.default_rng(0)
    actions = [rng.uniform(-1, 1, 3) for _ in range(8)]
    stop = np.zeros(3)
    for a, b in zip(actions, [stop, stop, *actions[:-2]], strict=True):
        assert late.step(a)[4]["rho"] == plain.step(b)[4]["rho"]


def test_observation_delay_shows_earlier_observations():
    plain = gym.make("Planar3P-v0", latency={"action_delay": 0}).unwrapped
    late = gym.make("Planar3P-v0", latency={"observation_delay": 1}).unwrapped
    a, _ = plain.reset(seed=2)
    b, _ = late.reset(seed=2)
    assert np.array_equal(a, b)
    previous = a
    for _ in range(5):
        action = np.array([0.5, -0.3, 0.2], dtype=np.float32)
        a = plain.step(action)[0]
        b = late.step(action)[0]
        assert np.array_equal(b, previous)
        previous = a


def test_delays_are_drawn_per_episode_from_their_range():
    env = gym.make("Planar3P-v0", latency={"action_delay": (0, 2), "observation_delay": (1, 2)})
    seen = set()
    for seed in range(40):
        _, info = env.reset(seed=seed)
        seen.add(info["delays"])
    assert {d[0] for d in seen} == {0, 1, 2} and {d[1] for d in seen} == {1, 2}


def test_on_off_actions():
    assert on_off_action(np.array([0, 1, 2]), "on-off") == (0.0, 1.0, -1.0)
    assert on_off_action(5, "on-off-discrete") == (0.0, 1.0, -1.0)  # 5 = 0 * 9 + 1 * 3 + 2
    assert on_off_action(np.int64(26), "on-off-discrete") == (-1.0, -1.0, -1.0)
    assert on_off_action(np.array([26]), "on-off-discrete") == (-1.0, -1.0, -1.0)
    # integral floats, as the three commands accept them (a runner's float64 array of one)
    assert on_off_action(np.array([9.0]), "on-off-discrete") == (1.0, 0.0, 0.0)
    assert on_off_action(26.0, "on-off-discrete") == (-1.0, -1.0, -1.0)
    for bad in (27, -1, 2.5, 27.0, np.nan, True, 1j, np.array([1, 2])):
        with pytest.raises(ValueError, match="action"):
            on_off_action(bad, "on-off-discrete")
    env = gym.make("Planar3P-v0", action_type="on-off").unwrapped
    env.reset(seed=3)
    before = env.get_state()
    for bad in ([0, 1, 3], [0.5, 0, 0], [0, 1], "abc", [np.nan, 0, 0], [True, 0, 0]):
        with pytest.raises(ValueError, match="action"):
            env.step(bad)
    assert env.get_state()["sim"] == before["sim"]
    # Forward, backward, stop: the slider commands +-on_off_speed max_speed, 0.
    plain = gym.make("Planar3P-v0", latency={"action_delay": 0}).unwrapped
    plain.reset(seed=3)
    v = env.on_off_speed
    for _ in range(3):
        got = env.step(np.array([1, 2, 0]))[4]
        want = plain.step(np.array([v, -v, 0.0]))[4]
        assert got["rho"] == want["rho"]
    assert got["rho"][0] > plain.reset(seed=3)[1]["rho"][0]


def test_snapshots_of_the_realistic_id_continue_bit_for_bit():
    env = gym.make(planar3p_gym.REAL_ENV_ID).unwrapped
    env.reset(seed=4)
    action = np.array([0.3, -0.2, 0.1], dtype=np.float32)
    for _ in range(5):
        env.step(action)
    snap = env.get_state()
    ahead = [env.step(action)[0] for _ in range(5)]
    other = Planar3PEnv(**gym.spec(planar3p_gym.REAL_ENV_ID).kwargs)
    other.set_state(snap)
    again = [other.step(action)[0] for _ in range(5)]
    assert _same(ahead, again)


@pytest.mark.parametrize(
    "kwargs,name",
    [
        ({"randomization": {"mass": -1.0}}, "randomization"),
        ({"randomization": {"weight": 1.0}}, "randomization"),
        ({"sensors": {"slider_noise": -1.0}}, "sensors"),
        ({"latency": {"action_delay": 3}}, "latency"),
        ({"latency": {"observation_delay": (2, 1)}}, "latency"),
        ({"action_type": "bang-bang"}, "action_type"),
        ({"on_off_speed": 0.0}, "on_off_speed"),
    ],
)
def test_bad_arguments_name_themselves(kwargs, name):
    with pytest.raises(ValueError, match=name):
        Planar3PEnv(**kwargs)


def test_a_start_out_of_every_drawn_machine_s_reach_falls_back_to_the_nominal_machine(
    monkeypatch,
):
    """When no draw reaches the start (none allowed here), the episode runs the nominal
    machine, not the previous episode's."""
    import planar3p_gym.envs.actuation as core

    env = gym.make("Planar3P-v0", randomization={"rail_offset": 1e-3, "servo_lag": 0.01}).unwrapped
    env.reset(seed=0)
    assert env.sim.design != env.design and env.sim.dynamics is not None
    monkeypatch.setattr(core, "MACHINE_DRAWS", 0)
    env.reset(seed=1)
    assert env.sim.design == env.design and env.sim.dynamics is None
    assert env.machine.episode.true_kin.design == env.design


def test_the_realistic_ranges_keep_the_task_solvable_in_principle():
    """Every drawn machine closes at the sampled starts (no fallback to the nominal one) and the
    nominal model's pose error stays within a few millimetres: the realistic defaults are
    manufacturing errors, not another machine."""
    env = gym.make("Planar3P-v0", randomization=REALISTIC_RANDOMIZATION.to_dict(),
                   sensors=REALISTIC_SENSORS.to_dict()).unwrapped  # fmt: skip
    for seed in range(20):
        obs, info = env.reset(seed=seed)
        assert env.machine.episode.machine.design != env.design
        assert np.abs(obs[SLICES["position"]] - np.array(info["pose"][:2])).max() < 0.005


# ------------------------------------------------------------------ control rates and resets
@pytest.mark.parametrize("env_id", REAL_IDS)
@pytest.mark.parametrize("frequency", [2.0, 5.0, 8.0, 10.0])
def test_a_control_rate_whose_step_cannot_take_every_drawn_machine_is_refused(env_id, frequency):
    """At these rates ``reset()`` raised for some seeds (a drawn slider friction too strong for
    the physics step); now the constructor refuses them, naming the lowest rate it accepts
    (slider_viscous up to 5 N s/m on sliders as light as 0.9 x 0.5 kg: h < 0.09 s), and so does
    the native vector env."""
    with pytest.raises(ValueError, match=r"control_frequency must exceed 11\.11 Hz at substeps=1"):
        gym.make(env_id, control_frequency=frequency)
    with pytest.raises(ValueError, match="control_frequency must exceed"):
        gym.make_vec(
            env_id, num_envs=2, vectorization_mode="vector_entry_point", control_frequency=frequency
        )
    env = gym.make(env_id, control_frequency=frequency, substeps=2 if frequency > 5 else 6)
    for seed in range(50, 60):  # more physics steps per control step: accepted, and resets
        env.reset(seed=seed)


def test_at_the_lowest_accepted_rate_every_reset_and_autoreset_works():
    """Just above the bound every seed resets, in the single env and through the native vector
    env's autoresets (which crashed at 10 Hz)."""
    env = gym.make(planar3p_gym.REAL_ENV_ID, control_frequency=11.2)
    for seed in range(200):
        env.reset(seed=seed)
    venv = gym.make_vec(
        planar3p_gym.REAL_ENV_ID,
        num_envs=2,
        vectorization_mode="vector_entry_point",
        control_frequency=11.2,
        max_episode_steps=3,
    )
    venv.reset(seed=0)
    for _ in range(40):  # ten episodes per env, each ended by the limit and reset
        obs, *_ = venv.step(venv.action_space.sample())
        assert np.isfinite(obs).all()


def test_a_reset_that_raises_changes_nothing(monkeypatch):
    """A reset whose drawn machine is refused (here: every draw) left the env half-reset: a new
    target, a reseeded generator, the old simulation, and step still accepted.  Now it changes
    nothing: the env steps on exactly as one that never tried."""
    from planar3p_gym.sim.randomization import DynamicsRandomization

    env, ref = gym.make(planar3p_gym.REAL_ENV_ID).unwrapped, gym.make(planar3p_gym.REAL_ENV_ID)
    env.reset(seed=50)
    ref.reset(seed=50)
    env.action_space.seed(1)
    ref.action_space.seed(1)
    env.step(env.action_space.sample())
    ref.step(ref.action_space.sample())
    target, sim, rng = env.target, env.sim, env.np_random.bit_generator.state

    def refuse(self, nominal, rng):
        raise ValueError("the drawn geometry cannot close")

    with monkeypatch.context() as m:
        m.setattr(DynamicsRandomization, "sample", refuse)
        with pytest.raises(ValueError, match="cannot close"):
            env.reset(seed=51)
    assert env.target == target and env.sim is sim and env.np_random.bit_generator.state == rng
    want = _stream_on(ref)
    assert _same(_stream_on(env), want)


def _stream_on(env: gym.Env, steps: int = 20) -> list:
    """Observations, rewards and poses of ``steps`` random steps and then of a reset."""
    out = []
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        out += [obs, reward, info["pose"]]
        if terminated or truncated:
            break
    obs, info = env.reset()
    return [*out, obs, info["pose"], info["machine"]["design"]["leg_lengths"]]
