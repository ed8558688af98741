"""Shared test configuration: headless rendering, a bounded hypothesis profile, and the
fixtures several test modules use (``env``, ``suites``, ``bench``)."""

import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("MPLBACKEND", "Agg")

import gymnasium as gym
import pytest
from hypothesis import HealthCheck, settings
from script_loader import command

import planar3p_gym
from planar3p_agents.evaluation import reach_suites as su

settings.register_profile(
    "project",
    max_examples=200,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
    derandomize=True,
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "project"))


@pytest.fixture(scope="module")
def env(request):
    """The environment of the test module's ``ENV_ID`` (default ``Planar3P-v0``), shared by
    the module's tests."""
    e = gym.make(getattr(request.module, "ENV_ID", planar3p_gym.ENV_ID))
    yield e
    e.close()


@pytest.fixture(scope="module")
def suites():
    """The fixed reach suites, 4 episodes each from seed 7."""
    return {name: su.make_suite(name, 4, seed=7) for name in su.SUITE_NAMES}


@pytest.fixture(scope="module")
def bench():
    """``planar3p benchmark`` (``bench.main(argv)``)."""
    return command("benchmark")
