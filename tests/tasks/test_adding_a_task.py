"""The checklist of :mod:`planar3p_gym.tasks` ("Adding a task") followed for a toy task: its
module (here, this test module), one registration row and these tests -- no other edit."""

from __future__ import annotations

from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.envs.registration import registry
from gymnasium.utils.env_checker import check_env

from planar3p_gym.envs.registry import EnvRegistration, register_all
from planar3p_gym.tasks import ReachTask

ID = "Planar3PHoldTest-v0"


class HoldTask(ReachTask):
    """Hold the start pose: the target is where the episode starts, and the observation
    carries the steps left.

    ## Description
    A toy task for the checklist: stay put against gravity for ``horizon`` steps.
    ## Episode End
    Never by success; by a crossing, a breakdown or the time limit.
    """

    name: ClassVar[str] = "hold_test"
    observation_fields = (("steps_left", 1, "steps left of the horizon"),)

    def __init__(self, horizon: int = 50) -> None:
        if not isinstance(horizon, int) or horizon < 1:
            raise ValueError(f"horizon must be an integer >= 1, got {horizon!r}")
        self.horizon = horizon

    def arguments(self) -> dict[str, Any]:
        return {"horizon": self.horizon}

    def episode_spec(self, rng: np.random.Generator, options: dict[str, Any]) -> dict[str, Any]:
        spec = super().episode_spec(rng, options)
        spec["target"] = spec["start"]
        return spec

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return np.zeros(1, np.float32), np.array([self.horizon], np.float32)

    def observation_extra(self, step: int, state: Any, measures: Any) -> list[float]:
        return [float(max(self.horizon - step, 0))]

    def is_success(self, state: Any, errors: tuple[float, float]) -> bool:
        return False


ROW = EnvRegistration(
    ID,
    "planar3p_gym.envs.core:Planar3PEnv",
    60,
    "hold the start pose (a test of the checklist)",
    "hold_test",
    vector_entry_point="planar3p_gym.envs.vector:Planar3PVectorEnv",
    kwargs={"task": f"{__name__}:HoldTask"},
)


@pytest.fixture(scope="module", autouse=True)
def registered():
    """The row registered as ``register_all`` registers the package's rows."""
    import planar3p_gym.envs.registry as reg

    saved = reg.ENV_SPECS
    reg.ENV_SPECS = (*saved, ROW)
    try:
        register_all()
        yield
    finally:
        reg.ENV_SPECS = saved
        registry.pop(ID, None)


def test_the_new_id_passes_gymnasiums_checker():
    env = gym.make(ID, task_kwargs={"horizon": 30})
    check_env(env.unwrapped, skip_render_check=True)
    obs, info = env.reset(seed=0)
    assert obs.shape == (32,) and obs[-1] == 30.0
    np.testing.assert_allclose(info["episode_spec"]["target"], info["episode_spec"]["start"])
    obs, *_ = env.step(np.zeros(3, np.float32))
    assert obs[-1] == 29.0


def test_seeded_episodes_replay():
    def run() -> list[np.ndarray]:
        env = gym.make(ID)
        out = [env.reset(seed=4)[0]]
        env.action_space.seed(4)
        for _ in range(20):
            out.append(env.step(env.action_space.sample())[0])
        return out

    for a, b in zip(run(), run(), strict=True):
        np.testing.assert_array_equal(a, b)


def test_the_native_vector_env_matches_single_envs():
    venv = gym.make_vec(ID, num_envs=2, vectorization_mode="vector_entry_point")
    singles = [gym.make(ID) for _ in range(2)]
    obs, _ = venv.reset(seed=[1, 2])
    for i, single in enumerate(singles):
        np.testing.assert_array_equal(obs[i], single.reset(seed=1 + i)[0])
    actions = np.zeros((2, 3), np.float32)
    obs, rewards, *_ = venv.step(actions)
    for i, single in enumerate(singles):
        o, r, *_ = single.step(actions[i])
        np.testing.assert_array_equal(obs[i], o)
        assert rewards[i] == r
    venv.close()


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"task_kwargs": {"horizon": 0}}, "horizon"),
        ({"task_kwargs": {"bogus": 1}}, "task_kwargs"),
        ({"task_kwargs": [1]}, "task_kwargs"),
        ({"task": "planar3p_gym.tasks.nothing:Here"}, "cannot be imported"),
        ({"task": "planar3p_gym.tasks.sampling:TaskConfig"}, "Task subclass"),
    ],
)
def test_bad_task_arguments_are_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        gym.make(ID, **kwargs)


def test_task_kwargs_need_a_task_path():
    from planar3p_gym.envs.core import Planar3PEnv

    with pytest.raises(ValueError, match="task_kwargs"):
        Planar3PEnv(task=ReachTask(), task_kwargs={"horizon": 3})
