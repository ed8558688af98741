"""Rendering of ``Planar3P-v0``: rgb_array frames, headless operation, human mode with the
dummy video driver (``SDL_VIDEODRIVER=dummy`` is set in conftest.py)."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from planar3p_gym import ENV_ID, Design
from planar3p_gym.sim.render import (
    TITLE_HEIGHT,
    Frame,
    Renderer,
    default_video_driver,
    overlay_layout,
    split_row,
    with_title,
)

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


@given(
    st.lists(
        st.tuples(st.text(max_size=20), st.text(max_size=12)),
        min_size=1,
        max_size=8,
    )
)
def test_overlay_values_share_one_right_edge_clear_of_the_labels(rows):
    """Values end on one edge, and each starts at least the gap right of the widest label
    (no "parallel margin0.069"); rows go down one line each (a font of 7 px per character)."""
    width_of = lambda t: 7 * len(t)  # noqa: E731
    places = overlay_layout(rows, width_of)
    widest = max(width_of(label) for label, _ in rows)
    ends = {vx + width_of(value) for (_, (vx, _)), (_, value) in zip(places, rows, strict=True)}
    assert len(ends) == 1
    for (lx, ly), (vx, vy) in places:
        assert lx == 8 and ly == vy
        assert vx >= lx + widest + 10
    assert [ly for (_, ly), _ in places] == [6 + 16 * n for n in range(len(rows))]


@pytest.mark.parametrize(
    ("line", "row"),
    [
        ("position error   12.3 mm", ("position error", "12.3 mm")),
        ("orientation error   -1.5 deg", ("orientation error", "-1.5 deg")),
        ("extra", ("extra", "")),
        ("42 steps", ("42 steps", "")),
    ],
)
def test_status_lines_split_into_label_and_value(line, row):
    assert split_row(line) == row


def test_title_line_goes_above_the_picture():
    """The title adds a band of TITLE_HEIGHT pixels with text in it; the picture below is
    unchanged, and a title longer than the picture is cut, not an error."""
    picture = np.full((50, 120, 3), 250, np.uint8)
    out = with_title(picture, "certified-line on Planar3P-v0")
    assert out.shape == (50 + TITLE_HEIGHT, 120, 3) and out.dtype == np.uint8
    assert np.array_equal(out[TITLE_HEIGHT:], picture)
    band = out[:TITLE_HEIGHT]
    assert len(np.unique(band.reshape(-1, 3), axis=0)) > 2  # text drawn on the band
    assert with_title(picture, "x" * 500).shape == out.shape


@pytest.mark.parametrize(
    ("env", "expected"),
    [
        ({}, "dummy"),  # no display: the dummy driver
        ({"DISPLAY": ":0"}, None),  # a display: SDL's own choice
        ({"WAYLAND_DISPLAY": "wayland-0"}, None),
        ({"SDL_VIDEODRIVER": "x11"}, "x11"),  # the user's choice is kept
    ],
)
def test_default_video_driver_only_where_no_display(monkeypatch, env, expected):
    for name in ("DISPLAY", "WAYLAND_DISPLAY", "SDL_VIDEODRIVER"):
        monkeypatch.delenv(name, raising=False)
    for name, value in env.items():
        monkeypatch.setenv(name, value)
    monkeypatch.setattr(sys, "platform", "linux")
    default_video_driver()
    assert os.environ.get("SDL_VIDEODRIVER") == expected


def test_check_env_in_human_mode_prints_nothing_from_sdl_headless():
    """Gymnasium's check_env on a human-mode env without a display and without
    SDL_VIDEODRIVER: SDL printed "XDG_RUNTIME_DIR is invalid" before the default driver."""
    env = {k: v for k, v in os.environ.items() if k not in ("SDL_VIDEODRIVER", "DISPLAY")}
    env.pop("WAYLAND_DISPLAY", None)
    env.pop("XDG_RUNTIME_DIR", None)
    code = (
        "import gymnasium as gym, planar3p_gym\n"
        "from gymnasium.utils.env_checker import check_env\n"
        "check_env(gym.make('Planar3P-v0', render_mode='human').unwrapped)\n"
    )
    r = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300
    )
    assert r.returncode == 0, r.stderr
    assert "XDG_RUNTIME_DIR" not in r.stdout + r.stderr
