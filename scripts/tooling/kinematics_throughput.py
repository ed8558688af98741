"""Throughput of the vectorised kinematics (``python scripts/bench_kinematics.py``).

* :func:`reachable_poses`: reachable poses (uniform over the paper's search rectangle, uniform
  orientation and working mode, travels inside the stroke) with their modes and travels;
* :func:`hard_travels`: travels of poses close to parallel singularities (parallel margin 1e-3
  to 1e-8) and with ``theta`` near 0 or pi, where the direct-kinematics solver takes its slow
  path;
* :func:`rate`: items per second of a call, median of timed runs after a warm-up, by the wall
  clock and by the process's CPU time.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable

import numpy as np

from planar3p_gym.machine import kinematics as K
from planar3p_gym.machine.design import Design

__all__ = ["hard_travels", "rate", "reachable_poses"]


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
