"""Fixed evaluation suites, the episode runner and the statistics of the policy benchmark.

Suites
------
A suite is an explicit list of episodes ``(start, target, working_mode)`` generated from a seed
with its own ``numpy`` generator (never the environment's), and played through
``env.reset(options=...)``, so every policy sees exactly the same episodes.  Episode ``i`` of a
suite does not depend on how many episodes are asked for (a shorter suite is a prefix of a
longer one with the same seed).  Every pair is a valid reset option: reachable within the
stroke, same assembly mode (``sign det A``), not at a singularity.

* ``standard``: pairs drawn exactly as the environment draws them (``task.sample_pair``):
  comfortable margins at both ends, straight path in pose space clear of singularities.
* ``hard``: both ends as comfortable as the environment's own start poses (its parallel and
  serial margins, travel margin, and at most ``hold_force_fraction`` of the actuator force
  needed to hold them against gravity), the straight path reachable within the stroke and
  away from serial singularities, but passing through a parallel singularity (``det A``
  changes sign along it) or within a parallel margin of ``hard_margin`` of one, so a
  controller that does not look ahead meets it.  The two ends are in the same connected
  region of their assembly mode (with margins) on a grid of the configuration space, so a
  detour exists.  On the default design no such path *crosses* ``det A = 0``: in every working
  mode the parallel singularities are wrapped in a band of poor conditioning, so pairs whose
  straight path crosses one have ill-conditioned ends (pass a lower ``end_parallel_margin``
  and another ``working_mode``, e.g. ``(1, 1, 1)``, for such a stress test).
* ``far``: pairs whose pose distance ``|dp| + L_ref |dtheta|`` is in the top decile of
  same-assembly pairs of acceptable poses (ends near opposite sides of the workspace of the
  working mode); the straight path need not be clear (it may leave the workspace), but both
  ends are in the same connected region, so the task is solvable.

Every suite uses the environment's default working mode ``(1, 1, -1)`` unless told otherwise.

Runner and statistics
---------------------
:func:`run_episode` plays one episode with any object that has an SB3-style ``predict`` and
returns an :class:`EpisodeResult`; :func:`evaluate` plays a suite.  :func:`summarize`
aggregates: success rate and IQM of the return with percentile-bootstrap confidence intervals
(:func:`bootstrap_ci`, :func:`iqm`), median errors, time to success, margins, failure counts,
actuator saturation and mechanical energy.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planar3p_gym import kinematics, task
from planar3p_gym.design import Design
from planar3p_gym.env import DEFAULT_WORKING_MODE
from planar3p_gym.observation import SLICES
from planar3p_gym.statics import holding_forces
from planar3p_gym.workspace import merge_labels

__all__ = [
    "DEFAULT_SUITE_MODES",
    "FAILURE_CAUSES",
    "SUITE_NAMES",
    "EpisodeResult",
    "EpisodeSpec",
    "RegionMap",
    "Suite",
    "bootstrap_ci",
    "episode_seed",
    "evaluate",
    "iqm",
    "load_suites",
    "make_suite",
    "make_suites",
    "path_profiles",
    "run_episode",
    "save_suites",
    "sequential_path_profiles",
    "summarize",
    "ytheta_fields",
]

#: The evaluation suites, in report order.
SUITE_NAMES: tuple[str, ...] = ("standard", "hard", "far")
_SUITE_IDS = {name: i for i, name in enumerate(SUITE_NAMES)}
#: Working mode of each suite unless another is asked for.
DEFAULT_SUITE_MODES: dict[str, tuple[int, int, int]] = {
    "standard": DEFAULT_WORKING_MODE,
    "hard": DEFAULT_WORKING_MODE,
    "far": DEFAULT_WORKING_MODE,
}
#: How an episode ended (``EpisodeResult.cause``): success, the two failures the environment
#: reports, and the diagnoses of a timeout from the final state.
FAILURE_CAUSES: tuple[str, ...] = (
    "success",
    "singularity_crossing",
    "physics_breakdown",
    "stalled_at_parallel_singularity",
    "stroke_limit",
    "serial_singularity",
    "not_at_rest",
    "not_converged",
)
_SUITE_FORMAT = "planar3p-benchmark-suites/1"

FloatArray = NDArray[np.float64]


# =============================================================================== suites
@dataclass(frozen=True)
class EpisodeSpec:
    """One episode of a suite.

    Attributes:
        suite: suite name.
        index: position in the suite (0-based).
        start, target: poses ``(x, y, theta)`` (m, m, rad).
        working_mode: ``(s1, s2, s3)``.
        path: diagnostics of the straight path in pose space from start to target (see
            :func:`path_profiles`): ``distance`` (m), ``reachable``, ``min_parallel_margin``,
            ``min_serial_margin``, ``crosses`` (``det A`` changes sign), ``clear`` (meets the
            environment's clear-path test).
    """

    suite: str
    index: int
    start: tuple[float, float, float]
    target: tuple[float, float, float]
    working_mode: tuple[int, int, int]
    path: dict[str, Any] = field(default_factory=dict)

    def reset_options(self) -> dict[str, Any]:
        """The ``options`` of ``env.reset`` that play this episode."""
        return {
            "start": np.array(self.start),
            "target": np.array(self.target),
            "working_mode": self.working_mode,
        }

    def to_dict(self) -> dict[str, Any]:
        return {
            "suite": self.suite,
            "index": self.index,
            "start": list(self.start),
            "target": list(self.target),
            "working_mode": list(self.working_mode),
            "path": dict(self.path),
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> EpisodeSpec:
        return cls(
            suite=str(data["suite"]),
            index=int(data["index"]),
            start=_triple(data["start"]),
            target=_triple(data["target"]),
            working_mode=tuple(int(v) for v in data["working_mode"]),  # type: ignore[arg-type]
            path=dict(data.get("path", {})),
        )


def _triple(v: Iterable[Any]) -> tuple[float, float, float]:
    a, b, c = (float(x) for x in v)
    return (a, b, c)


@dataclass
class Suite:
    """A named, seeded list of episodes and the parameters that generated it."""

    name: str
    seed: int
    episodes: list[EpisodeSpec]
    params: dict[str, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.episodes)

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "seed": self.seed,
            "params": self.params,
            "episodes": [e.to_dict() for e in self.episodes],
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Suite:
        return cls(
            name=str(data["name"]),
            seed=int(data["seed"]),
            episodes=[EpisodeSpec.from_dict(e) for e in data["episodes"]],
            params=dict(data.get("params", {})),
        )


def _suite_rng(name: str, seed: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence([int(seed), 0x5117E, _SUITE_IDS[name]]))


def path_profiles(
    design: Design,
    starts: ArrayLike,
    targets: ArrayLike,
    mode: ArrayLike,
    n_points: int = 64,
    cfg: task.TaskConfig | None = None,
) -> dict[str, np.ndarray]:
    """Diagnostics of the straight paths in pose space ``starts[k] -> targets[k]``.

    Returns arrays of shape ``(N,)``: ``distance`` (pose distance, m), ``reachable`` (every
    one of ``n_points`` poses reachable within the stroke in ``mode``),
    ``min_parallel_margin`` / ``min_serial_margin`` over the poses where every leg can close
    (NaN if none), ``crosses`` (``sign det A`` differs from the start's somewhere), and
    ``clear`` (reachable, no crossing, margins at least the task's path margins).
    """
    s = np.atleast_2d(np.asarray(starts, dtype=np.float64))
    t = np.atleast_2d(np.asarray(targets, dtype=np.float64))
    out = {"distance": task.pose_distance(s, t, design.characteristic_length)}
    out.update(_profile(design, task.interpolate(s, t, n_points), mode, cfg))
    return out


def sequential_path_profiles(
    design: Design,
    starts: ArrayLike,
    targets: ArrayLike,
    mode: ArrayLike,
    n_points: int = 64,
    cfg: task.TaskConfig | None = None,
) -> dict[str, np.ndarray]:
    """The diagnostics of :func:`path_profiles` for the path of the sequential simple motions:
    rotation about ``G`` to the target angle, then vertical, then horizontal translation."""
    s = np.atleast_2d(np.asarray(starts, dtype=np.float64))
    t = np.atleast_2d(np.asarray(targets, dtype=np.float64))
    dth = (t[:, 2] - s[:, 2] + math.pi) % (2.0 * math.pi) - math.pi
    w1 = s.copy()
    w1[:, 2] = s[:, 2] + dth
    w2 = w1.copy()
    w2[:, 1] = t[:, 1]
    w3 = t.copy()
    w3[:, 2] = w1[:, 2]
    path = np.concatenate(
        [task.interpolate(a, b, n_points) for a, b in ((s, w1), (w1, w2), (w2, w3))], axis=-2
    )
    return _profile(design, path, mode, cfg)


def _profile(
    design: Design, path: FloatArray, mode: ArrayLike, cfg: task.TaskConfig | None
) -> dict[str, np.ndarray]:
    cfg = cfg or task.TaskConfig()
    rho, reach = kinematics.inverse(design, path, np.asarray(mode, dtype=np.float64))
    closable = np.isfinite(rho).all(axis=-1)
    r = np.nan_to_num(rho)
    A = kinematics.normalised_A(design, path, r)
    with np.errstate(invalid="ignore", divide="ignore"):
        sv = np.linalg.svd(A, compute_uv=False)
        pm = sv[..., -1] / sv[..., 0]
        u = kinematics.leg_vectors(design, path, r)
        sm = np.min(np.abs(u[..., 0]) / np.hypot(u[..., 0], u[..., 1]), axis=-1)
    det = np.sign(np.linalg.det(A))
    min_pm = np.where(closable, pm, np.inf).min(axis=-1)
    min_sm = np.where(closable, sm, np.inf).min(axis=-1)
    min_pm = np.where(np.isinf(min_pm), np.nan, min_pm)
    min_sm = np.where(np.isinf(min_sm), np.nan, min_sm)
    crosses = (closable & (det != det[:, :1])).any(axis=-1)
    reachable = reach.all(axis=-1)
    with np.errstate(invalid="ignore"):
        clear = (
            reachable
            & ~crosses
            & (min_pm >= cfg.path_parallel_margin)
            & (min_sm >= cfg.path_serial_margin)
        )
    return {
        "reachable": reachable,
        "min_parallel_margin": min_pm,
        "min_serial_margin": min_sm,
        "crosses": crosses,
        "clear": clear,
    }


def _with_sequential(
    design: Design, s: FloatArray, t: FloatArray, mode: ArrayLike, cfg: task.TaskConfig, path: dict
) -> dict[str, Any]:
    seq = sequential_path_profiles(design, s, t, mode, cfg=cfg)
    out = dict(path)
    out.update({f"sequential_{k}": v for k, v in _path_dict(seq, 0).items()})
    return out


def _path_dict(prof: dict[str, np.ndarray], k: int) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, arr in prof.items():
        v = arr[k].item()
        out[key] = bool(v) if isinstance(v, (bool, np.bool_)) else round(float(v), 6)
    return out


# ------------------------------------------------------------------ (y, theta) fields
def ytheta_fields(
    design: Design, mode: ArrayLike, ys: ArrayLike, thetas: ArrayLike
) -> dict[str, np.ndarray]:
    """Kinematic fields over a ``(y, theta)`` grid, shape ``(len(ys), len(thetas))`` each.

    With every rail on ``y = 0`` the leg vectors do not depend on the gripper's ``x``, so the
    singularity structure is a function of ``(y, theta)`` (and the working mode) alone:
    ``det`` (``det A_bar``, NaN where a leg cannot close), ``parallel_margin``,
    ``serial_margin``, ``closable``, and the interval ``[x_lo, x_hi]`` of gripper ``x`` that
    keeps every travel inside ``[0, stroke]`` (empty when ``x_lo > x_hi``).
    """
    y = np.asarray(ys, dtype=np.float64)
    th = np.asarray(thetas, dtype=np.float64)
    Y, T = np.meshgrid(y, th, indexing="ij")
    poses = np.stack([np.zeros_like(Y), Y, T], axis=-1)
    rho0, _ = kinematics.inverse(design, poses, np.asarray(mode, dtype=np.float64))
    closable = np.isfinite(rho0).all(axis=-1)
    r = np.nan_to_num(rho0)
    A = kinematics.normalised_A(design, poses, r)
    det = np.where(closable, np.linalg.det(A), np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        sv = np.linalg.svd(A, compute_uv=False)
        pm = np.where(closable, sv[..., -1] / sv[..., 0], np.nan)
        u = kinematics.leg_vectors(design, poses, r)
        sm = np.where(
            closable, np.min(np.abs(u[..., 0]) / np.hypot(u[..., 0], u[..., 1]), axis=-1), np.nan
        )
    # rho_i(x) = x + rho_i(0): all in [0, L] iff x in [max(-rho_i(0)), min(L - rho_i(0))].
    x_lo = np.where(closable, np.max(-r, axis=-1), np.inf)
    x_hi = np.where(closable, np.min(design.stroke - r, axis=-1), -np.inf)
    return {
        "det": det,
        "parallel_margin": pm,
        "serial_margin": sm,
        "closable": closable,
        "x_lo": x_lo,
        "x_hi": x_hi,
    }


def _label(mask: NDArray[np.bool_], wrap_last: bool) -> NDArray[np.int64]:
    """Face-connected components of an n-D mask (last axis periodic if ``wrap_last``):
    labels ``-1`` off the mask, else the smallest flat index of the component."""
    shape = mask.shape
    idx = np.arange(mask.size).reshape(shape)
    ea, eb = [], []
    for ax in range(mask.ndim):
        a = np.moveaxis(idx, ax, 0)
        m = np.moveaxis(mask, ax, 0)
        pairs = [(a[:-1], a[1:], m[:-1] & m[1:])]
        if wrap_last and ax == mask.ndim - 1 and shape[ax] > 2:
            pairs.append((a[-1:], a[:1], m[-1:] & m[:1]))
        for p, q, ok in pairs:
            ea.append(p[ok])
            eb.append(q[ok])
    lab = merge_labels(mask.size, np.concatenate(ea), np.concatenate(eb))
    out = np.where(mask.ravel(), lab, -1)
    return out.reshape(shape)


class RegionMap:
    """Connected regions of one working mode's configuration space, per assembly mode.

    A grid over ``(x, y, theta)`` (``x`` over the search rectangle, ``y`` in ``[-h, h]``,
    ``theta`` periodic) marks the cells reachable within the stroke with parallel margin at
    least ``min_parallel_margin``, serial margin at least ``min_serial_margin`` and a given
    sign of ``det A``; :meth:`region` names the connected component a pose lies in.  Two poses
    in the same region are joined by a path that keeps those margins (up to grid resolution),
    so a task between them is solvable without crossing a singularity.
    """

    def __init__(
        self,
        design: Design,
        mode: ArrayLike,
        min_parallel_margin: float = 0.015,
        min_serial_margin: float = 0.1,
        shape: tuple[int, int, int] = (72, 56, 144),
    ) -> None:
        self.design = design
        self.mode = tuple(int(m) for m in np.asarray(mode).tolist())
        nx, ny, nt = shape
        x0, x1, _, h = design.search_rectangle
        self.x = np.linspace(x0, x1, nx)
        self.y = np.linspace(-h, h, ny)
        self.theta = -math.pi + 2.0 * math.pi * np.arange(nt) / nt
        f = ytheta_fields(design, self.mode, self.y, self.theta)
        with np.errstate(invalid="ignore"):
            ok2 = (
                f["closable"]
                & (f["parallel_margin"] >= min_parallel_margin)
                & (f["serial_margin"] >= min_serial_margin)
            )
        X = self.x[:, None, None]
        inside = (X >= f["x_lo"][None]) & (X <= f["x_hi"][None])
        sign = np.sign(np.nan_to_num(f["det"]))
        self.labels = np.full((nx, ny, nt), -1, dtype=np.int64)
        for s in (1.0, -1.0):
            mask = inside & (ok2 & (sign == s))[None]
            lab = _label(mask, wrap_last=True)
            self.labels = np.where(mask, lab * 2 + (0 if s > 0 else 1), self.labels)

    def region(self, pose: ArrayLike) -> int:
        """Label of the region of the grid cells around ``pose`` (-1 if none is inside)."""
        x, y, th = (float(v) for v in np.asarray(pose, dtype=np.float64))
        best, best_d = -1, math.inf
        fx = np.interp(x, self.x, np.arange(self.x.size))
        fy = np.interp(y, self.y, np.arange(self.y.size))
        nt = self.theta.size
        ft = ((th + math.pi) / (2.0 * math.pi) * nt) % nt
        for ix in {math.floor(fx), min(math.floor(fx) + 1, self.x.size - 1)}:
            for iy in {math.floor(fy), min(math.floor(fy) + 1, self.y.size - 1)}:
                for it in {math.floor(ft) % nt, (math.floor(ft) + 1) % nt}:
                    lab = int(self.labels[ix, iy, it])
                    if lab < 0:
                        continue
                    dt = min(abs(ft - it), nt - abs(ft - it))
                    d = (fx - ix) ** 2 + (fy - iy) ** 2 + dt**2
                    if d < best_d:
                        best, best_d = lab, d
        return best


def _pose_pool(
    design: Design,
    mode: tuple[int, int, int],
    rng: np.random.Generator,
    cfg: task.TaskConfig,
    size: int,
    max_force: float | None = None,
) -> tuple[FloatArray, FloatArray]:
    poses, dets = [], []
    total = 0
    if max_force is not None:  # the suite's own limit replaces the task's holding-force limit
        cfg = replace(cfg, max_holding_force=1.0)
    for _ in range(400):
        p, d = task.sample_poses(design, mode, rng, cfg)
        if max_force is not None:
            with np.errstate(invalid="ignore"):
                ok = np.abs(holding_forces(design, p, mode)).max(axis=-1) <= max_force
            p, d = p[ok], d[ok]
        poses.append(p)
        dets.append(d)
        total += len(p)
        if total >= size:
            break
    return np.concatenate(poses), np.concatenate(dets)


def _pairs_from_pool(
    design: Design,
    mode: tuple[int, int, int],
    rng: np.random.Generator,
    cfg: task.TaskConfig,
    n: int,
    accept: Callable[[FloatArray, FloatArray, dict[str, np.ndarray]], NDArray[np.bool_]],
    regions: RegionMap,
    pool_size: int = 3000,
    batch: int = 4096,
    max_batches: int = 200,
    max_force: float | None = None,
    prefilter: Callable[[FloatArray, FloatArray], NDArray[np.bool_]] | None = None,
) -> tuple[list[tuple[FloatArray, FloatArray, dict[str, Any]]], dict[str, int]]:
    """Candidate pairs from a pool of acceptable poses (same assembly mode, at least the
    minimum distance apart), kept in order when ``prefilter`` (a cheap test) and ``accept``
    (on the path profiles) say so and both ends lie in the same region of ``regions``."""
    pool, dets = _pose_pool(design, mode, rng, cfg, pool_size, max_force)
    out: list[tuple[FloatArray, FloatArray, dict[str, Any]]] = []
    counts = {"candidates": 0, "accepted_by_path": 0, "rejected_unsolvable": 0}
    region_cache: dict[int, int] = {}

    def region(i: int) -> int:
        if i not in region_cache:
            region_cache[i] = regions.region(pool[i])
        return region_cache[i]

    for _ in range(max_batches):
        i = rng.integers(len(pool), size=batch)
        j = rng.integers(len(pool), size=batch)
        keep = (i != j) & (dets[i] == dets[j])
        i, j = i[keep], j[keep]
        far = task.pose_distance(pool[i], pool[j], design.characteristic_length) >= cfg.min_distance
        i, j = i[far], j[far]
        counts["candidates"] += len(i)
        if prefilter is not None:
            keep = prefilter(pool[i], pool[j])
            i, j = i[keep], j[keep]
        prof = path_profiles(design, pool[i], pool[j], mode, cfg=cfg)
        ok = accept(pool[i], pool[j], prof)
        for k in np.flatnonzero(ok):
            counts["accepted_by_path"] += 1
            ri, rj = region(int(i[k])), region(int(j[k]))
            if ri < 0 or ri != rj:
                counts["rejected_unsolvable"] += 1
                continue
            out.append((pool[i[k]], pool[j[k]], _path_dict(prof, int(k))))
            if len(out) >= n:
                return out, counts
    raise ValueError(
        f"could only find {len(out)} of {n} pairs for this suite in working mode {mode} "
        f"after {counts['candidates']} candidates; relax its parameters"
    )


def make_suite(
    name: str,
    n_episodes: int,
    seed: int,
    design: Design | None = None,
    working_mode: Sequence[int] | None = None,
    task_config: task.TaskConfig | None = None,
    hard_margin: float = 0.01,
    end_parallel_margin: float | None = None,
    far_quantile: float = 0.9,
    hold_force_fraction: float = 0.25,
) -> Suite:
    """Generate suite ``name`` (one of :data:`SUITE_NAMES`) of ``n_episodes`` from ``seed``.

    ``working_mode`` defaults to :data:`DEFAULT_SUITE_MODES`; ``task_config`` to the
    environment's.  ``hard_margin``: the ``hard`` paths come within this parallel margin of a
    singularity (or cross one) while both ends have a parallel margin of at least
    ``end_parallel_margin`` (default: the task's ``min_parallel_margin``, the margin the
    environment demands of its start poses).  ``far_quantile``: the ``far`` pairs have
    a pose distance above this quantile of same-assembly pairs.  ``hold_force_fraction``: the
    ends of ``hard`` and ``far`` pairs need at most this fraction of ``max_force`` to be held
    against gravity (:func:`planar3p_gym.statics.holding_forces`), so a policy that does
    nothing stays put.
    """
    if name not in _SUITE_IDS:
        raise ValueError(f"unknown suite {name!r}; known: {', '.join(SUITE_NAMES)}")
    if not (isinstance(n_episodes, (int, np.integer)) and n_episodes >= 1):
        raise ValueError(f"n_episodes must be a positive integer, got {n_episodes!r}")
    design = design or Design.fig8()
    cfg = task_config or task.TaskConfig()
    mode = tuple(int(m) for m in (working_mode or DEFAULT_SUITE_MODES[name]))
    if len(mode) != 3 or any(m not in (1, -1) for m in mode):
        raise ValueError(f"working_mode must be three entries of +1 or -1, got {working_mode!r}")
    rng = _suite_rng(name, seed)
    params: dict[str, Any] = {"working_mode": list(mode), "task_config": asdict(cfg)}
    if name != "standard":
        params["hold_force_fraction"] = hold_force_fraction
    pairs: list[tuple[FloatArray, FloatArray, dict[str, Any]]] = []
    if name == "standard":
        sampler = task.PoseSampler(design, mode, cfg)
        for _ in range(n_episodes):
            s, t = task.sample_pair(design, mode, rng, cfg, sampler=sampler)
            prof = path_profiles(design, s, t, mode, cfg=cfg)
            pairs.append((s, t, _path_dict(prof, 0)))
    else:
        regions = RegionMap(design, mode)
        pool_size = 6000 if name == "hard" else 3000
        if name == "hard":
            end = cfg.min_parallel_margin if end_parallel_margin is None else end_parallel_margin
            params["hard_margin"] = hard_margin
            params["end_parallel_margin"] = end
            pool_cfg = replace(cfg, min_parallel_margin=end)
            coarse = replace(cfg, path_points=24)

            def prefilter(s: FloatArray, t: FloatArray) -> np.ndarray:
                prof = _profile(design, task.interpolate(s, t, 24), mode, coarse)
                with np.errstate(invalid="ignore"):
                    return prof["crosses"] | (prof["min_parallel_margin"] <= 3.0 * hard_margin)

            def accept(s: FloatArray, t: FloatArray, prof: dict[str, np.ndarray]) -> np.ndarray:
                with np.errstate(invalid="ignore"):
                    return (
                        prof["reachable"]
                        & (prof["min_serial_margin"] >= cfg.path_serial_margin)
                        & (prof["crosses"] | (prof["min_parallel_margin"] <= hard_margin))
                    )

        else:
            params["far_quantile"] = far_quantile
            pool_cfg = cfg
            ref_pool, ref_dets = _pose_pool(
                design, mode, rng, cfg, 3000, hold_force_fraction * design.max_force
            )
            a = rng.integers(len(ref_pool), size=20000)
            b = rng.integers(len(ref_pool), size=20000)
            same = (a != b) & (ref_dets[a] == ref_dets[b])
            dist = task.pose_distance(
                ref_pool[a[same]], ref_pool[b[same]], design.characteristic_length
            )
            threshold = float(np.quantile(dist, far_quantile))
            params["far_distance"] = round(threshold, 6)

            def prefilter(s: FloatArray, t: FloatArray) -> np.ndarray:
                return task.pose_distance(s, t, design.characteristic_length) >= threshold

            def accept(s: FloatArray, t: FloatArray, prof: dict[str, np.ndarray]) -> np.ndarray:
                return prof["distance"] >= threshold

        pairs, counts = _pairs_from_pool(
            design,
            mode,
            rng,
            pool_cfg,
            n_episodes,
            accept,
            regions,
            pool_size=pool_size,
            max_force=hold_force_fraction * design.max_force,
            prefilter=prefilter,
        )
        params["generation"] = counts
    episodes = [
        EpisodeSpec(
            name,
            k,
            _triple(s),
            _triple(t),
            mode,  # type: ignore[arg-type]
            _with_sequential(design, s, t, mode, cfg, path),
        )
        for k, (s, t, path) in enumerate(pairs)
    ]
    return Suite(name, int(seed), episodes, params)


def make_suites(
    names: Sequence[str], n_episodes: int, seed: int, design: Design | None = None, **kwargs: Any
) -> dict[str, Suite]:
    """:func:`make_suite` for each name (unknown names raise ``ValueError`` before any work)."""
    for name in names:
        if name not in _SUITE_IDS:
            raise ValueError(f"unknown suite {name!r}; known: {', '.join(SUITE_NAMES)}")
    return {name: make_suite(name, n_episodes, seed, design, **kwargs) for name in names}


def save_suites(path: str | Path, suites: dict[str, Suite], design: Design | None = None) -> None:
    """Write suites (and the design they were made for) as JSON."""
    data = {
        "format": _SUITE_FORMAT,
        "design": (design or Design.fig8()).to_dict(),
        "suites": [s.to_dict() for s in suites.values()],
    }
    Path(path).write_text(json.dumps(data, indent=1) + "\n")


def load_suites(path: str | Path) -> tuple[dict[str, Suite], Design]:
    """Read suites written by :func:`save_suites`; ``ValueError`` with a clear message if the
    file is missing or not a suite file."""
    p = Path(path)
    try:
        data = json.loads(p.read_text())
    except FileNotFoundError as exc:
        raise ValueError(f"suite file not found: {p}") from exc
    except (OSError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"cannot read suite file {p}: {exc}") from exc
    if not isinstance(data, dict) or data.get("format") != _SUITE_FORMAT:
        raise ValueError(f"{p} is not a benchmark suite file (format {_SUITE_FORMAT!r})")
    try:
        suites = {s["name"]: Suite.from_dict(s) for s in data["suites"]}
        design = Design.from_dict(data["design"])
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"malformed suite file {p}: {exc}") from exc
    return suites, design


# =============================================================================== runner
@dataclass
class EpisodeResult:
    """Outcome and measurements of one episode (SI units unless the name says otherwise).

    ``cause`` is one of :data:`FAILURE_CAUSES`.  ``max_closure_error`` is the largest
    loop-closure error of the simulation during the episode (m).  ``trajectory`` (poses,
    ``(steps + 1, 3)``) is kept only when asked for and is not part of :meth:`row`.
    """

    policy: str
    suite: str
    index: int
    success: bool
    termination_reason: str
    cause: str
    steps: int
    duration: float
    time_to_success: float
    episode_return: float
    final_position_error: float
    final_orientation_error: float
    min_parallel_margin: float
    min_serial_margin: float
    saturation_fraction: float
    energy: float
    end_stop_fraction: float
    max_closure_error: float
    working_mode_changed: bool
    path_crosses: bool
    path_clear: bool
    sequential_path_clear: bool
    trajectory: np.ndarray | None = None

    def row(self) -> dict[str, Any]:
        """Plain values for CSV/JSON (no trajectory)."""
        out = asdict(self)
        out.pop("trajectory")
        return out


def _reset_policy(policy: Any, seed: np.random.SeedSequence) -> None:
    reset = getattr(policy, "reset", None)
    if callable(reset):
        try:
            reset(seed=seed)
        except TypeError:
            reset()


def episode_seed(seed: int, suite: str, index: int) -> np.random.SeedSequence:
    """Seed of a policy's randomness in episode ``index`` of ``suite`` (run order does not
    matter)."""
    return np.random.SeedSequence([int(seed), 0xE915, _SUITE_IDS.get(suite, 99), int(index)])


def _diagnose(info: dict[str, Any], design: Design, tol: task.TaskConfig) -> str:
    """Why an episode that timed out did not succeed, from its final state."""
    if info["parallel_margin"] < 0.01:
        return "stalled_at_parallel_singularity"
    stop = 0.005
    if any(r <= stop or r >= design.stroke - stop for r in info["rho"]):
        return "stroke_limit"
    if info["serial_margin"] < 0.05:
        return "serial_singularity"
    if (
        info["position_error"] <= tol.position_tolerance
        and abs(info["orientation_error"]) <= tol.orientation_tolerance
    ):
        return "not_at_rest"
    return "not_converged"


def run_episode(
    env: Any,
    policy: Any,
    spec: EpisodeSpec,
    *,
    policy_name: str = "policy",
    seed: int = 0,
    deterministic: bool = True,
    record: bool = False,
) -> EpisodeResult:
    """Play ``spec`` in ``env`` (a ``Planar3P-v0`` made with ``gymnasium.make``, so with its time
    limit) with ``policy`` (anything with SB3's ``predict``).  A policy with a ``reset(seed=)``
    method is reset first with :func:`episode_seed`."""
    base = env.unwrapped
    design: Design = base.design
    dt = float(base.dt)
    stroke = design.stroke
    _reset_policy(policy, episode_seed(seed, spec.suite, spec.index))
    obs, info = env.reset(seed=int(seed) + spec.index, options=spec.reset_options())
    state: Any = None
    start = np.ones(1, dtype=bool)
    total = 0.0
    energy = 0.0
    saturated = 0
    end_stop = 0
    closure = float(info["closure_error"])
    steps = 0
    min_pm = float(info["parallel_margin"])
    min_sm = float(info["serial_margin"])
    poses = [info["pose"]] if record else None
    legs = SLICES["legs"]
    mode = np.asarray(spec.working_mode, dtype=np.float64)
    mode_changed = False
    reason: str | None = None
    truncated = False
    while True:
        action, state = policy.predict(
            obs, state=state, episode_start=start, deterministic=deterministic
        )
        start = np.zeros(1, dtype=bool)
        action = np.asarray(action, dtype=np.float64).reshape(-1)
        if not np.isfinite(action).all():
            raise ValueError(f"policy {policy_name!r} returned a non-finite action {action}")
        obs, reward, terminated, truncated, info = env.step(action)
        steps += 1
        total += float(reward)
        f, v = info["actuator_forces"], info["rho_dot"]
        energy += (abs(f[0] * v[0]) + abs(f[1] * v[1]) + abs(f[2] * v[2])) * dt
        saturated += bool(any(info["actuator_saturated"]))
        rho = info["rho"]
        end_stop += bool(min(rho) <= 0.001 or max(rho) >= stroke - 0.001)
        closure = max(closure, float(info["closure_error"]))
        min_pm = min(min_pm, float(info["parallel_margin"]))
        min_sm = min(min_sm, float(info["serial_margin"]))
        if poses is not None:
            poses.append(info["pose"])
        if not mode_changed:
            cos_a = np.asarray(obs[legs], dtype=np.float64)[0::2]
            mode_changed = bool(np.any(cos_a * mode < -1e-3))
        if terminated or truncated:
            reason = info["termination_reason"]
            break
    success = bool(info["is_success"])
    if reason is None:
        reason = "timeout"
        cause = _diagnose(info, design, base.task_config)
    else:
        cause = reason
    return EpisodeResult(
        policy=policy_name,
        suite=spec.suite,
        index=spec.index,
        success=success,
        termination_reason=reason,
        cause=cause,
        steps=steps,
        duration=steps * dt,
        time_to_success=steps * dt if success else math.nan,
        episode_return=total,
        final_position_error=float(info["position_error"]),
        final_orientation_error=abs(float(info["orientation_error"])),
        min_parallel_margin=min_pm,
        min_serial_margin=min_sm,
        saturation_fraction=saturated / steps,
        energy=energy,
        end_stop_fraction=end_stop / steps,
        max_closure_error=closure,
        working_mode_changed=mode_changed,
        path_crosses=bool(spec.path.get("crosses", False)),
        path_clear=bool(spec.path.get("clear", False)),
        sequential_path_clear=bool(spec.path.get("sequential_clear", False)),
        trajectory=np.array(poses) if poses is not None else None,
    )


def evaluate(
    env: Any,
    policy: Any,
    suite: Suite,
    *,
    policy_name: str = "policy",
    seed: int = 0,
    record: bool | Callable[[EpisodeSpec], bool] = False,
    callback: Callable[[EpisodeResult], None] | None = None,
) -> list[EpisodeResult]:
    """Play every episode of ``suite``; ``record`` may be a predicate on the episode."""
    out = []
    for spec in suite.episodes:
        rec = record(spec) if callable(record) else bool(record)
        res = run_episode(env, policy, spec, policy_name=policy_name, seed=seed, record=rec)
        out.append(res)
        if callback is not None:
            callback(res)
    return out


# =============================================================================== statistics
def iqm(values: ArrayLike, axis: int = -1) -> np.ndarray | float:
    """Interquartile mean: the mean of the middle 50% of the values along ``axis``, trimming
    ``floor(n / 4)`` values at each end (as ``scipy.stats.trim_mean(x, 0.25)``, used by
    rliable).  NaN for an empty input."""
    x = np.sort(np.asarray(values, dtype=np.float64), axis=axis)
    n = x.shape[axis]
    if n == 0:
        return math.nan
    k = n // 4
    mid = np.take(x, np.arange(k, n - k), axis=axis)
    out = mid.mean(axis=axis)
    return float(out) if np.ndim(out) == 0 else out


def _mean(x: np.ndarray, axis: int = -1) -> np.ndarray:
    return np.mean(x, axis=axis)


def bootstrap_ci(
    values: ArrayLike,
    statistic: Callable[..., Any] = _mean,
    n_resamples: int = 2000,
    confidence: float = 0.95,
    seed: int = 0,
) -> tuple[float, float]:
    """Percentile-bootstrap confidence interval of ``statistic`` of ``values``.

    ``statistic(samples, axis=-1)`` must reduce the last axis (as ``np.mean``, :func:`iqm`).
    Resampling uses its own generator seeded with ``seed``, so the interval is reproducible.
    ``(nan, nan)`` for an empty input.
    """
    x = np.asarray(values, dtype=np.float64).reshape(-1)
    if x.size == 0:
        return (math.nan, math.nan)
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, x.size, size=(int(n_resamples), x.size))
    stats = np.asarray(statistic(x[idx], axis=-1), dtype=np.float64)
    alpha = (1.0 - confidence) / 2.0
    lo, hi = np.quantile(stats, [alpha, 1.0 - alpha])
    return (float(lo), float(hi))


def _median(values: Sequence[float]) -> float:
    x = np.asarray(values, dtype=np.float64)
    x = x[np.isfinite(x)]
    return float(np.median(x)) if x.size else math.nan


def summarize(
    results: Sequence[EpisodeResult], n_resamples: int = 2000, seed: int = 0
) -> dict[str, Any]:
    """Aggregate statistics of one policy on one suite (see the module docstring)."""
    if not results:
        raise ValueError("no episodes to summarize")
    succ = np.array([r.success for r in results], dtype=np.float64)
    ret = np.array([r.episode_return for r in results])
    causes = {c: 0 for c in FAILURE_CAUSES}
    for r in results:
        causes[r.cause] = causes.get(r.cause, 0) + 1
    total_steps = sum(r.steps for r in results)
    return {
        "policy": results[0].policy,
        "suite": results[0].suite,
        "episodes": len(results),
        "successes": int(succ.sum()),
        "success_rate": float(succ.mean()),
        "success_ci": bootstrap_ci(succ, n_resamples=n_resamples, seed=seed),
        "return_iqm": iqm(ret),
        "return_ci": bootstrap_ci(ret, iqm, n_resamples=n_resamples, seed=seed),
        "median_position_error_mm": 1000.0 * _median([r.final_position_error for r in results]),
        "median_orientation_error_deg": math.degrees(
            _median([r.final_orientation_error for r in results])
        ),
        "median_time_to_success": _median([r.time_to_success for r in results]),
        "worst_min_parallel_margin": float(min(r.min_parallel_margin for r in results)),
        "median_min_parallel_margin": _median([r.min_parallel_margin for r in results]),
        "singularity_crossings": causes["singularity_crossing"],
        "physics_breakdowns": causes["physics_breakdown"],
        "timeouts": sum(r.termination_reason == "timeout" for r in results),
        "saturation_fraction": float(
            sum(r.saturation_fraction * r.steps for r in results) / total_steps
        ),
        "median_energy": _median([r.energy for r in results]),
        "causes": causes,
        "path_crossing_episodes": int(sum(r.path_crosses for r in results)),
        "working_mode_changes": int(sum(r.working_mode_changed for r in results)),
    }
