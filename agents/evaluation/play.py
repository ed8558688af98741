"""Play a policy on a registered id and report each episode (``planar3p play``, rl-zoo3's
``enjoy`` for any policy the project knows).

- :func:`play_env_id`: the id a policy plays by default (a model's own training id, else
  ``Planar3P-v0``);
- :func:`play`: makes the environment (with the observation arguments a model's run
  recorded), loads the policy through the one policy factory
  (:func:`planar3p_agents.policies.factory.load_policy`) and plays seeded episodes, rendered
  to a window or recorded to a GIF if asked;
- :class:`PlayedEpisode`: one episode's outcome.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from planar3p_agents.evaluation.episode_gif import write_gif
from planar3p_agents.policies.play_envs import play_kwargs
from planar3p_agents.policies.sb3_models import renamed, training_record
from planar3p_agents.policies.spec import PolicySpec, parse_policy_spec
from planar3p_gym.atomic_files import check_output_file
from planar3p_gym.envs.end_reason import end_reason
from planar3p_gym.envs.registry import ENV_ID

__all__ = ["PlayedEpisode", "play", "play_env_id"]


@dataclass(frozen=True)
class PlayedEpisode:
    """The outcome of one played episode.

    Attributes:
        seed: the seed of its reset.
        steps: control steps taken.
        end_reason: why it ended (``"success"``, ``"time_limit"``, a failure reason).
        success: whether it ended in success.
        episode_return: the sum of its rewards.
        position_error_mm: the final position error (mm), if the task reports one.
    """

    seed: int
    steps: int
    end_reason: str
    success: bool
    episode_return: float
    position_error_mm: float | None

    def as_dict(self) -> dict[str, Any]:
        """The outcome as plain data (JSON-ready)."""
        return asdict(self)


def play_env_id(spec: str | PolicySpec) -> str:
    """The id the policy ``spec`` plays by default: the id a model's training recorded (a
    retired development id renamed to the one it ran), else :data:`ENV_ID`."""
    ps = spec if isinstance(spec, PolicySpec) else parse_policy_spec(spec)
    if ps.kind == "model" and ps.path is not None:
        record = training_record(ps.path)
        if record is not None and record.env_id:
            return renamed(record.env_id)
    return ENV_ID


def play(
    spec: str,
    env_id: str | None = None,
    *,
    episodes: int = 1,
    seed: int = 0,
    env_kwargs: Mapping[str, Any] | None = None,
    render_mode: str | None = None,
    gif: str | Path | None = None,
    frame_every: int = 2,
    device: str = "cpu",
    on_episode: Callable[[PlayedEpisode], None] | None = None,
) -> list[PlayedEpisode]:
    """Play ``episodes`` episodes of ``env_id`` (default :func:`play_env_id`) with the policy
    ``spec`` (a baseline, ``pretrained:<name>`` or a model path), deterministically, the
    ``k``-th reset with seed ``seed + k``; return their outcomes.

    ``env_kwargs`` are the environment's arguments; a model also gets the observation
    arguments its run recorded (:func:`~planar3p_agents.policies.play_envs.play_kwargs`).
    ``render_mode``: ``"human"`` (a window, pygame) or ``None``; ``gif``: a path to which every
    ``frame_every``-th frame of the episodes is written as an animated GIF at the matching frame
    rate (:func:`~planar3p_agents.evaluation.episode_gif.write_gif`; rendered off screen, so not
    with ``"human"``).  ``on_episode`` is called with each outcome as it ends.  Bad arguments
    raise ``ValueError`` before anything is made; a policy that cannot play the id raises
    :class:`~planar3p_agents.policies.spec.PolicyError` before any episode is played.
    """
    from planar3p_agents.policies.factory import load_policy

    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes!r}")
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed!r}")
    if render_mode not in (None, "human"):
        raise ValueError(f"render_mode must be 'human' or None, got {render_mode!r}")
    if frame_every < 1:
        raise ValueError(f"frame_every must be >= 1, got {frame_every!r}")
    if gif is not None and render_mode is not None:
        raise ValueError("a GIF is rendered off screen: give gif or render_mode='human', not both")
    if gif is not None:
        check_output_file(gif)
        render_mode = "rgb_array"
    frames: list[np.ndarray] | None = [] if gif is not None else None
    ps = parse_policy_spec(spec)
    env_id = env_id if env_id is not None else play_env_id(ps)
    if env_id not in gym.registry:
        raise ValueError(f"unknown environment id {env_id!r}")
    kwargs = dict(env_kwargs or {})
    env = gym.make(env_id, render_mode=render_mode, **kwargs)
    try:
        if ps.kind == "model" and ps.path is not None:
            record = training_record(ps.path)
            wanted = play_kwargs(record.env_kwargs if record else None, env)
            changed = {k: v for k, v in wanted.items() if k not in kwargs}
            if any(getattr(env.unwrapped, k, None) != v for k, v in changed.items()):
                env.close()
                env = gym.make(env_id, render_mode=render_mode, **kwargs, **changed)
        policy = load_policy(ps, env, device=device, seed=seed)
        played = [_episode(env, policy, seed + k, frames, on_episode) for k in range(episodes)]
        fps = env.metadata["render_fps"] / frame_every
    finally:
        env.close()
    if gif is not None and frames:
        write_gif(gif, frames[::frame_every], fps)
    return played


def _episode(
    env: Any,
    policy: Any,
    seed: int,
    frames: list[np.ndarray] | None,
    on_episode: Callable[[PlayedEpisode], None] | None,
) -> PlayedEpisode:
    """One deterministic episode of ``policy`` from ``env.reset(seed=seed)``, its frames
    appended to ``frames`` (if a list)."""
    if hasattr(policy, "reset"):
        policy.reset()
    obs, info = env.reset(seed=seed)
    if frames is not None:
        frames.append(env.render())
    state, start, steps, total = None, True, 0, 0.0
    terminated = truncated = False
    while not (terminated or truncated):
        action, state = policy.predict(
            obs, state=state, episode_start=np.array([start]), deterministic=True
        )
        start = False
        obs, reward, terminated, truncated, info = env.step(action)
        steps += 1
        total += float(reward)
        if frames is not None:
            frames.append(env.render())
    error = info.get("position_error")
    played = PlayedEpisode(
        seed=seed,
        steps=steps,
        end_reason=end_reason(terminated, truncated, info),
        success=bool(info.get("is_success", False)),
        episode_return=total,
        position_error_mm=None if error is None else 1000.0 * float(error),
    )
    if on_episode is not None:
        on_episode(played)
    return played
