#!/usr/bin/env python
"""Throughput of the vectorised kinematics on one core (a measurement, not a test).

Prints, for the chosen design (fig8: the default design, stroke 0.30 m; or fig7):

  IK   poses per second of planar3p_gym.machine.kinematics.inverse on a batch of poses, each
       with its own working mode
  DK   solves per second of kinematics.forward_batch (every solution of every row) on the
       travels of reachable poses (uniform over the paper's search rectangle, uniform
       orientation and working mode, travels inside the stroke)
  DK   on a hard batch: travels of poses close to parallel singularities (parallel margin 1e-3
       to 1e-8) and with theta near 0 or pi, where the solver takes its slow path

Each figure is the median of --repeats timed runs after one warm-up run, by the wall clock and
by the process's CPU time.  The process is pinned to one CPU (--no-pin: not).

Library: tooling.kinematics_throughput.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser
from tooling import script

#: Largest --batch (the hard batch is drawn from 16 times as many poses).
MAX_BATCH = 1_000_000


def add_arguments(p: CliParser) -> None:
    p.add_argument("--batch", type=int, default=10_000, help="rows per vectorised call")
    p.add_argument("--repeats", type=int, default=7, help="timed runs (median reported)")
    p.add_argument("--design", choices=("fig8", "fig7"), default="fig8", help="design preset")
    p.add_argument("--seed", type=int, default=0, help="seed of the sampled poses")
    p.add_argument("--profile", action="store_true", help="also cProfile forward_batch")
    p.add_argument("--no-pin", action="store_true", help="do not pin the process to one CPU")


def check(args: argparse.Namespace) -> None:
    checks.in_range("--batch", args.batch, 1, MAX_BATCH)
    checks.at_least("--repeats", args.repeats, 1)
    checks.at_least("--seed", args.seed, 0)


def run(args: argparse.Namespace) -> int:
    import cProfile
    import platform
    import pstats

    import numpy as np

    from planar3p_agents.commands.runtime import pin_one_core
    from planar3p_gym.machine import kinematics as K
    from planar3p_gym.machine.design import Design
    from tooling.kinematics_throughput import (
        hard_travels,
        rate,
        reachable_poses,
    )

    pinned = "not pinned" if args.no_pin else pin_one_core()
    design = Design.fig8() if args.design == "fig8" else Design.fig7()
    rng = np.random.default_rng(args.seed)
    n = args.batch
    poses, modes, rho = reachable_poses(design, n, rng)
    hard = hard_travels(design, n, rng)

    print(f"python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}")
    print(
        f"design {args.design}: legs {design.leg_lengths} m, spacings {design.spacings} m, "
        f"stroke {design.stroke} m"
    )
    print(f"batch {n} rows, median of {args.repeats} runs; {pinned}")

    ik_wall, ik_cpu = rate(lambda: K.inverse(design, poses, modes), n, args.repeats)
    print(f"IK  {ik_wall:10.3g} poses/s  (wall)   {ik_cpu:10.3g} poses/s  (CPU time)")

    sol = K.forward_batch(design, rho)
    dk_wall, dk_cpu = rate(lambda: K.forward_batch(design, rho), n, args.repeats)
    print(
        f"DK  {dk_wall:10.3g} solves/s (wall)   {dk_cpu:10.3g} solves/s (CPU time)   "
        f"reachable poses, {sol.count.mean():.2f} poses per solve"
    )
    hsol = K.forward_batch(design, hard)
    hk_wall, hk_cpu = rate(lambda: K.forward_batch(design, hard), len(hard), args.repeats)
    print(
        f"DK  {hk_wall:10.3g} solves/s (wall)   {hk_cpu:10.3g} solves/s (CPU time)   "
        f"hard batch, {hsol.count.mean():.2f} poses per solve"
    )
    one = rho[0]
    lat_wall, _ = rate(lambda: [K.forward_batch(design, one) for _ in range(200)], 200, 3)
    print(f"DK  {1e6 / lat_wall:10.3g} us per call on a single rho (Python overhead)")
    if args.profile:
        prof = cProfile.Profile()
        prof.runcall(lambda: [K.forward_batch(design, rho) for _ in range(5)])
        pstats.Stats(prof).sort_stats("tottime").print_stats(15)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run this script with ``argv`` (default: the process's arguments); the exit status."""
    return script.main(__name__, argv)


if __name__ == "__main__":
    raise SystemExit(main())
