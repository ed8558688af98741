"""Which ids a trained model may play (:func:`planar3p_agents.policies.sb3_models.same_task`):
its own, a retired development id's successor, and registrations of the same class and task
that differ only in their defaults -- never another task's id, also not one added with
:func:`planar3p_gym.register_task` on the generic environment, and a registered id is never
renamed."""

from __future__ import annotations

from typing import ClassVar

import pytest
from gymnasium.envs.registration import registry

import planar3p_gym
import planar3p_gym.envs.registry as reg
from planar3p_agents.policies.sb3_models import RENAMED_IDS, renamed, same_task
from planar3p_gym.tasks import ReachTask


class OtherTask(ReachTask):
    """Another task on the generic environment (a reach under another name)."""

    name: ClassVar[str] = "other_test"


@pytest.fixture
def registered():
    """Register ``ids`` for one test, the public way; unregistered afterwards."""
    added: list[str] = []

    def register(env_id: str) -> str:
        planar3p_gym.register_task(env_id, OtherTask, 50, "another task (a test)")
        added.append(env_id)
        return env_id

    yield register
    for env_id in added:
        registry.pop(env_id, None)
        reg._ADDED[:] = [row for row in reg._ADDED if row.id != env_id]


@pytest.mark.parametrize(
    ("trained", "played", "may"),
    [
        ("Planar3P-v0", "Planar3P-v0", True),
        ("Planar3PGoal-v0", "Planar3PGoalDense-v0", True),  # the same class, another reward
        ("Planar3P-v0", "Planar3PReal-v0", True),  # the same class and task, the built machine
        ("Planar3P-v1", "Planar3P-v0", True),  # a retired development id
        ("Planar3P-v0", "Planar3PTrack-v0", False),
        ("Planar3PModeChange-v0", "Planar3PAssemblyChange-v0", False),
        ("Unknown-v0", "Planar3P-v0", False),
    ],
)
def test_a_model_plays_its_own_task_only(trained, played, may):
    assert same_task(trained, played) is may


def test_an_added_task_on_the_generic_env_is_another_task(registered):
    other = registered("Planar3POtherTest-v0")
    assert not same_task("Planar3P-v0", other) and not same_task(other, "Planar3P-v0")
    assert same_task(other, other)


def test_a_registered_id_is_never_renamed(registered):
    assert "Planar3P-v1" in RENAMED_IDS and renamed("Planar3P-v1") == "Planar3P-v0"
    registered("Planar3P-v1")  # a real next version of the reach
    assert renamed("Planar3P-v1") == "Planar3P-v1"
    assert not same_task("Planar3P-v1", "Planar3P-v0")
