"""Fixed evaluation suites of ``Planar3P-v0``: generation from a seed, saving and loading.

A suite is an explicit list of episodes ``(start, target, working_mode)`` generated from a seed
with its own generator (never the environment's) and played through ``env.reset(options=...)``,
so every policy sees exactly the same episodes; a shorter suite is a prefix of a longer one.
What each suite asks: docs/benchmark.md, "How the suite and score modules work".

* :data:`SUITE_NAMES`: ``standard`` (as the environment draws), ``hard`` (the straight path
  passes at or near a parallel singularity), ``far`` (ends far apart);
* :func:`make_suite`, :func:`make_suites`, :func:`save_suites`, :func:`load_suites`,
  :class:`Suite`, :class:`EpisodeSpec`: building and storing them.
"""

from __future__ import annotations

import copy
import json
import zlib
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from planar3p_agents.evaluation.path_diagnostics import (
    path_dict,
    path_profiles,
    profile,
    with_sequential,
    with_slider_line,
)
from planar3p_agents.evaluation.region_maps import RegionMap
from planar3p_gym.envs.core import DEFAULT_WORKING_MODE
from planar3p_gym.machine.design import Design
from planar3p_gym.machine.statics import holding_forces
from planar3p_gym.tasks import sampling as task

__all__ = [
    "DEFAULT_SUITE_MODES",
    "SUITE_FORMAT",
    "SUITE_NAMES",
    "EpisodeSpec",
    "Suite",
    "load_suites",
    "make_suite",
    "make_suites",
    "save_suites",
    "suite_id",
    "triple",
]

#: The evaluation suites of the reach task, in report order.
SUITE_NAMES: tuple[str, ...] = ("standard", "hard", "far")
_SUITE_IDS = {name: i for i, name in enumerate(SUITE_NAMES)}
#: Working mode of each suite unless another is asked for.
DEFAULT_SUITE_MODES: dict[str, tuple[int, int, int]] = {
    "standard": DEFAULT_WORKING_MODE,
    "hard": DEFAULT_WORKING_MODE,
    "far": DEFAULT_WORKING_MODE,
}
#: ``format`` field of a suite file.
SUITE_FORMAT = "planar3p-benchmark-suites/1"

FloatArray = NDArray[np.float64]


def suite_id(name: str) -> int:
    """A small integer naming suite ``name`` in seed sequences (for a name that is not a reach
    suite, e.g. a task suite, one derived from the name's CRC-32)."""
    return _SUITE_IDS.get(name, 100 + zlib.crc32(name.encode()) % 1_000_000)


@dataclass(frozen=True)
class EpisodeSpec:
    """One episode of a suite.

    Attributes:
        suite: suite name.
        index: position in the suite (0-based).
        start, target: poses ``(x, y, theta)`` (m, m, rad); ``target`` is ``None`` for a task
            without one (tracking).
        working_mode: ``(s1, s2, s3)`` at the start.
        path: diagnostics of the straight path in pose space from start to target (see
            :func:`planar3p_agents.evaluation.path_diagnostics.path_profiles`): ``distance`` (m),
            ``reachable``, ``min_parallel_margin``, ``min_serial_margin``, ``crosses`` (``det A``
            changes sign), ``clear`` (meets the environment's clear-path test); for the reach suites
            also the sequential path's (``sequential_<key>``) and ``slider_line_reaches``
            (:func:`planar3p_agents.evaluation.path_diagnostics.with_slider_line`).
        options: for a task suite (:mod:`planar3p_agents.evaluation.task_suites`), the environment's
            ``info["episode_spec"]``, which ``reset(options=...)`` replays; ``None`` for the
            reach suites, whose options are built from start, target and working mode.
    """

    suite: str
    index: int
    start: tuple[float, float, float]
    target: tuple[float, float, float] | None
    working_mode: tuple[int, int, int]
    path: dict[str, Any] = field(default_factory=dict)
    options: dict[str, Any] | None = None

    def reset_options(self) -> dict[str, Any]:
        """The ``options`` of ``env.reset`` that play this episode."""
        if self.options is not None:
            return copy.deepcopy(self.options)
        return {
            "start": np.array(self.start),
            "target": np.array(self.target),
            "working_mode": self.working_mode,
        }

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON values (``options`` only for a task suite)."""
        out = {
            "suite": self.suite,
            "index": self.index,
            "start": list(self.start),
            "target": None if self.target is None else list(self.target),
            "working_mode": list(self.working_mode),
            "path": dict(self.path),
        }
        if self.options is not None:
            out["options"] = copy.deepcopy(self.options)
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> EpisodeSpec:
        """Inverse of :meth:`to_dict`."""
        target = data["target"]
        options = data.get("options")
        return cls(
            suite=str(data["suite"]),
            index=int(data["index"]),
            start=triple(data["start"]),
            target=None if target is None else triple(target),
            working_mode=tuple(int(v) for v in data["working_mode"]),  # type: ignore[arg-type]
            path=dict(data.get("path", {})),
            options=None if options is None else dict(options),
        )


def triple(v: Iterable[Any]) -> tuple[float, float, float]:
    """Three floats from any iterable of three numbers (``ValueError`` otherwise)."""
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
            out.append((pool[i[k]], pool[j[k]], path_dict(prof, int(k))))
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
    against gravity (:func:`planar3p_gym.machine.statics.holding_forces`), so a policy that does
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
            pairs.append((s, t, path_dict(prof, 0)))
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
                prof = profile(design, task.interpolate(s, t, 24), mode, coarse)
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
            triple(s),
            triple(t),
            mode,  # type: ignore[arg-type]
            with_slider_line(design, s, t, mode, with_sequential(design, s, t, mode, cfg, path)),
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
        "format": SUITE_FORMAT,
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
    if not isinstance(data, dict) or data.get("format") != SUITE_FORMAT:
        raise ValueError(f"{p} is not a benchmark suite file (format {SUITE_FORMAT!r})")
    try:
        suites = {s["name"]: Suite.from_dict(s) for s in data["suites"]}
        design = Design.from_dict(data["design"])
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"malformed suite file {p}: {exc}") from exc
    return suites, design
