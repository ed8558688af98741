#!/usr/bin/env python
"""The main job: the shipped learned policy against the analytic controller, on a quick suite.

Runs ``scripts/benchmark.py --quick`` on the shipped pretrained policy (``agents/pretrained/``)
and the paper's simultaneous simple-motion controller, then records one episode of each as an
animated GIF (the same start and target for both), and prints where everything is.  Trains
nothing; a few minutes on a laptop-class CPU.

    python scripts/demo.py [--out results/demo] [--policy pretrained:NAME] [--seed 0]
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("MPLBACKEND", "Agg")

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402

import planar3p_gym  # noqa: E402
from agents import suites as su  # noqa: E402
from agents.policies import (  # noqa: E402
    TRUSTED_FILES_NOTE,
    PolicyError,
    list_pretrained,
    load_policy,
    policy_label,
)

ANALYTIC = "analytic-simultaneous"


def _benchmark_main():
    import importlib.util

    spec = importlib.util.spec_from_file_location("benchmark", ROOT / "scripts" / "benchmark.py")
    module = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    spec.loader.exec_module(module)
    return module.main


def record_gif(policy_spec: str, episode: su.EpisodeSpec, path: Path, seed: int) -> dict:
    """Play ``episode`` with the policy, rendering every other frame into an animated GIF."""
    import imageio.v2 as imageio

    env = gym.make(planar3p_gym.ENV_ID, render_mode="rgb_array", render_size=(480, 320))
    policy = load_policy(policy_spec, env=env, seed=seed)
    if hasattr(policy, "reset"):
        policy.reset()
    obs, info = env.reset(seed=seed, options=episode.reset_options())
    frames = [env.render()]
    state, start, steps, terminated, truncated = None, True, 0, False, False
    while not (terminated or truncated):
        action, state = policy.predict(obs, state=state, episode_start=np.array([start]))
        start = False
        obs, _, terminated, truncated, info = env.step(action)
        steps += 1
        if steps % 2 == 0 or terminated or truncated:
            frames.append(env.render())
    frames.extend([frames[-1]] * 12)  # hold the last picture for a moment
    fps = env.metadata["render_fps"] / 2
    env.close()
    path.parent.mkdir(parents=True, exist_ok=True)
    imageio.mimsave(path, frames, duration=1.0 / fps, loop=0)
    return {
        "steps": steps,
        "reason": info.get("termination_reason") or "time limit",
        "position_error_mm": 1000 * info["position_error"],
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=TRUSTED_FILES_NOTE,
    )
    p.add_argument("--out", type=Path, default=ROOT / "results" / "demo")
    p.add_argument("--policy", default=None, help="learned policy (default: the shipped one)")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)

    learned = args.policy
    if learned is None:
        shipped = list_pretrained()
        if not shipped:
            print("error: no pretrained policy in agents/pretrained/", file=sys.stderr)
            return 2
        learned = f"pretrained:{shipped[0]}"
    try:
        load_policy(learned, env=gym.make(planar3p_gym.ENV_ID))
    except PolicyError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2

    policies = [learned, ANALYTIC]
    bench_dir = args.out / "benchmark"
    print(f"Benchmarking {', '.join(policies)} on the quick suites ...", flush=True)
    status = _benchmark_main()(
        [
            "--quick",
            "--policies",
            ",".join(policies),
            "--seed",
            str(args.seed),
            "--out",
            str(bench_dir),
            "--force",  # the demo's own directory: a rerun replaces its results
        ]
    )
    if status != 0:
        return status

    episode = su.make_suite("standard", 1, args.seed).episodes[0]
    gifs = {}
    for spec in policies:
        path = args.out / f"{policy_label(spec).replace(':', '_').replace('/', '_')}.gif"
        outcome = record_gif(spec, episode, path, args.seed)
        gifs[spec] = (path, outcome)

    print("\nDone.")
    print(f"  report:        {bench_dir / 'report.md'}")
    print(f"  per episode:   {bench_dir / 'episodes.csv'}")
    print(f"  plots:         {bench_dir}/*.png")
    for spec, (path, outcome) in gifs.items():
        print(
            f"  animation:     {path}  ({spec}: {outcome['reason']} after "
            f"{outcome['steps']} steps, final error {outcome['position_error_mm']:.1f} mm)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
