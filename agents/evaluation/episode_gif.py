"""Record one episode of a policy as an animated GIF (the demo's and the docs' animations).

The episode is fixed by its reset ``options`` (a suite's
:meth:`~planar3p_agents.evaluation.reach_suites.EpisodeSpec.reset_options`), so several policies
can be recorded on exactly the same start and target.

- :func:`write_gif` is the one GIF writer: frame delays in the GIF's own unit (10 ms), the
  last picture held on.
- :func:`record_gif` plays an episode and writes it with :func:`write_gif`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from planar3p_gym.envs.end_reason import end_reason

__all__ = ["GIF_SIZE", "HOLD_S", "frame_delay_ms", "record_gif", "write_gif"]

#: Frame size of the recorded animations, pixels (width, height).
GIF_SIZE = (480, 320)
#: How long the last picture of an animation stays before it loops, s.
HOLD_S = 1.0


def frame_delay_ms(fps: float) -> int:
    """Delay of one frame shown at ``fps`` frames/s, ms, rounded to the GIF's 10 ms unit (a
    GIF stores delays in hundredths of a second; Pillow truncates, so 59.99 ms would be 50)."""
    if not fps > 0:
        raise ValueError(f"fps must be > 0, got {fps!r}")
    return 10 * max(1, round(100.0 / fps))


def write_gif(
    path: str | Path, frames: Sequence[np.ndarray], fps: float, hold_s: float = HOLD_S
) -> list[int]:
    """Write ``frames`` (RGB arrays) to ``path`` as a looping GIF shown at ``fps`` frames/s,
    the last frame held ``hold_s`` s longer; return the delays written, ms per frame.

    The delays go to Pillow in milliseconds (its unit; seconds would be read as 0 ms). The
    pause is the last frame's delay rather than copies of it: Pillow merges identical
    consecutive frames into one, adding their delays, so the time shown stays the same."""
    import imageio.v2 as imageio

    if not frames:
        raise ValueError("no frames to write")
    if hold_s < 0:
        raise ValueError(f"hold_s must be >= 0, got {hold_s!r}")
    delay = frame_delay_ms(fps)
    delays = [delay] * len(frames)
    delays[-1] += 10 * round(100.0 * hold_s)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    imageio.mimsave(path, list(frames), duration=delays, loop=0)
    return delays


def record_gif(
    env_id: str,
    make_policy: Callable[[Any], Any],
    options: dict[str, Any],
    path: str | Path,
    seed: int = 0,
    frame_every: int = 2,
    title: str | None = None,
) -> dict[str, Any]:
    """Play the episode ``options`` of ``env_id`` with the policy ``make_policy(env)`` (SB3's
    ``predict``; a ``reset()`` method is called first), render every ``frame_every``-th step,
    write the frames to ``path`` as a looping GIF at the matching frame rate (the last held
    :data:`HOLD_S` s; :func:`write_gif`), each under the line ``title`` if given (e.g. the
    policy and the id; the frames stay :data:`GIF_SIZE`), and return the outcome: ``steps``,
    ``reason`` (the end reason, e.g. ``"time_limit"``), ``success``, ``position_error_mm``
    (final, mm)."""
    if frame_every < 1:
        raise ValueError(f"frame_every must be >= 1, got {frame_every!r}")
    from planar3p_gym.sim.render import TITLE_HEIGHT, with_title

    size = GIF_SIZE if title is None else (GIF_SIZE[0], GIF_SIZE[1] - TITLE_HEIGHT)
    env = gym.make(env_id, render_mode="rgb_array", render_size=size)
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
    if title is not None:
        frames = [with_title(f, title) for f in frames]
    write_gif(path, frames, fps)
    return {
        "steps": steps,
        "reason": end_reason(terminated, truncated, info),
        "success": bool(info["is_success"]),
        "position_error_mm": 1000.0 * float(info["position_error"]),
    }
