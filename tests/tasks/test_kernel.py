"""The task kernel contract (:mod:`planar3p_gym.tasks.kernel`)."""

from __future__ import annotations

import math
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import planar3p_gym  # noqa: F401  (registers the ids)
from planar3p_gym.envs.core import Planar3PEnv
from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.machine.norm import hypot
from planar3p_gym.tasks import ReachTask
from planar3p_gym.tasks.base import COMPILED_HOOKS
from planar3p_gym.tasks.goal import GoalKernel
from planar3p_gym.tasks.kernel import CompiledKernel, HookKernel, ReachKernel, StepKernel
from planar3p_gym.tasks.observation import pose_errors
from planar3p_gym.tasks.track import TrackKernel


class _Recording(ReachTask):
    """The reach task recording what its hooks are handed."""

    name: ClassVar[str] = "recording"
    observation_fields = (("one", 1, "a constant"),)

    def bind(self, env: Any) -> None:
        super().bind(env)
        self.seen: list[tuple] = []

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return np.zeros(1, np.float32), np.ones(1, np.float32)

    def observation_extra(self, step: int, state: Any, measures: Any) -> list[float]:
        self.seen.append((step, state, measures))
        return [1.0]


@pytest.mark.parametrize(
    ("env_id", "kernel"),
    [
        ("Planar3P-v0", ReachKernel),
        ("Planar3PReal-v0", StepKernel),
        ("Planar3PGoal-v0", GoalKernel),
        ("Planar3PGoalDense-v0", GoalKernel),
        ("Planar3PTrack-v0", TrackKernel),
        ("Planar3PModeChange-v0", HookKernel),
        ("Planar3PAssemblyChange-v0", HookKernel),
    ],
)
def test_each_task_picks_its_kernel(env_id, kernel):
    """The compiled reach kernel on the projected physics of the nominal machine, for the
    reach task's own hooks; the reference (the hooks) everywhere else."""
    env = gym.make(env_id).unwrapped
    assert type(env.kernel) is kernel
    env.close()


@pytest.mark.parametrize(
    ("env_id", "family"),
    [
        ("Planar3P-v0", "reach"),
        ("Planar3PReal-v0", "reach"),
        ("Planar3PGoal-v0", "goal"),
        ("Planar3PTrack-v0", "track"),
        ("Planar3PModeChange-v0", "mode_change"),
        ("Planar3PAssemblyChange-v0", "assembly_change"),
    ],
)
def test_a_task_s_compiled_hooks_are_its_class_s_own(env_id, family):
    """Each task's compiled hooks are named by its class; a subclass keeps them while its
    per-step hooks are the class's and loses them (the reference kernel, its hooks) when it
    overrides one, whatever other methods it adds."""
    env = gym.make(env_id).unwrapped
    cls = type(env.task)
    assert env.task.compiled_family == family
    same = type("Same", (cls,), {"describe": lambda self: "a method that is not a hook"})
    assert object.__new__(same).compiled_family == family
    for hook in COMPILED_HOOKS:
        method = getattr(cls, hook)
        override = {hook: lambda self, *a, m=method, **k: m(self, *a, **k)}  # the same results
        other = type("Other", (cls,), override)
        assert object.__new__(other).compiled_family is None, hook
    env.close()


@pytest.mark.parametrize(
    "env_id",
    ["Planar3P-v0", "Planar3PGoal-v0", "Planar3PTrack-v0", "Planar3PModeChange-v0"],
)
def test_the_compiled_kernels_share_one_step_prologue(env_id):
    """Every compiled kernel steps through :meth:`CompiledKernel.step` (none writes its own
    fallback test): without a state array, or on a state past the breakdown distance, its
    step is the reference kernel's, bit for bit; a moving reference's target is set before the
    compiled outputs (the target of the step, the same as the reference kernel's)."""
    env = gym.make(env_id).unwrapped
    kernel = env.kernel
    assert isinstance(kernel, CompiledKernel) and type(kernel).step is CompiledKernel.step
    twin = gym.make(env_id).unwrapped
    env.reset(seed=3)
    twin.reset(seed=3)
    reference = StepKernel(twin.task, twin.kernel.settings, twin.machine)
    for k, a in enumerate(np.random.default_rng(0).uniform(-0.5, 0.5, (12, 3))):
        states = [e.sim.step_unchecked(*(a * e.design.max_speed)) for e in (env, twin)]
        for e in (env, twin):
            e.episode.steps += 1
        array = None if k % 3 == 0 else env.sim.state_array  # (None: the reference's step)
        out = kernel.step(env.episode, states[0], array, tuple(a), env.np_random)
        ref = reference.step(twin.episode, states[1], None, tuple(a), twin.np_random)
        assert env.episode.target == twin.episode.target  # (the moving target of the step)
        if array is None:
            np.testing.assert_array_equal(out[0], ref[0])
            assert out[1:3] == ref[1:3]
        else:
            np.testing.assert_allclose(out[0], ref[0], rtol=1e-6, atol=1e-6)
            assert out[1] == pytest.approx(ref[1], rel=1e-9, abs=1e-12)
            assert out[2] == ref[2]
    env.close()
    twin.close()


def test_a_subclass_changing_a_hook_gets_the_reference_kernel():
    env = Planar3PEnv(task=_Recording())
    assert type(env.kernel) is StepKernel
    assert type(Planar3PEnv(projection=False).kernel) is StepKernel  # no state array
    env.close()


def test_hooks_are_handed_the_state_and_measures_the_env_computed():
    """``observation_extra`` gets the step, the simulation's state after the step and its
    measures (the ones in ``info``), at reset and at every step."""
    task = _Recording()
    env = Planar3PEnv(task=task)
    env.reset(seed=4)
    for a in np.random.default_rng(0).uniform(-1, 1, (20, 3)):
        _, _, terminated, _, info = env.step(a)
        step, state, measures = task.seen[-1]
        assert step == env.episode.steps and state is env.sim.state
        assert measures.parallel_margin == info["parallel_margin"]
        assert measures.det_sign == info["assembly_mode"]
        if terminated:
            break
    assert [s for s, _, _ in task.seen] == list(range(len(task.seen)))
    env.close()


def test_the_episode_record_is_what_the_env_returned():
    env = gym.make("Planar3PTrack-v0")
    obs, info = env.reset(seed=1)
    ep = env.unwrapped.episode
    np.testing.assert_array_equal(ep.obs, obs)
    assert ep.info is info and ep.steps == 0 and ep.spec == info["episode_spec"]
    obs, _, _, _, info = env.step(env.action_space.sample())
    np.testing.assert_array_equal(ep.obs, obs)
    assert ep.info is info and ep.steps == 1
    assert ep.target == env.unwrapped.task.reference(1)
    env.close()


@pytest.mark.parametrize("env_id", ["Planar3PModeChange-v0", "Planar3PAssemblyChange-v0"])
def test_the_hooks_on_compiled_measures_agree_with_the_reference(env_id):
    """Over 1,500 random steps: the same ends and metrics, the observation equal or one float32
    rounding apart, margins and errors within a few float64 rounding errors of the reference
    kernel's (the compiled margins share intermediate values), and the rewards within that
    rounding carried through the barrier that stays (``ref dm / m^2`` below its reference
    margin, weighted); the task's hooks are the same calls."""
    eps = np.finfo(np.float64).eps
    compiled, reference = gym.make(env_id), gym.make(env_id)
    assert type(compiled.unwrapped.kernel) is HookKernel
    k = reference.unwrapped.kernel
    reference.unwrapped.kernel = StepKernel(k.task, k.settings, k.machine)
    w = compiled.unwrapped.reward_weights
    metrics = compiled.unwrapped.task.metric_keys
    compiled.reset(seed=7)
    reference.reset(seed=7)
    for a in np.random.default_rng(2).uniform(-1, 1, (1500, 3)).astype(np.float32):
        o1, r1, te1, tr1, i1 = compiled.step(a)
        o2, r2, te2, tr2, i2 = reference.step(a)
        assert (te1, tr1, i1["termination_reason"]) == (te2, tr2, i2["termination_reason"])
        assert [i1[key] for key in metrics] == [i2[key] for key in metrics]
        np.testing.assert_allclose(o1, o2, rtol=2 * np.finfo(np.float32).eps, atol=1e-12)
        for key in ("position_error", "orientation_error", "parallel_margin", "serial_margin"):
            assert abs(i1[key] - i2[key]) <= 64 * eps, key
        assert i1["pose"] == i2["pose"] and i1["assembly_mode"] == i2["assembly_mode"]
        slope = sum(
            ref / m**2
            for m, ref in (
                (i2["parallel_margin"], w.parallel_margin_ref),
                (i2["serial_margin"], w.serial_margin_ref),
            )
            if m < ref
        )
        assert abs(r1 - r2) <= 64 * eps * (max(1.0, abs(r2)) + 2.0 * w.singularity * slope)
        if te1 or tr1:
            compiled.reset()
            reference.reset()


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.floats(min_value=-10.0, max_value=10.0, allow_nan=False, allow_infinity=False),
        min_size=6,
        max_size=6,
    )
)
def test_the_compiled_pose_errors_are_pythons_bit_for_bit(values):
    """The errors the reference kernel and the built machine's batched step share
    (:func:`~planar3p_gym.tasks.observation.pose_errors`, compiled) are ``math.hypot`` and the
    wrapped angle difference bit for bit, where C's ``hypot`` is not always (numpy's here)."""
    tx, ty, tth, x, y, th = values
    assert pose_errors(tx, ty, tth, x, y, th) == (
        math.hypot(tx - x, ty - y),
        wrap_angle(tth - th),
    )


def test_the_compiled_hypot_rounds_as_python_where_c_does_not():
    """Over 200,000 seeded random vectors of lengths from 1e-9 to 1 m (where a fraction of a
    percent differ from C's ``hypot`` in the last bit, ``np.hypot``), ``hypot`` equals
    ``math.hypot`` on every one, zero and the non-finite cases included."""
    rng = np.random.default_rng(0)
    scale = 10.0 ** rng.uniform(-9.0, 0.0, 200_000)
    a, b = rng.normal(size=(2, 200_000)) * scale
    ours = np.array([hypot(u, v) for u, v in zip(a.tolist(), b.tolist(), strict=True)])
    python = np.array([math.hypot(u, v) for u, v in zip(a.tolist(), b.tolist(), strict=True)])
    np.testing.assert_array_equal(ours, python)
    assert (np.hypot(a, b) != python).sum() > 0  # (what the compiled hypot is for)
    for u, v in ((0.0, 0.0), (-0.0, 3.0), (math.inf, math.nan), (math.nan, 1.0), (3.0, -4.0)):
        got, want = hypot(u, v), math.hypot(u, v)
        assert got == want or (math.isnan(got) and math.isnan(want))
