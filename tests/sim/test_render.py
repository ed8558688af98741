"""Rendering of ``Planar3P-v0``: rgb_array frames, headless operation, human mode with the
dummy video driver (``SDL_VIDEODRIVER=dummy`` is set in conftest.py)."""

from __future__ import annotations

import os
import warnings

import gymnasium as gym
import numpy as np
import pytest

from planar3p_gym import ENV_ID, Design
from planar3p_gym.sim.render import Frame, Renderer

#: The status text occupies the top-left corner; mechanism changes must show outside it.
TEXT_BOX = (slice(0, 140), slice(0, 260))


def outside_text(frame: np.ndarray) -> np.ndarray:
    out = frame.copy()
    out[TEXT_BOX] = 0
    return out


def test_headless_driver_is_set():
    assert os.environ.get("SDL_VIDEODRIVER") == "dummy"


@pytest.fixture
def rgb_env():
    env = gym.make(ENV_ID, render_mode="rgb_array")
    yield env
    env.close()


def test_rgb_array_frames_shape_and_dtype(rgb_env):
    rgb_env.reset(seed=0)
    frame = rgb_env.render()
    assert isinstance(frame, np.ndarray)
    assert frame.shape == (480, 640, 3) and frame.dtype == np.uint8
    assert frame.std() > 0  # not a blank picture


def test_frames_change_with_the_state_and_only_then(rgb_env):
    rgb_env.reset(seed=0)
    f0 = rgb_env.render()
    assert np.array_equal(f0, rgb_env.render())  # same state, same picture
    for _ in range(10):
        rgb_env.step(np.array([1.0, 1.0, 1.0], np.float32))
    f1 = rgb_env.render()
    assert f1.shape == f0.shape
    changed = np.any(outside_text(f0) != outside_text(f1), axis=-1)
    assert changed.sum() > 100  # the mechanism moved on screen, not just the text


def test_a_new_target_changes_the_picture(rgb_env):
    rgb_env.reset(seed=0)
    f0 = rgb_env.render()
    rgb_env.reset(seed=1)
    f1 = rgb_env.render()
    assert np.any(outside_text(f0) != outside_text(f1))


def test_custom_render_size():
    env = gym.make(ENV_ID, render_mode="rgb_array", render_size=(320, 200))
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (200, 320, 3) and frame.dtype == np.uint8
    env.close()


def test_render_without_mode_returns_none_and_warns():
    env = gym.make(ENV_ID)
    env.reset(seed=0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert env.unwrapped.render() is None
    assert any("render_mode" in str(w.message) for w in caught)


def test_human_mode_with_dummy_driver_does_not_crash():
    env = gym.make(ENV_ID, render_mode="human")
    env.reset(seed=0)
    for _ in range(3):
        env.step(np.array([0.5, -0.5, 0.2], np.float32))
    assert env.render() is None
    env.close()
    env.close()  # closing twice is harmless


def test_render_after_close_reopens(rgb_env):
    rgb_env.reset(seed=0)
    rgb_env.render()
    rgb_env.close()
    frame = rgb_env.render()
    assert frame.shape == (480, 640, 3)


def test_renderer_draws_extreme_frames():
    """Singular and degenerate states draw without errors: margins 0, a leg on its rail
    line, no target, no forces."""
    d = Design.fig8()
    r = Renderer(d, (160, 120), "rgb_array")
    frames = [
        Frame(
            rho=(0.0, 0.1, 0.3),
            pose=(0.1, 0.0, 0.0),
            target=None,
            parallel_margin=0.0,
            serial_margin=0.0,
        ),
        Frame(
            rho=(0.3, 0.3, 0.3),
            pose=(0.2, 0.15, 3.1),
            target=(0.0, 0.1, -1.0),
            parallel_margin=1.0,
            serial_margin=1.0,
            forces=(40.0, 0.0, 12.5),
            text=("extra",),
        ),
    ]
    for f in frames:
        img = r.render(f)
        assert img.shape == (120, 160, 3) and img.dtype == np.uint8
    r.close()
    with pytest.raises(ValueError):
        Renderer(d, (160, 120), "ascii")
