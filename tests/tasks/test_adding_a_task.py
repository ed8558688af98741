"""The checklist of ``docs/adding_a_task.md`` followed for a toy task from outside the package:
its class (here, in this test module), one call of the public
:func:`planar3p_gym.register_task` and these tests -- no edit of the package.  The id is made
with ``gym.make`` and ``gym.make_vec``, stepped, and its page generated from the task's
docstring; bad registrations are refused with a clear error and register nothing."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.envs.registration import registry
from gymnasium.utils.env_checker import check_env
from hypothesis import given, settings
from hypothesis import strategies as st

import planar3p_gym
import planar3p_gym.envs.registry as reg
from planar3p_gym.tasks import ReachTask

DOCS_SCRIPTS = Path(__file__).resolve().parents[2] / "docs" / "_scripts"

ID = "Planar3PHoldTest-v0"


class HoldTask(ReachTask):
    """Hold the start pose: the target is where the episode starts.

    ## Description
    A toy task for the checklist: stay put against gravity for ``horizon`` steps.

    ## Observation Space
    The 31 entries of ``Planar3P-v0``, then the steps left of the horizon.

    ## Episode End
    Never by success; by a crossing, a breakdown or the time limit.

    ## Version History
    - v0: the toy task of the test.
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


SUMMARY = "hold the start pose (a test of the checklist)"


def _unregister(env_id: str) -> None:
    """Undo a registration of this test (no public call: a registered id stays registered)."""
    registry.pop(env_id, None)
    reg._ADDED[:] = [row for row in reg._ADDED if row.id != env_id]


@pytest.fixture(scope="module", autouse=True)
def registered():
    """The toy task registered the public way, as another package would at its import."""
    row = planar3p_gym.register_task(ID, HoldTask, 60, SUMMARY)
    try:
        yield row
    finally:
        _unregister(ID)


def test_the_registration_is_the_generic_env_running_the_task(registered):
    assert registered in planar3p_gym.registrations()
    assert registered not in planar3p_gym.ENV_SPECS  # the package's own table is unchanged
    assert registered.task == "hold_test" and registered.max_episode_steps == 60
    spec = gym.spec(ID)
    assert spec.entry_point == "planar3p_gym.envs.core:Planar3PEnv"
    assert spec.vector_entry_point == "planar3p_gym.envs.vector:Planar3PVectorEnv"
    assert spec.kwargs == {"task": f"{__name__}:HoldTask"}
    assert planar3p_gym.max_episode_steps(ID) == 60


def test_its_page_is_generated_from_the_task_s_docstring():
    if str(DOCS_SCRIPTS) not in sys.path:
        sys.path.insert(0, str(DOCS_SCRIPTS))
    import gen_envs

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # no media for a toy id
        page, row = gen_envs.env_page(ID)
    assert page.startswith(
        f"# {ID}\n\nHold the start pose: the target is where the episode starts."
    )
    assert "A toy task for the checklist" in page and "## Version History" in page
    assert "`steps_left`" in page  # the observation layout, from the task's fields
    assert "the mission's id" not in page and "Planar3PEnv.__init__" not in page
    assert row["task"] == "hold_test" and row["length"].startswith("60 ")


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
    venv = gym.make_vec(ID, num_envs=2)  # the registered native vector env
    assert type(venv).__name__ == "Planar3PVectorEnv"
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


def _state() -> tuple[tuple, list[str]]:
    return planar3p_gym.registrations(), sorted(registry)


@pytest.mark.parametrize(
    ("args", "kwargs", "message"),
    [
        (("Planar3PHold", HoldTask, 60, SUMMARY), {}, "version -vN"),
        (("not an id!", HoldTask, 60, SUMMARY), {}, "not a Gymnasium id"),
        ((3, HoldTask, 60, SUMMARY), {}, "env_id"),
        ((ID, HoldTask, 60, SUMMARY), {}, "already registered"),
        (("Planar3P-v0", HoldTask, 60, SUMMARY), {}, "already registered"),
        (("Planar3PHold-v1", ReachTask(), 60, SUMMARY), {}, "task must be"),
        (("Planar3PHold-v1", "nowhere.at_all:Task", 60, SUMMARY), {}, "cannot be imported"),
        (("Planar3PHold-v1", "planar3p_gym.tasks.sampling:TaskConfig", 60, SUMMARY), {}, "Task"),
        (("Planar3PHold-v1", HoldTask, 0, SUMMARY), {}, "max_episode_steps"),
        (("Planar3PHold-v1", HoldTask, 60.0, SUMMARY), {}, "max_episode_steps"),
        (("Planar3PHold-v1", HoldTask, True, SUMMARY), {}, "max_episode_steps"),
        (("Planar3PHold-v1", HoldTask, 60, ""), {}, "summary"),
        (("Planar3PHold-v1", HoldTask, 60, "two\nlines"), {}, "summary"),
        (("Planar3PHold-v1", HoldTask, 60, SUMMARY), {"vector": "yes"}, "vector"),
        (("Planar3PHold-v1", HoldTask, 60, SUMMARY), {"kwargs": [1]}, "kwargs"),
        (("Planar3PHold-v1", HoldTask, 60, SUMMARY), {"kwargs": {"task": "x:Y"}}, "kwargs"),
        (("Planar3PHold-v1", HoldTask, 60, SUMMARY), {"kwargs": {"bogus": 1}}, "bogus"),
        (
            ("Planar3PHold-v1", HoldTask, 60, SUMMARY),
            {"kwargs": {"task_kwargs": {"horizon": 0}}},
            "horizon",
        ),
        (
            ("Planar3PHold-v1", HoldTask, 60, SUMMARY),
            {"kwargs": {"task_kwargs": {"bogus": 1}}},
            "task_kwargs",
        ),
        (
            ("Planar3PHold-v1", HoldTask, 60, SUMMARY),
            {"kwargs": {"design": object()}},
            "JSON",
        ),
    ],
)
def test_a_bad_registration_is_refused_and_registers_nothing(args, kwargs, message):
    before = _state()
    with pytest.raises(ValueError, match=message):
        planar3p_gym.register_task(*args, **kwargs)
    assert _state() == before


@settings(max_examples=25, deadline=None)
@given(steps=st.one_of(st.integers(max_value=0), st.floats(allow_nan=True), st.text(max_size=3)))
def test_any_bad_time_limit_is_refused_and_registers_nothing(steps):
    before = _state()
    with pytest.raises(ValueError, match="max_episode_steps"):
        planar3p_gym.register_task("Planar3PHold-v1", HoldTask, steps, SUMMARY)
    assert _state() == before


def test_registered_defaults_reach_the_task():
    row = planar3p_gym.register_task(
        "Planar3PHold-v1",
        f"{__name__}:HoldTask",
        40,
        SUMMARY,
        kwargs={"task_kwargs": {"horizon": 7}},
        vector=False,
    )
    try:
        assert row.vector_entry_point is None and gym.spec(row.id).vector_entry_point is None
        env = gym.make(row.id)
        obs, _ = env.reset(seed=1)
        assert obs[-1] == 7.0 and env.unwrapped.task.horizon == 7
        env.close()
    finally:
        _unregister(row.id)
