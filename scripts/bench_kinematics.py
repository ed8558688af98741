"""Throughput of the vectorised kinematics on one core (a script, not a test).

    python scripts/bench_kinematics.py [--batch 10000] [--repeats 7] [--design fig8|fig7]
                                       [--profile]

Prints, for the chosen design (default: the default design, ``fig8`` with stroke 0.30 m):

* IK: poses per second of :func:`planar3p_gym.machine.kinematics.inverse` on a batch of poses, each
  with its own working mode;
* DK: solves per second of :func:`planar3p_gym.machine.kinematics.forward_batch` (every solution of
  every row) on the travels of reachable poses (uniform over the paper's search rectangle,
  uniform orientation and working mode, travels inside the stroke);
* DK on a hard batch: travels of poses close to parallel singularities (parallel margin
  1e-3 to 1e-8) and with ``theta`` near 0 or pi, where the solver takes its slow path.

Each figure is the median of ``--repeats`` timed runs after one warm-up run.  Thread pools
of the BLAS libraries are limited to one thread before numpy is imported.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import cProfile  # noqa: E402
import platform  # noqa: E402
import pstats  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402

import numpy as np  # noqa: E402

from planar3p_gym.machine import kinematics as K  # noqa: E402
from planar3p_gym.machine.design import Design  # noqa: E402


def reachable_poses(design: Design, n: int, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    """``n`` reachable poses (both half-planes) with their working modes and travels."""
    x0, x1, _, h = design.search_rectangle
    poses, modes, rhos = [], [], []
    got = 0
    while got < n:
        m = 4 * n
        p = np.stack(
            [rng.uniform(x0, x1, m), rng.uniform(-h, h, m), rng.uniform(-np.pi, np.pi, m)], -1
        )
        mode = K.ALL_MODES[rng.integers(0, 8, m)]
        ik = K.inverse(design, p, mode)
        ok = ik.reachable
        poses.append(p[ok])
        modes.append(mode[ok])
        rhos.append(ik.rho[ok])
        got += int(ok.sum())
    return tuple(np.concatenate(a)[:n] for a in (poses, modes, rhos))


def hard_travels(design: Design, n: int, rng: np.random.Generator) -> np.ndarray:
    """Travels of poses near parallel singularities and with theta near 0 or pi."""
    p, mode, _ = reachable_poses(design, 4 * n, rng)
    ref = design.characteristic_length
    out = []
    # walk from each pose along a random direction to the first sign change of det A, then
    # step back by a small distance
    direction = rng.normal(size=p.shape)
    direction[:, 2] /= ref
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    ts = np.linspace(0.0, 0.05, 21)
    A_sign = []
    for t in ts:
        q = p + t * direction
        rho = K.inverse(design, q, mode).rho
        s = np.zeros(len(q))
        ok = ~np.isnan(rho).any(axis=1)
        s[ok] = K.assembly_mode(design, q[ok], rho[ok])
        A_sign.append(s)
    A_sign = np.stack(A_sign)
    change = (A_sign[:-1] * A_sign[1:]) < 0
    has = change.any(axis=0)
    first = np.argmax(change, axis=0)
    idx = np.nonzero(has)[0]
    lo, hi = ts[first[idx]], ts[first[idx] + 1]
    for _ in range(50):  # bisection on the sign of det A
        mid = 0.5 * (lo + hi)
        q = p[idx] + mid[:, None] * direction[idx]
        rho = K.inverse(design, q, mode[idx]).rho
        s = K.assembly_mode(design, q, np.nan_to_num(rho))
        same = s == A_sign[first[idx], idx]
        lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
    eps = 10.0 ** rng.uniform(-8, -3, idx.size)
    q = p[idx] + (lo - eps)[:, None] * direction[idx]
    rho = K.inverse(design, q, mode[idx]).rho
    out.append(rho[~np.isnan(rho).any(axis=1)])
    # theta near 0 or pi
    m = 4 * n
    th = rng.choice([0.0, np.pi], m) + rng.choice([-1.0, 1.0], m) * 10.0 ** rng.uniform(-9, -2, m)
    x0, x1, _, h = design.search_rectangle
    q = np.stack([rng.uniform(x0, x1, m), rng.uniform(-h, h, m), th], -1)
    rho = K.inverse(design, q, K.ALL_MODES[rng.integers(0, 8, m)]).rho
    out.append(rho[~np.isnan(rho).any(axis=1)])
    rho = np.concatenate(out)
    return rho[rng.permutation(len(rho))[:n]]


def rate(fn: Callable[[], object], items: int, repeats: int) -> tuple[float, float]:
    """Median items/s of ``repeats`` timed calls (after one warm-up call), by the wall clock
    and by the process's CPU time (the latter is immune to other jobs sharing the core)."""
    fn()
    wall, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return items / statistics.median(wall), items / statistics.median(cpu)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--batch", type=int, default=10_000, help="rows per vectorised call")
    ap.add_argument("--repeats", type=int, default=7, help="timed runs (median reported)")
    ap.add_argument("--design", choices=("fig8", "fig7"), default="fig8")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--profile", action="store_true", help="cProfile forward_batch")
    args = ap.parse_args()

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
    print(f"batch {n} rows, median of {args.repeats} runs, one thread")

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


if __name__ == "__main__":
    main()
