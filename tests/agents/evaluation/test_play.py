"""planar3p_agents.evaluation.play: the episodes a policy plays are the environment's own,
seeded one by one; a model plays its training id; a GIF holds every recorded frame for its
time; bad arguments are refused before anything is made or written."""

from __future__ import annotations

import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gif_helpers import gif_delays

from planar3p_agents.evaluation.episode_gif import HOLD_S, frame_delay_ms
from planar3p_agents.evaluation.play import play, play_env_id
from planar3p_agents.policies.factory import load_policy


def _by_hand(spec: str, env_id: str, seed: int) -> tuple[int, float, bool]:
    """Steps, return and success of one deterministic episode, played without :func:`play`."""
    env = gym.make(env_id)
    policy = load_policy(spec, env, seed=seed)
    obs, _ = env.reset(seed=seed)
    steps, total, done, info = 0, 0.0, False, {}
    while not done:
        action, _ = policy.predict(obs, deterministic=True)
        obs, reward, terminated, truncated, info = env.step(action)
        steps, total, done = steps + 1, total + float(reward), terminated or truncated
    env.close()
    return steps, total, bool(info["is_success"])


def test_the_played_episodes_are_the_environments_own_seed_by_seed() -> None:
    seen = []
    played = play("analytic-simultaneous", episodes=2, seed=7, on_episode=seen.append)
    assert [p.seed for p in played] == [7, 8] and seen == played
    for p in played:
        steps, total, success = _by_hand("analytic-simultaneous", "Planar3P-v0", p.seed)
        assert (p.steps, p.success) == (steps, success)
        assert p.episode_return == total  # the same floats summed in the same order
        assert (p.end_reason == "success") == p.success
    assert play("analytic-simultaneous", episodes=2, seed=7) == played


def test_a_model_plays_its_training_id_and_a_baseline_the_reach() -> None:
    assert play_env_id("pretrained:ppo_track") == "Planar3PTrack-v0"
    assert play_env_id("pretrained:tqc_goal") == "Planar3PGoal-v0"
    assert play_env_id("crossing") == "Planar3P-v0"
    (ep,) = play("pretrained:ppo_reach_line", seed=0)
    assert ep.success and ep.position_error_mm is not None and ep.position_error_mm < 5.0


def test_the_gif_holds_every_recorded_frame_for_its_time(tmp_path: Path) -> None:
    out = tmp_path / "play.gif"
    frame_every = 3
    played = play("analytic-simultaneous", episodes=2, seed=1, gif=out, frame_every=frame_every)
    frames = sum(p.steps + 1 for p in played)  # the reset's frame and one per step
    recorded = math.ceil(frames / frame_every)
    delays, loop = gif_delays(out)
    fps = gym.spec("Planar3P-v0").kwargs.get("control_frequency", 50.0) / frame_every
    # Pillow merges identical consecutive frames and adds their delays: the total is kept
    assert sum(delays) == recorded * frame_delay_ms(fps) + round(1000 * HOLD_S)
    assert loop == 0


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"episodes": 0}, "episodes"),
        ({"seed": -1}, "seed"),
        ({"frame_every": 0}, "frame_every"),
        ({"render_mode": "rgb_array"}, "render_mode"),
        ({"render_mode": "human", "gif": "x.gif"}, "GIF"),
        ({"env_id": "Planar3P-v9"}, "Planar3P-v9"),
    ],
)
def test_bad_arguments_are_refused_before_anything_is_made(
    kwargs: dict, message: str, tmp_path: Path, monkeypatch
) -> None:
    monkeypatch.chdir(tmp_path)
    made = []
    monkeypatch.setattr(gym, "make", lambda *a, **k: made.append(a))
    with pytest.raises(ValueError, match=message):
        play("zero", **kwargs)
    assert made == [] and list(tmp_path.iterdir()) == []


def test_a_gif_under_a_file_is_refused_before_playing(tmp_path: Path) -> None:
    a_file = tmp_path / "a_file"
    a_file.write_text("keep")
    with pytest.raises(ValueError):
        play("zero", gif=a_file / "x.gif")
    assert a_file.read_text() == "keep"


def test_a_model_on_another_task_is_refused() -> None:
    from planar3p_agents.policies.spec import PolicyError

    with pytest.raises(PolicyError, match="Planar3PTrack-v0"):
        play("pretrained:ppo_track", "Planar3P-v0")


def test_outcomes_are_plain_data() -> None:
    (ep,) = play("zero", seed=0, env_kwargs={"max_episode_steps": 5})
    data = ep.as_dict()
    assert data == {
        "seed": 0,
        "steps": 5,
        "end_reason": "time_limit",
        "success": False,
        "episode_return": ep.episode_return,
        "position_error_mm": ep.position_error_mm,
    }
    assert np.isfinite(data["episode_return"])
