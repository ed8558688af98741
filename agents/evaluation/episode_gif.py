"""Record one episode of a policy as an animated GIF (the demo's animations).

The episode is fixed by its reset ``options`` (a suite's
:meth:`~planar3p_agents.evaluation.reach_suites.EpisodeSpec. reset_options`), so several policies
can be recorded on exactly the same start and target.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from planar3p_gym.envs.end_reason import end_reason

__all__ = ["GIF_SIZE", "record_gif"]

#: Frame size of the recorded animations, pixels (width, height).
GIF_SIZE = (480, 320)


def record_gif(
    env_id: str,
    make_policy: Callable[[Any], Any],
    options: dict[str, Any],
    path: str | Path,
    seed: int = 0,
    frame_every: int = 2,
) -> dict[str, Any]:
    """Play the episode ``options`` of ``env_id`` with the policy ``make_policy(env)`` (SB3's
    ``predict``; a ``reset()`` method is called first), render every ``frame_every``-th step,
    write the frames to ``path`` as a looping GIF at the matching frame rate, and return the
    outcome: ``steps``, ``reason`` (the end reason, e.g. ``"time_limit"``), ``success``,
    ``position_error_mm`` (final, mm)."""
    import imageio.v2 as imageio

    if frame_every < 1:
        raise ValueError(f"frame_every must be >= 1, got {frame_every!r}")
    env = gym.make(env_id, render_mode="rgb_array", render_size=GIF_SIZE)
    try:
        policy = make_policy(env)
        if hasattr(policy, "reset"):
            policy.reset()
        obs, info = env.reset(seed=seed, options=options)
        frames = [env.render()]
        state, start, steps, terminated, truncated = None, True, 0, False, False
        while not (terminated or truncated):
            action, state = policy.predict(
                obs, state=state, episode_start=np.array([start]), deterministic=True
            )
            start = False
            obs, _, terminated, truncated, info = env.step(action)
            steps += 1
            if steps % frame_every == 0 or terminated or truncated:
                frames.append(env.render())
        fps = env.metadata["render_fps"] / frame_every
    finally:
        env.close()
    frames.extend([frames[-1]] * 12)  # hold the last picture for a moment
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    imageio.mimsave(path, frames, duration=1.0 / fps, loop=0)
    return {
        "steps": steps,
        "reason": end_reason(terminated, truncated, info),
        "success": bool(info["is_success"]),
        "position_error_mm": 1000.0 * float(info["position_error"]),
    }
