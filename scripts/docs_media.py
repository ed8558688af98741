#!/usr/bin/env python
"""Media of the documentation's environment pages: a frame, an animated GIF of an episode and
its caption for every registered id.

For every id registered by ``import planar3p_gym`` (ids starting with ``Planar3P``): a
rendered frame (``<out>/<id>.png``), a short animated GIF of an episode played by the id's
analytic controller under a title line naming the controller and the id (``<out>/<id>.gif``)
and what the GIF shows (``<out>/<id>.json``, read by the page generator for the caption).

    python scripts/docs_media.py [--out docs/_static/envs] [--ids ID ...] [--seed 0]
                        [--size 320x240] [--frame-every 3] [--max-steps 150]
                        [--max-kb 400]

The controller of an id is the analytic one of its task: the paper's simultaneous simple
motions (``analytic-simultaneous``), except on tracking (with the reference velocity fed
forward, ``analytic-feedforward``) and on the working-mode change (the certified travel-space
planner, ``planner``: the simple motions stop at the serial singularity the task must pass);
``--controller ID=NAME`` overrides it.  Arguments are checked before anything is made or
written (exit status 2 naming the flag).  About a minute for all ids.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser, UsageError
from tooling import script

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("MPLBACKEND", "Agg")


#: Controller of an id by its task's name (others: ``analytic-simultaneous``).
TASK_CONTROLLER = {"track": "analytic-feedforward", "mode_change": "planner"}
#: Controller of an id by its action type, before its task's (on-off motors).
ACTION_CONTROLLER = {"on-off": "analytic-on-off", "on-off-discrete": "analytic-on-off"}
#: What the controller names mean, for the captions.
CONTROLLER_TEXT = {
    "analytic-simultaneous": "the paper's simple motions (simultaneous)",
    "analytic-feedforward": "the simple motions with the reference velocity fed forward",
    "planner": "the certified travel-space planner, then the simple motions",
    "crossing": "the crossing demonstration, then the simple motions",
    "analytic-on-off": "the simple motions as on-off motor commands (dead-band bang-bang)",
}
ID_PREFIX = "Planar3P"


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT, got {text!r}") from exc
    if not (64 <= w <= 2048 and 64 <= h <= 2048):
        raise argparse.ArgumentTypeError(f"sizes must be 64..2048 pixels, got {text!r}")
    return w, h


def add_arguments(p: CliParser) -> None:
    p.add_argument(
        "--out",
        type=Path,
        default=Path("docs") / "_static" / "envs",
        help="output directory (created if missing; must not be a file)",
    )
    p.add_argument(
        "--ids",
        nargs="+",
        default=None,
        help="ids to render (default: every registered Planar3P id)",
    )
    p.add_argument("--seed", type=int, default=0, help="reset seed of the recorded episode")
    p.add_argument("--size", type=_size, default=(320, 240), help="GIF size, WIDTHxHEIGHT")
    p.add_argument("--frame-size", type=_size, default=(480, 360), help="PNG size")
    p.add_argument("--frame-every", type=int, default=3, help="render every n-th step")
    p.add_argument(
        "--max-steps",
        type=int,
        default=150,
        help="steps recorded at most (the episode is cut there)",
    )
    p.add_argument("--max-kb", type=int, default=400, help="fail when a GIF is larger (kB)")
    p.add_argument(
        "--controller",
        nargs="*",
        default=[],
        metavar="ID=NAME",
        help="controller of an id (" + ", ".join(CONTROLLER_TEXT) + ")",
    )


def _fail(flag: str, msg: str) -> None:
    raise UsageError(f"{flag}: {msg}")


def check(args: argparse.Namespace) -> None:
    checks.at_least("--seed", args.seed, 0)
    for flag, value in (
        ("--frame-every", args.frame_every),
        ("--max-steps", args.max_steps),
        ("--max-kb", args.max_kb),
    ):
        checks.at_least(flag, value, 1)
    """Validate everything before any work; returns the controller overrides."""
    import gymnasium as gym

    import planar3p_gym  # noqa: F401  (registers the ids)

    checks.output_dir("--out", args.out)  # (a file, under a file, or not writable)
    known = [i for i in gym.registry if i.startswith(ID_PREFIX)]
    if args.ids is None:
        args.ids = known
    unknown = [i for i in args.ids if i not in known]
    if unknown:
        _fail("--ids", f"not registered: {', '.join(unknown)}; known: {', '.join(known)}")
    overrides = {}
    for item in args.controller:
        env_id, sep, name = item.partition("=")
        if not sep or env_id not in known or name not in CONTROLLER_TEXT:
            _fail(
                "--controller",
                f"expected ID=NAME with a registered id and NAME in "
                f"{', '.join(CONTROLLER_TEXT)}, got {item!r}",
            )
        overrides[env_id] = name
    args.overrides = overrides


def make_controller(name: str, env_id: str, env: Any) -> Any:
    """The controller ``name`` for ``env`` (SB3-style ``predict``)."""
    from planar3p_agents.policies.factory import load_policy

    return load_policy(name, env=env)


def record(env_id: str, controller: str | None, args: argparse.Namespace) -> dict[str, Any]:
    """Write the frame and the GIF of ``env_id``; return its description."""
    import gymnasium as gym
    import imageio.v2 as imageio
    import numpy as np

    from planar3p_agents.evaluation.episode_gif import write_gif
    from planar3p_gym.sim.render import TITLE_HEIGHT, with_title

    with gym.make(env_id, render_mode="rgb_array", render_size=args.frame_size) as env:
        env.reset(seed=args.seed)
        imageio.imwrite(args.out / f"{env_id}.png", env.render())
    # The GIF's frames are --size with the title line (controller and id) on top.
    size = (args.size[0], args.size[1] - TITLE_HEIGHT)
    env = gym.make(env_id, render_mode="rgb_array", render_size=size)
    try:
        task = getattr(env.unwrapped.task, "name", "")
        action_type = getattr(env.unwrapped, "action_type", "continuous")
        name = (
            controller
            or ACTION_CONTROLLER.get(action_type)
            or TASK_CONTROLLER.get(task, "analytic-simultaneous")
        )
        policy = make_controller(name, env_id, env)
        if hasattr(policy, "reset"):
            policy.reset()
        obs, info = env.reset(seed=args.seed)
        frames = [env.render()]
        state, start, steps, done = None, True, 0, False
        while not done and steps < args.max_steps:
            action, state = policy.predict(
                obs, state=state, episode_start=np.array([start]), deterministic=True
            )
            start = False
            obs, _, terminated, truncated, info = env.step(action)
            steps += 1
            done = terminated or truncated
            if steps % args.frame_every == 0 or done:
                frames.append(env.render())
        fps = env.metadata["render_fps"] / args.frame_every
    finally:
        env.close()
    frames = [with_title(f, f"{name} on {env_id}") for f in frames]
    gif = args.out / f"{env_id}.gif"
    delays = write_gif(gif, frames, fps)  # the last picture held about a second
    fps = 1000.0 / delays[0]  # the rate shown (the GIF's delays are whole 10 ms)
    kb = gif.stat().st_size / 1024
    if done:
        reason = info.get("termination_reason") or "time limit"
        outcome = f"{'success' if info.get('is_success') else reason} after {steps} steps"
    else:
        outcome = f"the first {steps} steps"
    seconds = steps / env.metadata["render_fps"]
    caption = (
        f"{CONTROLLER_TEXT[name]} (`{name}`), reset seed {args.seed}: {outcome} "
        f"({seconds:g} s, shown at {fps:.3g} frames/s)."
    )
    return {
        "id": env_id,
        "controller": name,
        "seed": args.seed,
        "steps": steps,
        "outcome": outcome,
        "gif_kb": round(kb, 1),
        "caption": caption,
    }


def run(args: argparse.Namespace) -> int:
    overrides = args.overrides
    args.out.mkdir(parents=True, exist_ok=True)
    too_big = []
    for env_id in args.ids:
        meta = record(env_id, overrides.get(env_id), args)
        (args.out / f"{env_id}.json").write_text(json.dumps(meta, indent=2) + "\n")
        print(f"{env_id}: {meta['outcome']}, GIF {meta['gif_kb']} kB")
        if meta["gif_kb"] > args.max_kb:
            too_big.append(f"{env_id} ({meta['gif_kb']} kB)")
    if too_big:
        print(f"GIFs above --max-kb {args.max_kb}: {', '.join(too_big)}", file=sys.stderr)
        return 1
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run this script with ``argv`` (default: the process's arguments); the exit status."""
    return script.main(__name__, argv)


if __name__ == "__main__":
    raise SystemExit(main())
