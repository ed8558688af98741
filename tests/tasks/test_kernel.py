"""The task kernel contract (:mod:`planar3p_gym.tasks.kernel`)."""

from __future__ import annotations

from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
import pytest

import planar3p_gym  # noqa: F401  (registers the ids)
from planar3p_gym.envs.core import Planar3PEnv
from planar3p_gym.tasks import ReachTask
from planar3p_gym.tasks.goal import GoalKernel
from planar3p_gym.tasks.kernel import ReachKernel, StepKernel
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
        ("Planar3PModeChange-v0", StepKernel),
        ("Planar3PAssemblyChange-v0", StepKernel),
    ],
)
def test_each_task_picks_its_kernel(env_id, kernel):
    """The compiled reach kernel on the projected physics of the nominal machine, for the
    reach task's own hooks; the reference (the hooks) everywhere else."""
    env = gym.make(env_id).unwrapped
    assert type(env.kernel) is kernel
    env.close()


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
