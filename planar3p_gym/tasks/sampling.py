"""The reaching task: sampling start and target poses, and the success test.

Poses are drawn by rejection, uniformly over a region of the search box (``x`` over the search
rectangle, ``0 <= y <= h``, any ``theta``) that holds every pose reachable in the working mode
(:mod:`.pose_proposal`), and kept when they are reachable in the episode's working mode with
every travel away from the end stops, both singularity margins above thresholds, and holding
forces well within the actuators' limit (so that a machine told to stand still can).  A
target is paired with a start only if it has the same assembly mode (``sign det A``) and, by
default, the straight path between them in pose space stays reachable, in that assembly mode,
with margins: every task the environment samples can be solved without crossing a
singularity.
"""

from __future__ import annotations

import math
import operator
from collections import deque
from collections.abc import Callable, Iterator, Mapping
from dataclasses import asdict, dataclass, replace
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from planar3p_gym import checks
from planar3p_gym.checks import as_finite_float, as_int
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.machine.design import Design
from planar3p_gym.machine.kinematics import pose_distance
from planar3p_gym.machine.slider_line import slider_line_reaches
from planar3p_gym.machine.statics import holding_forces_of_rows
from planar3p_gym.tasks.pose_proposal import pose_proposal, propose

__all__ = [
    "PAIR_KINDS",
    "SCHEDULABLE_FIELDS",
    "PoseSampler",
    "TaskConfig",
    "assembly_modes",
    "check_detours",
    "check_mode",
    "check_pose",
    "draw_pair",
    "has_detours",
    "has_pairs",
    "path_is_clear",
    "sample_pair",
    "sample_poses",
    "updated_config",
]


#: The :class:`TaskConfig` fields that may change between episodes of a running environment
#: (:meth:`planar3p_gym.envs.core.Planar3PEnv.set_task_config`, training curricula): the success
#: test and the mix of training pairs.  The others decide which working modes have pairs at
#: all, which an environment checks once, when it is made.
SCHEDULABLE_FIELDS = (
    "position_tolerance",
    "orientation_tolerance",
    "rest_speed",
    "near_singular_fraction",
    "near_singular_margin",
    "detour_fraction",
)


def updated_config(cfg: TaskConfig, changes: Mapping[str, Any]) -> TaskConfig:
    """``cfg`` with ``changes`` (a mapping of :data:`SCHEDULABLE_FIELDS` to new values), checked
    as any :class:`TaskConfig`; ``ValueError`` naming the field otherwise."""
    if not isinstance(changes, Mapping):
        raise ValueError(f"task config changes must be a mapping, got {changes!r}")
    unknown = [k for k in changes if k not in SCHEDULABLE_FIELDS]
    if unknown:
        raise ValueError(
            f"TaskConfig field(s) {unknown} cannot change in a running environment; "
            f"schedulable: {', '.join(SCHEDULABLE_FIELDS)}"
        )
    return replace(cfg, **changes)


#: Upper bound of ``TaskConfig.path_points``: 1000 poses put checks well under a millimetre
#: apart on any path across the workspace, and keep a candidate batch's check small in memory.
MAX_PATH_POINTS = 1000

#: Search-box poses whose volume a default batch of :func:`sample_poses` covers.
DEFAULT_BATCH = 4096
#: Poses a refill of :class:`PoseSampler` aims for by default: the candidates of one try of
#: :func:`sample_pair`.  A working mode whose default batch yields fewer draws a multiple of it.
MIN_YIELD = 8


@dataclass(frozen=True)
class TaskConfig:
    """Parameters of the reaching task.

    Attributes:
        position_tolerance: success when ``G`` is within this distance of the target (m).
        orientation_tolerance: ... and the angle within this of the target angle (rad).
        rest_speed: ... and every slider slower than this (m/s): "nearly at rest".
        min_parallel_margin: sampled poses have at least this parallel margin.
        min_serial_margin: sampled poses have at least this serial margin.
        max_holding_force: sampled poses need at most this fraction of ``design.max_force`` to
            be held at rest against gravity (:func:`planar3p_gym.machine.statics.holding_forces`).
        travel_margin: sampled poses keep this fraction of the stroke free at both ends.
        min_distance: start and target differ by at least this pose distance
            ``|dp| + L_ref |dtheta|`` (m).
        clear_path: require the straight start-target path to stay clear of singularities.
        path_parallel_margin: parallel margin required along that path.
        path_serial_margin: serial margin required along that path.
        path_points: number of poses at which the path is checked (2 to 1000).
        near_singular_fraction: share of the drawn pairs (neither end given) whose straight
            path instead comes within ``near_singular_margin`` of a parallel singularity, or
            crosses one and comes back, while staying reachable with ``path_serial_margin``:
            the kind of pair of the benchmark's ``hard`` suite, for training near
            singularities.  0 (the default) draws no extra random number.
        near_singular_margin: parallel margin such a path comes within.
        detour_fraction: share of the drawn pairs (neither end given, not near-singular)
            that otherwise meet every rule above but which the straight line in slider space
            (every slider at a constant rate) does not solve: it carries the gripper to the
            target's mirror image about the rail line or loses the branch
            (:mod:`planar3p_gym.machine.slider_line`).  These need a detour in slider space, the
            pairs on which PPO from scratch fails the benchmark's ``standard`` suite; for
            training on them more often.  0 (the default) draws no extra random number.  Some
            working modes have no such pairs (:func:`has_detours`; ``(1, 1, 1)`` on the
            paper's design): an environment whose every mode lacks them refuses a positive
            share (:func:`check_detours`); under random working modes those modes draw an
            ordinary pair.
    """

    position_tolerance: float = 0.002
    orientation_tolerance: float = math.radians(1.0)
    rest_speed: float = 0.01
    min_parallel_margin: float = 0.04
    min_serial_margin: float = 0.2
    max_holding_force: float = 0.75
    travel_margin: float = 0.03
    min_distance: float = 0.03
    clear_path: bool = True
    path_parallel_margin: float = 0.02
    path_serial_margin: float = 0.1
    path_points: int = 24
    near_singular_fraction: float = 0.0
    near_singular_margin: float = 0.01
    detour_fraction: float = 0.0

    @property
    def success_tolerances(self) -> tuple[float, float, float]:
        """``(position_tolerance, orientation_tolerance, rest_speed)``: m, rad, m/s."""
        return (self.position_tolerance, self.orientation_tolerance, self.rest_speed)

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if name == "clear_path":
                if not isinstance(value, (bool, np.bool_)):
                    raise ValueError(f"TaskConfig.clear_path must be a bool, got {value!r}")
                object.__setattr__(self, name, bool(value))
                continue
            if name == "path_points":
                count = as_int(value)
                if count is None or not 2 <= count <= MAX_PATH_POINTS:
                    raise ValueError(
                        f"TaskConfig.path_points must be an integer in [2, {MAX_PATH_POINTS}], "
                        f"got {value!r}"
                    )
                object.__setattr__(self, name, count)
                continue
            number = as_finite_float(value)
            if number is None or number < 0:
                raise ValueError(f"TaskConfig.{name} must be a finite number >= 0, got {value!r}")
            object.__setattr__(self, name, number)  # plain floats (NumPy scalars accepted)
        for name in ("position_tolerance", "orientation_tolerance", "rest_speed"):
            if getattr(self, name) <= 0:
                raise ValueError(f"TaskConfig.{name} must be > 0, got {getattr(self, name)!r}")
        for name in (
            "min_parallel_margin",
            "min_serial_margin",
            "path_parallel_margin",
            "path_serial_margin",
            "near_singular_margin",
        ):
            if getattr(self, name) >= 1:
                raise ValueError(f"TaskConfig.{name} must be < 1, got {getattr(self, name)!r}")
        if not 0 < self.max_holding_force <= 1:
            raise ValueError(
                f"TaskConfig.max_holding_force must be in (0, 1], got {self.max_holding_force!r}"
            )
        for name in ("near_singular_fraction", "detour_fraction"):
            if getattr(self, name) > 1:
                raise ValueError(
                    f"TaskConfig.{name} must be in [0, 1], got {getattr(self, name)!r}"
                )
        if self.travel_margin >= 0.5:
            raise ValueError(f"TaskConfig.travel_margin must be < 0.5, got {self.travel_margin!r}")


def _acceptable(
    design: Design, poses: np.ndarray, mode: np.ndarray, cfg: TaskConfig
) -> tuple[np.ndarray, np.ndarray]:
    """Mask of acceptable poses ``(N,)`` and their assembly modes (0 where not acceptable)."""
    ok, rho, asm = kinematics.screen_poses(
        design,
        poses,
        mode,
        travel=design.travel_band(cfg.travel_margin),
        min_parallel=cfg.min_parallel_margin,
        min_serial=cfg.min_serial_margin,
    )
    det = asm.astype(np.float64)
    if ok.any():
        forces = holding_forces_of_rows(design, poses[ok], rho[ok])
        ok[ok] = np.abs(forces).max(axis=-1) <= cfg.max_holding_force * design.max_force
    return ok, det


def sample_poses(
    design: Design,
    mode: ArrayLike,
    rng: np.random.Generator,
    cfg: TaskConfig,
    batch: int = DEFAULT_BATCH,
    max_batches: int = 200,
) -> tuple[np.ndarray, np.ndarray]:
    """Acceptable poses drawn by rejection: ``(poses (M, 3), assembly (M,))``, ``M >= 1``.

    A batch is uniform over the region of :func:`.pose_proposal.pose_proposal` (every pose of
    the search box reachable in ``mode`` with the task's travel margin) and covers the volume
    of ``batch`` uniform poses of the search box: as many acceptable poses are expected as from
    ``batch`` poses of the box, from about ten times fewer draws.  Raises ``ValueError`` if the
    working mode has no acceptable pose after ``max_batches`` batches (a budget: every sampler
    loop of the package is bounded).
    """
    modes = tuple(int(m) for m in np.asarray(mode).tolist())
    lo, hi = design.travel_band(cfg.travel_margin)
    proposal = pose_proposal(design, modes, lo, hi)  # type: ignore[arg-type]
    draws = math.ceil(batch * proposal.fraction)
    mode = np.asarray(mode, dtype=np.float64)
    for _ in range(max_batches if draws else 0):
        poses = propose(proposal, rng.random((draws, 3)))
        ok, det = _acceptable(design, poses, mode, cfg)
        if ok.any():
            return poses[ok], det[ok]
    raise ValueError(
        f"no pose of working mode {tuple(int(m) for m in mode)} meets the task's margins "
        f"(parallel >= {cfg.min_parallel_margin}, serial >= {cfg.min_serial_margin}, holding "
        f"force <= {cfg.max_holding_force} max_force) on this design"
    )


def interpolate(start: np.ndarray, target: np.ndarray, n: int) -> np.ndarray:
    """``n`` poses on the straight path from ``start`` to ``target`` (shortest rotation);
    shapes ``(..., 3)`` -> ``(..., n, 3)``."""
    t = _steps(operator.index(n))
    delta = np.subtract(target, start, dtype=np.float64)
    delta[..., 2] = wrap_angle(delta[..., 2])
    return start[..., None, :] + t * delta[..., None, :]


@lru_cache(maxsize=16)
def _steps(n: int) -> np.ndarray:
    """``linspace(0, 1, n)`` as a read-only column (n, 1)."""
    t = np.linspace(0.0, 1.0, n)[:, None]
    t.setflags(write=False)
    return t


def path_is_clear(
    design: Design,
    start: np.ndarray,
    targets: np.ndarray,
    mode: ArrayLike,
    assembly: float,
    cfg: TaskConfig,
) -> np.ndarray:
    """Mask ``(N,)``: the straight path from ``start`` to each target stays reachable within
    the stroke, with the path margins, in the assembly mode ``assembly``."""
    return kinematics.screen_paths(
        design,
        interpolate(start[None, :], targets, cfg.path_points),  # (N, P, 3)
        np.asarray(mode, dtype=np.float64),
        min_parallel=cfg.path_parallel_margin,
        min_serial=cfg.path_serial_margin,
        assembly=assembly,
    )


class PoseSampler:
    """Acceptable poses of one working mode, drawn by rejection in batches and handed out in
    order (a batch yields tens of poses, so most resets need no new batch).

    Every random number comes from the generator passed to :meth:`draw`; :meth:`clear` drops
    the pool (the environment does so when it is re-seeded, so a seed fixes the episode).

    The pool is kept per assembly mode, each pose with its place in the order drawn, so that
    :meth:`draw` (the next pose of either assembly mode) and :meth:`draw_many` (the next poses
    of one) take constant time however many poses of the other assembly mode have piled up.
    """

    def __init__(self, design: Design, mode: ArrayLike, cfg: TaskConfig) -> None:
        self.design = design
        self.mode = tuple(int(m) for m in np.asarray(mode).tolist())
        self.cfg = cfg
        self._pools: dict[float, deque[tuple[int, np.ndarray]]] = {1.0: deque(), -1.0: deque()}
        self._count = 0  # poses pooled so far: the order of the next one
        self._batches: dict[int, int] = {}  # refill_batch by need

    def __deepcopy__(self, memo: dict[int, Any]) -> PoseSampler:
        """A copy with its own pools of the same pose arrays (read-only, so no copy sees a
        change of another) and the same design and task config (frozen): a snapshot or a
        reset's undo record costs a pass over the pooled poses, not a copy of each."""
        out = type(self).__new__(type(self))
        memo[id(self)] = out
        vars(out).update(vars(self))
        out._pools = {det: deque(pool) for det, pool in self._pools.items()}
        out._batches = dict(self._batches)
        return out

    def __setstate__(self, state: dict[str, Any]) -> None:
        """Unpickling: the pooled poses read-only again (pickle gives writable arrays)."""
        vars(self).update(state)
        for pool in self._pools.values():
            for _, pose in pool:
                pose.flags.writeable = False

    def clear(self) -> None:
        """Forget the pooled poses."""
        for pool in self._pools.values():
            pool.clear()

    def size(self) -> int:
        """The number of pooled poses."""
        return sum(len(pool) for pool in self._pools.values())

    def pooled(self) -> list[tuple[np.ndarray, float]]:
        """The pooled poses and their assembly modes, in the order they are handed out."""
        items = [(k, pose, det) for det, pool in self._pools.items() for k, pose in pool]
        return [(pose, det) for _, pose, det in sorted(items, key=lambda item: item[0])]

    def push_front(self, pose: np.ndarray, det: float) -> None:
        """Put an acceptable pose of assembly mode ``det`` first in line."""
        first = min((pool[0][0] for pool in self._pools.values() if pool), default=self._count)
        pose = np.array(pose, dtype=np.float64)  # (the pool's own, read-only: __deepcopy__)
        pose.flags.writeable = False
        self._pools[float(det)].appendleft((first - 1, pose))

    def _refill(self, rng: np.random.Generator, need: int = MIN_YIELD) -> None:
        # A larger batch draws from the same uniform proposal and keeps the acceptable poses:
        # the pool stays an i.i.d. sequence of uniform acceptable poses, in fewer, larger calls.
        batch = self._batches.get(need)
        if batch is None:  # (the yield depends on fields a running environment keeps)
            batch = self._batches[need] = refill_batch(self.design, self.mode, self.cfg, need)
        try:
            poses, dets = sample_poses(self.design, self.mode, rng, self.cfg, batch=batch)
        except ValueError:
            # Rare in a mode whose acceptable poses are sparse: if the mode has poses at all
            # (check_mode raises if not), keep drawing from the same stream (a bounded number
            # of batches: ValueError if even those find none).
            check_mode(self.design, self.mode, self.cfg)
            batches = max(1, REFILL_BATCHES * DEFAULT_BATCH // batch)  # (the same volume)
            poses, dets = sample_poses(
                self.design, self.mode, rng, self.cfg, batch=batch, max_batches=batches
            )
        poses.flags.writeable = False  # (shared by copies of the sampler: __deepcopy__)
        for pose, det in zip(poses, dets.tolist(), strict=True):
            self._pools[det].append((self._count, pose))
            self._count += 1

    def draw(self, rng: np.random.Generator, need: int = MIN_YIELD) -> tuple[np.ndarray, float]:
        """The next pose and its assembly mode (a refill aims for ``need`` poses)."""
        up, down = self._pools[1.0], self._pools[-1.0]
        if not (up or down):
            self._refill(rng, need)
        if up and (not down or up[0][0] < down[0][0]):
            return up.popleft()[1], 1.0
        return down.popleft()[1], -1.0

    def draw_many(
        self, rng: np.random.Generator, assembly: float, n: int, need: int = MIN_YIELD
    ) -> np.ndarray:
        """Up to ``n`` next poses of assembly mode ``assembly``, shape (m, 3); ``m == 0`` when
        none turned up in :data:`DRAW_MANY_REFILLS` refills (the assembly mode is rare or empty
        in this working mode: the caller draws another start).  A refill draws batches enough
        for about ``need`` poses (:func:`refill_batch`)."""
        pool = self._pools.get(assembly)
        if pool is None:  # not an assembly mode (+-1): no pose has it
            return np.empty((0, 3))
        for _ in range(DRAW_MANY_REFILLS):
            if pool:
                return np.array([pool.popleft()[1] for _ in range(min(n, len(pool)))])
            self._refill(rng, need)
        return np.empty((0, 3))


#: The largest multiple of the default batch a refill draws (a bound on its memory).
MAX_BATCH_FACTOR = 32
#: Batches of :func:`sample_poses` (fixed seed) over which :func:`pose_yield` averages.
YIELD_BATCHES = 32


def pose_yield(design: Design, mode: ArrayLike, cfg: TaskConfig) -> float:
    """The mean number of acceptable poses in a default batch of :func:`sample_poses` in working
    ``mode``, over :data:`YIELD_BATCHES` batches drawn with a fixed internal seed (the
    episode's random stream is not touched; cached)."""
    key = replace(cfg, **{f: getattr(_DEFAULT_CONFIG, f) for f in SCHEDULABLE_FIELDS})
    return _pose_yield(design, tuple(int(m) for m in np.asarray(mode).tolist()), key)


@lru_cache(maxsize=256)
def _pose_yield(design: Design, mode: tuple[int, int, int], cfg: TaskConfig) -> float:
    found = sum(len(poses) for poses, _ in _fixed_seed_batches(design, mode, cfg, YIELD_BATCHES))
    return found / YIELD_BATCHES


def _fixed_seed_batches(
    design: Design, mode: ArrayLike, cfg: TaskConfig, batches: int
) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """``(poses, assembly)`` of each of ``batches`` batches of :func:`sample_poses` (one batch
    each) drawn with the fixed internal seed 0, the batches that found no pose left out: the
    searches of :func:`pose_yield`, :func:`check_mode` and :func:`assembly_modes` (the episode's
    random stream is not touched)."""
    rng = np.random.default_rng(0)
    for _ in range(batches):
        try:
            found = sample_poses(design, mode, rng, cfg, max_batches=1)
        except ValueError:
            continue
        yield found


def refill_batch(design: Design, mode: ArrayLike, cfg: TaskConfig, need: int) -> int:
    """The batch (in search-box poses, :func:`sample_poses`) a :class:`PoseSampler` refill
    draws for about ``need`` poses: the default batch times the smallest power of two, up to
    :data:`MAX_BATCH_FACTOR`, whose expected yield (:func:`pose_yield`) reaches ``need``; the
    default batch in a mode whose yield is unknown (0).  In a mode whose default batch yields
    ``MIN_YIELD`` poses or more, a default refill is one default batch."""
    mean = pose_yield(design, mode, cfg)
    factor = 1
    while mean > 0 and mean * factor < need and factor < MAX_BATCH_FACTOR:
        factor *= 2
    return DEFAULT_BATCH * factor


#: Refills :meth:`PoseSampler.draw_many` tries before it gives up (returns no pose).
DRAW_MANY_REFILLS = 50
#: Batches (:func:`sample_poses`) a refill draws after the first 200 found none, in a working
#: mode that :func:`check_mode` accepts, before it raises ``ValueError`` (a budget: the volume
#: of about 8 million search-box poses; the check found at least two acceptable poses in the
#: volume of 1.6 million, so some ten are expected here, and the budget runs out with a
#: probability below 1e-4 of a refill that already came up empty, itself rare).
REFILL_BATCHES = 2000


#: The kinds of pair :func:`draw_pair` reports: drawn by the ordinary rules, near-singular
#: (``near_singular_fraction``), needing a detour (``detour_fraction``), an ordinary pair drawn
#: because the search for the requested kind ran out of its budget, or given by the caller.
PAIR_KINDS = (
    "ordinary",
    "near_singular",
    "detour",
    "near_singular_not_found",
    "detour_not_found",
    "given",
)


def sample_pair(
    design: Design,
    mode: ArrayLike,
    rng: np.random.Generator,
    cfg: TaskConfig,
    start: np.ndarray | None = None,
    target: np.ndarray | None = None,
    sampler: PoseSampler | None = None,
    max_tries: int = 100,
    assembly: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The ``(start, target)`` of :func:`draw_pair` (same arguments), without its kind."""
    s, t, _ = draw_pair(design, mode, rng, cfg, start, target, sampler, max_tries, assembly)
    return s, t


def draw_pair(
    design: Design,
    mode: ArrayLike,
    rng: np.random.Generator,
    cfg: TaskConfig,
    start: np.ndarray | None = None,
    target: np.ndarray | None = None,
    sampler: PoseSampler | None = None,
    max_tries: int = 100,
    assembly: float | None = None,
) -> tuple[np.ndarray, np.ndarray, str]:
    """A ``(start, target, kind)`` for the task; either pose may be given (already validated),
    a given start with its assembly mode (``sign det A``, computed if ``None``); ``kind`` is one
    of :data:`PAIR_KINDS` ("given" with both poses given).

    The target has the start's assembly mode, is at least ``min_distance`` away and, with
    ``clear_path``, is joined to the start by a straight path clear of singularities.

    With neither given, draws until a pair is found (after ``max_tries`` failed starts it
    checks, once, that the working mode has pairs at all: :func:`check_mode`), at most
    ``PAIR_TRIES_FACTOR * max_tries`` starts (a budget; then ``ValueError``); a given start or
    target that cannot be paired in ``max_tries`` tries raises ``ValueError``.  A requested
    near-singular or detour pair whose search runs out of its budget is replaced by an ordinary
    pair, reported as such (``kind`` ``"near_singular_not_found"`` / ``"detour_not_found"``).
    """
    if start is not None and target is not None:
        return start, target, "given"
    if assembly is not None and (start is None or assembly not in (1.0, -1.0)):
        raise ValueError(
            f"assembly must be +1 or -1 and comes with a given start, got {assembly!r}"
        )
    sampler = sampler if sampler is not None else PoseSampler(design, mode, cfg)
    free = start is None and target is None
    kind = "ordinary"
    if free and cfg.near_singular_fraction > 0 and rng.random() < cfg.near_singular_fraction:
        pair = _near_singular_pair(design, mode, rng, cfg, sampler)
        if pair is not None:
            return (*pair, "near_singular")
        kind = "near_singular_not_found"
    elif free and cfg.detour_fraction > 0 and rng.random() < cfg.detour_fraction:
        # (A mode without such pairs draws an ordinary pair at once, not after the budget.)
        pair = (
            _detour_pair(design, mode, rng, cfg, sampler)
            if has_detours(design, mode, cfg)
            else None
        )
        if pair is not None:
            return (*pair, "detour")
        kind = "detour_not_found"
    for attempt in range(max_tries * PAIR_TRIES_FACTOR if free else max_tries):
        if attempt == max_tries:
            check_mode(design, tuple(int(m) for m in np.asarray(mode).tolist()), cfg)
        if start is None:
            s, det = sampler.draw(rng)
        elif assembly is not None:
            s, det = start, float(assembly)
        else:
            s = start
            rho = kinematics.inverse(design, s, mode).rho
            det = float(kinematics.assembly_mode(design, s, rho))
        if target is not None:
            if _first_ok(design, s, target[None, :], mode, det, cfg) == 0:
                return s, target, kind
            if start is not None:
                break
            continue
        cands = sampler.draw_many(rng, det, 8)
        first = _first_ok(design, s, cands, mode, det, cfg) if len(cands) else None
        if first is not None:
            return s, cands[first], kind
        if start is None:
            continue
    raise ValueError(
        "could not pair a start with a target under the task's constraints "
        "(same assembly mode, minimum distance, clear path); relax TaskConfig or give both"
    )


#: Starts :func:`sample_pair` draws for a free pair, in units of ``max_tries``, before it gives
#: up (a budget: a working mode that passes :func:`check_mode` has pairs far more often).
PAIR_TRIES_FACTOR = 20


#: Candidate targets screened per start by :func:`_near_singular_pair`, and starts tried.
NEAR_SINGULAR_CANDIDATES = 32
NEAR_SINGULAR_STARTS = 200


def _near_singular_pair(
    design: Design, mode: ArrayLike, rng: np.random.Generator, cfg: TaskConfig, sampler: PoseSampler
) -> tuple[np.ndarray, np.ndarray] | None:
    """A pair of the same assembly mode, ``min_distance`` apart, whose straight path stays
    reachable within the stroke with ``path_serial_margin`` but comes within
    ``near_singular_margin`` of a parallel singularity (or crosses one): by rejection over
    :data:`NEAR_SINGULAR_CANDIDATES` targets per start; ``None`` after
    :data:`NEAR_SINGULAR_STARTS` starts (a design with no such pairs: the caller draws an
    ordinary pair)."""
    m = np.asarray(mode, dtype=np.float64)

    def near_singular(s: np.ndarray, det: float, cands: np.ndarray) -> np.ndarray:
        # reachable & ~clear, in one screen for the common path (reachable and clear): the
        # screen of both tests passes exactly those, and only the paths it fails need the
        # reachability screen alone (reachable & ~(reachable & clear) == reachable & ~clear).
        paths = interpolate(s[None, :], cands, cfg.path_points)
        both = kinematics.screen_paths(
            design,
            paths,
            m,
            min_parallel=cfg.near_singular_margin,
            min_serial=cfg.path_serial_margin,
            assembly=det,
        )
        hits = ~both
        if hits.any():
            hits[hits] = kinematics.screen_paths(
                design, paths[hits], m, min_serial=cfg.path_serial_margin
            )
        return hits

    return _pair_by_rejection(
        design, rng, cfg, sampler, near_singular, NEAR_SINGULAR_CANDIDATES, NEAR_SINGULAR_STARTS
    )


#: Candidate targets screened per start by :func:`_detour_pair`, and the starts the fixed-seed
#: search of :func:`has_detours` tries.
DETOUR_CANDIDATES = 32
DETOUR_STARTS = 200
#: Starts one reset's detour search tries: a budget on the reset's time (each start follows the
#: slider line of its clear candidates by direct kinematics); a search that runs out draws an
#: ordinary pair, reported as ``"detour_not_found"`` (the share: docs/throughput.md).
DETOUR_RESET_STARTS = 12


def _detour_pair(
    design: Design,
    mode: ArrayLike,
    rng: np.random.Generator,
    cfg: TaskConfig,
    sampler: PoseSampler,
    starts: int | None = None,
) -> tuple[np.ndarray, np.ndarray] | None:
    """A pair meeting every rule of an ordinary pair that the straight line in slider space
    does not solve (:func:`planar3p_gym.machine.slider_line.slider_line_reaches`): by rejection over
    :data:`DETOUR_CANDIDATES` targets per start; ``None`` after ``starts`` starts
    (:data:`DETOUR_RESET_STARTS` by default: the caller draws an ordinary pair)."""

    def detour(s: np.ndarray, det: float, cands: np.ndarray) -> np.ndarray:
        ok = (
            path_is_clear(design, s, cands, mode, det, cfg)
            if cfg.clear_path
            else np.ones(len(cands), dtype=bool)
        )
        if ok.any():
            ok[ok] = ~slider_line_reaches(design, s, cands[ok], mode)
        return ok

    budget = DETOUR_RESET_STARTS if starts is None else starts
    return _pair_by_rejection(design, rng, cfg, sampler, detour, DETOUR_CANDIDATES, budget)


def has_detours(design: Design, mode: ArrayLike, cfg: TaskConfig) -> bool:
    """Whether working ``mode`` of ``design`` has pairs :func:`_detour_pair` finds: one found
    within its budget with a fixed internal seed (the episode's random stream is not touched;
    cached).  A mode without detours is one where every reset would spend that budget (about
    a second) for nothing."""
    # The schedulable fields (tolerances, shares of pairs) do not change the answer: one entry
    # of the cache serves a curriculum over them.
    key = replace(cfg, **{f: getattr(_DEFAULT_CONFIG, f) for f in SCHEDULABLE_FIELDS})
    return _has_detours(design, tuple(int(m) for m in np.asarray(mode).tolist()), key)


_DEFAULT_CONFIG = TaskConfig()


@lru_cache(maxsize=256)
def _has_detours(design: Design, mode: tuple[int, int, int], cfg: TaskConfig) -> bool:
    sampler = PoseSampler(design, mode, cfg)
    rng = np.random.default_rng(0)
    return _detour_pair(design, mode, rng, cfg, sampler, DETOUR_STARTS) is not None


def check_detours(design: Design, modes: list[tuple[int, int, int]], cfg: TaskConfig) -> None:
    """``ValueError`` naming ``detour_fraction`` if it is positive and none of the working
    ``modes`` an environment draws from has detour pairs (:func:`has_detours`); with some that
    have them, the others draw ordinary pairs."""
    if cfg.detour_fraction == 0 or any(has_detours(design, m, cfg) for m in modes):
        return
    raise ValueError(
        f"task_config.detour_fraction ({cfg.detour_fraction:g}) asks for pairs the straight "
        f"slider line does not solve, but working mode(s) {', '.join(map(str, modes))} have "
        f"none (none in {DETOUR_STARTS} starts of a fixed-seed search); set detour_fraction "
        "to 0 or choose a working mode with such pairs"
    )


#: The candidates of this many starts a refill of :func:`_pair_by_rejection` aims for: its
#: searches go through many starts, and fewer, larger batches cost less per pose.
SEARCH_STOCK = 8


def _pair_by_rejection(
    design: Design,
    rng: np.random.Generator,
    cfg: TaskConfig,
    sampler: PoseSampler,
    accept: Callable[[np.ndarray, float, np.ndarray], np.ndarray],
    candidates: int,
    starts: int,
) -> tuple[np.ndarray, np.ndarray] | None:
    """The first pair ``(start, target)`` that ``accept(start, assembly, targets)`` marks
    among ``candidates`` targets of the start's assembly mode at least ``min_distance`` away,
    trying up to ``starts`` starts; ``None`` if none."""
    for _ in range(starts):
        s, det = sampler.draw(rng, need=SEARCH_STOCK * candidates)
        cands = sampler.draw_many(rng, det, candidates, need=SEARCH_STOCK * candidates)
        if not len(cands):
            continue
        cands = cands[
            pose_distance(s[None, :], cands, design.characteristic_length) >= cfg.min_distance
        ]
        if not len(cands):
            continue
        hits = np.flatnonzero(accept(s, det, cands))
        if hits.size:
            return s, cands[int(hits[0])]
    return None


def _first_ok(
    design: Design,
    start: np.ndarray,
    targets: np.ndarray,
    mode: ArrayLike,
    assembly: float,
    cfg: TaskConfig,
) -> int | None:
    """Index of the first of ``targets`` (N, 3) that may be paired with ``start``, or None.

    The paths are checked lazily: the first far-enough target alone (it usually passes), then
    the others together.
    """
    far = pose_distance(start[None, :], targets, design.characteristic_length) >= cfg.min_distance
    idx = np.flatnonzero(far)
    if not cfg.clear_path or not idx.size:
        return int(idx[0]) if idx.size else None
    for chunk in (idx[:1], idx[1:]):
        if chunk.size:
            clear = path_is_clear(design, start, targets[chunk], mode, assembly, cfg)
            if clear.any():
                return int(chunk[int(np.argmax(clear))])
    return None


#: Budget of :func:`check_mode`: batches of :func:`sample_poses` searched (fixed seed).
CHECK_BATCHES = 400


def check_mode(design: Design, mode: ArrayLike, cfg: TaskConfig) -> None:
    """Raise ``ValueError`` unless working mode ``mode`` of ``design`` has a start/target pair
    meeting ``cfg``, found among ``CHECK_BATCHES`` batches of :func:`sample_poses` drawn with a
    fixed internal seed (the episode's random stream is not touched).  The result is cached.

    A mode that passes has pairs with positive probability, so :func:`sample_pair` without a
    given start or target always ends; one that fails has, at best, a vanishing share.
    """
    reason = _mode_problem(design, tuple(int(m) for m in np.asarray(mode).tolist()), cfg)
    if reason is not None:
        raise ValueError(reason)


def has_pairs(design: Design, mode: ArrayLike, cfg: TaskConfig) -> bool:
    """Whether :func:`check_mode` accepts ``mode``."""
    return _mode_problem(design, tuple(int(m) for m in np.asarray(mode).tolist()), cfg) is None


@lru_cache(maxsize=256)
def _mode_problem(design: Design, mode: tuple[int, int, int], cfg: TaskConfig) -> str | None:
    """Why ``mode`` has no usable pair (see :func:`check_mode`), or ``None``."""
    m = np.asarray(mode, dtype=np.float64)
    pools: dict[float, list[np.ndarray]] = {1.0: [], -1.0: []}
    found = 0
    for poses, dets in _fixed_seed_batches(design, m, cfg, CHECK_BATCHES):
        found += len(poses)
        for pose, det in zip(poses, dets.tolist(), strict=True):
            others = pools[det]
            if others and _first_ok(design, pose, np.array(others[-64:]), m, det, cfg) is not None:
                return None
            others.append(pose)
    what = "pose" if not found else "start/target pair (same assembly mode, min_distance apart"
    what += "" if not found else (", clear path)" if cfg.clear_path else ")")
    return (
        f"working mode {mode} of this design has no {what} meeting the task's margins "
        f"(parallel >= {cfg.min_parallel_margin}, serial >= {cfg.min_serial_margin}, holding "
        f"force <= {cfg.max_holding_force} max_force, travel margin {cfg.travel_margin}) in "
        f"{CHECK_BATCHES} sampling batches (as many poses as {CHECK_BATCHES * 4096} uniform "
        f"samples of the search box; {found} acceptable); choose another working mode or relax "
        "the TaskConfig"
    )


#: Batches of :func:`sample_poses` (fixed seed) in which :func:`assembly_modes` looks for the
#: assembly modes of a working mode's acceptable poses.
ASSEMBLY_BATCHES = 32


def assembly_modes(design: Design, mode: ArrayLike, cfg: TaskConfig) -> frozenset[float]:
    """The assembly modes (``sign det A``, +-1.0) among the acceptable poses of working
    ``mode`` found in :data:`ASSEMBLY_BATCHES` batches of uniform poses (fixed internal seed,
    cached).  A pose of another assembly mode has no partner there in practice (one would take
    hundreds of batches to turn up): samplers draw another pose rather than search for one.
    (On the default design, working mode ``(+1, +1, -1)`` has no pose of assembly mode -1 in
    these batches.)"""
    return _assembly_modes(design, tuple(int(m) for m in np.asarray(mode).tolist()), cfg)


@lru_cache(maxsize=256)
def _assembly_modes(
    design: Design, mode: tuple[int, int, int], cfg: TaskConfig
) -> frozenset[float]:
    found: set[float] = set()
    for _, asm in _fixed_seed_batches(design, mode, cfg, ASSEMBLY_BATCHES):
        found |= set(asm.tolist())
        if len(found) == 2:
            break
    return frozenset(found)


def check_pose(design: Design, pose: ArrayLike, mode: ArrayLike, name: str) -> np.ndarray:
    """Validate a user-given pose: 3 finite numbers, reachable in ``mode`` within the stroke and
    not at a parallel singularity.  Returns it as a float array, or raises ``ValueError``."""
    p = checks.numbers(pose, 3, name, " (x, y, theta)")
    rho, reachable = kinematics.inverse(design, p, mode)
    if not bool(reachable):
        raise ValueError(
            f"{name} {tuple(p.tolist())} is not reachable in working mode "
            f"{tuple(int(m) for m in np.asarray(mode))} within the stroke [0, {design.stroke}] m "
            f"(travels {np.round(rho, 6).tolist()} m)"
        )
    if float(kinematics.parallel_margin(design, p, rho)) < 1e-6:
        raise ValueError(f"{name} {tuple(p.tolist())} is at a parallel singularity")
    return p
