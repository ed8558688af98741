"""Working-mode change: the task of ``Planar3PModeChange-v0`` (reach a target pose in another
working mode; the id's page is :class:`planar3p_gym.envs.mode_change.Planar3PModeChangeEnv`).

Start and target differ in the working mode of ``flips`` legs, which must pass a serial
singularity on the way; a pair is kept only with a feasibility certificate
(:func:`planar3p_gym.tasks.joint_paths.find_joint_path`).  How the sampler certifies a pair and
which working-mode pairs exist on the default design: docs/environments.md, "How the task
modules work".

* :class:`ModeChangeTask`: the task (sampling, success in the target mode, the reward without
  the serial barrier, the optional travel term);
* :func:`leg_modes`, :func:`single_flip_modes`: working modes of a configuration and the modes
  one or more flips away.
"""

from __future__ import annotations

import math
from dataclasses import asdict
from functools import lru_cache
from typing import Any, ClassVar

import numpy as np
from numba import njit

from planar3p_gym import checks
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design
from planar3p_gym.machine.scalar_kinematics import ConfigurationMeasures
from planar3p_gym.sim.physics import SimState
from planar3p_gym.tasks import sampling as task
from planar3p_gym.tasks.base import ModeTriple, Pose, Task, pose_list
from planar3p_gym.tasks.joint_paths import (
    JointPath,
    PathLimits,
    find_joint_path,
    first_straight_path,
)
from planar3p_gym.tasks.reach_step import TERMS_START
from planar3p_gym.tasks.rewards import weighted_terms
from planar3p_gym.tasks.travel_shaping import TravelShaping, check_travel_shaping

__all__ = ["ModeChangeTask", "leg_modes", "leg_sign", "mode_change_rows", "single_flip_modes"]


@njit(cache=True)
def leg_sign(alpha: float) -> int:
    """The working mode of a leg at angle ``alpha`` (rad): ``sign cos alpha`` (+1 when ``cos
    alpha >= 0``)."""
    return 1 if math.cos(alpha) >= 0.0 else -1


def leg_modes(leg_angles: tuple[float, float, float]) -> ModeTriple:
    """``sign cos alpha_i`` of each leg (:func:`leg_sign`)."""
    a1, a2, a3 = leg_angles
    return leg_sign(a1), leg_sign(a2), leg_sign(a3)


@njit(cache=True)
def mode_change_rows(
    rows: np.ndarray, states: np.ndarray, actions: np.ndarray, res: np.ndarray,
    target_modes: np.ndarray, w: np.ndarray, length: float, parallel_barrier: bool,
    serial_barrier: bool,
) -> None:  # fmt: skip
    """The mode-change task's part of a batched step, after the reach outputs ``res``
    (``(len(RESULT_FIELDS), n)``) of the environments ``rows`` (int64 ``(n,)``, of a batch of
    ``N``): for each stepped row ``j`` (environment ``i = rows[j]``, its state ``states[:, j]``,
    the leg angles at 12-14), success is the reach test's and every :func:`leg_sign` equal
    to the target's working mode ``target_modes[i]`` (``(N, 3)``); the reason and the reward
    terms (:func:`~planar3p_gym.tasks.rewards.weighted_terms` with the task's barriers, the
    failure penalty on a crossing) and their sum are written back into ``res``, as
    :meth:`ModeChangeTask.termination` and :meth:`ModeChangeTask.reward_terms` give them.
    ``actions`` ``(N, 3)``: the clipped actions; ``w``: the reward weights; ``length``: the
    characteristic length (m)."""
    for j in range(rows.shape[0]):
        i = rows[j]
        crossing = res[1, j] == 2
        success = res[1, j] == 1
        for d in range(3):
            if leg_sign(states[12 + d, j]) != target_modes[i, d]:
                success = False
        terms = weighted_terms(
            w, res[2, j], res[3, j], length, res[4, j] if parallel_barrier else 1.0,
            res[5, j] if serial_barrier else 1.0, actions[i, 0], actions[i, 1], actions[i, 2],
            success, crossing,
        )  # fmt: skip
        total = 0.0
        for t in range(len(terms)):
            total += terms[t]
            res[TERMS_START + t, j] = terms[t]
        res[0, j] = total
        res[1, j] = 2.0 if crossing else (1.0 if success else 0.0)


def single_flip_modes(mode: ModeTriple, flips: int = 1) -> list[ModeTriple]:
    """The working modes that differ from ``mode`` in exactly ``flips`` legs (1 to 3)."""
    out = []
    for m in kinematics.ALL_MODES.tolist():
        if sum(a != b for a, b in zip(m, mode, strict=True)) == flips:
            out.append(tuple(int(v) for v in m))
    return out  # type: ignore[return-value]


class ModeChangeTask(TravelShaping, Task):
    """Reach a target pose in another working mode (see the module docstring).

    Args:
        flips: number of legs whose working mode differs between start and target (1 to 3).
        limits: :class:`~planar3p_gym.tasks.joint_paths.PathLimits` of the feasibility
            certificate.
        pair_tries: certificate attempts per start pose before another start is drawn.
        travel_shaping: weight ``w >= 0`` of the travel term of the reward (dimensionless, per
            step; 0: no such term).
    """

    name: ClassVar[str] = "mode_change"
    hooks_family: ClassVar[str | None] = "mode_change"
    observation_fields = (
        ("target_rho", 3, "slider travels of the target pose in its working mode (m)"),
        ("target_working_mode", 3, "the target's working mode, sign cos alpha_i (+-1)"),
    )
    option_keys: ClassVar[tuple[str, ...]] = (
        "start",
        "target",
        "working_mode",
        "target_working_mode",
    )
    metric_keys: ClassVar[tuple[str, ...]] = (
        "target_working_mode",
        "in_target_mode",
        "legs_to_flip",
    )
    #: Passing a serial singularity is the task: no serial barrier in the reward.
    serial_barrier: ClassVar[bool] = False
    compiled_measures: ClassVar[bool] = True

    def __init__(
        self,
        flips: int = 1,
        limits: PathLimits | None = None,
        pair_tries: int = 8,
        travel_shaping: float = 0.0,
    ) -> None:
        self.flips = checks.integer(flips, "flips", low=1, high=3)
        self.limits = checks.config_from(limits, PathLimits, "path_limits")
        self.pair_tries = checks.count(pair_tries, "pair_tries")
        self.travel_shaping = check_travel_shaping(travel_shaping)

    # ------------------------------------------------------------------ set-up
    def arguments(self) -> dict[str, Any]:
        return {
            "flips": self.flips,
            "limits": asdict(self.limits),
            "pair_tries": self.pair_tries,
            **self.shaping_arguments(),
        }

    def bind(self, env: Any) -> None:
        super().bind(env)
        self._target: Pose = (0.0, 0.0, 0.0)
        self._target_mode: ModeTriple = (1, 1, 1)
        self._target_rho: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self.pairs = {
            ms: list(mts)
            for ms, mts in _viable_pairs(
                env.design, tuple(env.modes), self.flips, self.limits, env.task_config
            )
        }
        if not self.pairs:
            raise ValueError(
                f"no working-mode pair of this design (start modes {env.modes}, {self.flips} "
                "leg(s) flipped) has a certified start/target pair under the task's margins"
            )
        # The sampler's table of each target mode's assembly modes (cached per design and
        # config, about 30 ms each) is built here, not by the first reset that draws the mode.
        for mt in {mt for mts in self.pairs.values() for mt in mts}:
            task.assembly_modes(env.design, mt, env.task_config)

    def _requested_pair_viable(self, ms: ModeTriple, mt: ModeTriple) -> bool:
        """For a requested pair of working modes the construction-time check did not list:
        whether a certified pair turns up among a few drawn with a fixed internal seed
        (:func:`_pair_viable`, cached), so an infeasible request fails fast instead of after
        many draws."""
        if mt in self.pairs.get(ms, []):
            return True
        return _pair_viable(self.env.design, ms, mt, self.limits, self.env.task_config)

    # ------------------------------------------------------------------ options and sampling
    def check_options(self, options: dict[str, Any]) -> dict[str, Any]:
        for key in ("working_mode", "target_working_mode"):
            if options.get(key) is not None:
                options[key] = checks.mode_from(options[key], key)
        ms, mt = options.get("working_mode"), options.get("target_working_mode")
        if ms is not None and mt is not None and ms == mt:
            raise ValueError(
                f"target_working_mode {mt} equals working_mode {ms}: a mode change needs at "
                "least one leg in another working mode"
            )
        both_poses = options.get("start") is not None and options.get("target") is not None
        if (ms is not None or mt is not None) and not both_poses:
            # bounded, cached, fixed internal seed: modes without a certified pair fail here
            if ms is not None and mt is not None:
                if not self._requested_pair_viable(ms, mt):
                    raise ValueError(self._no_pair_message(ms, mt))
            elif ms is not None and not self._target_choices(ms):
                raise ValueError(
                    f"working_mode {ms} has no certified mode change to a mode with "
                    f"{self.flips} leg(s) flipped (fixed internal seed); this environment "
                    f"samples {self.pairs}"
                )
            elif mt is not None and not self._start_choices(mt):
                raise ValueError(
                    f"target_working_mode {mt} has no certified mode change from any of the "
                    f"working modes {self.env.modes} (fixed internal seed); this environment "
                    f"samples {self.pairs}"
                )
        if ms is None and len(self.pairs) == 1:
            ms = next(iter(self.pairs))
        design = self.env.design
        if ms is not None and options.get("start") is not None:
            options["start"] = task.check_pose(design, options["start"], ms, "start")
        if mt is not None and options.get("target") is not None:
            options["target"] = task.check_pose(design, options["target"], mt, "target")
        return options

    def _target_choices(self, ms: ModeTriple) -> list[ModeTriple]:
        """The target modes drawn for start mode ``ms``: the construction-time list, or for a
        requested start mode not in it, the modes ``flips`` legs away with a certified pair."""
        if ms in self.pairs:
            return self.pairs[ms]
        return [m for m in single_flip_modes(ms, self.flips) if self._requested_pair_viable(ms, m)]

    def _start_choices(self, mt: ModeTriple) -> list[ModeTriple]:
        """The start modes drawn for a requested target mode ``mt`` (as :meth:`_target_choices`)."""
        listed = [m for m in self.pairs if mt in self.pairs[m]]
        if listed:
            return listed
        return [m for m in self.env.modes if m != mt and self._requested_pair_viable(m, mt)]

    def _no_pair_message(self, ms: ModeTriple, mt: ModeTriple) -> str:
        return (
            f"no certified mode change from working mode {ms} to {mt} found among "
            f"{VIABILITY_TRIES} candidate pairs (fixed internal seed); request another pair of "
            f"working modes (this environment samples {self.pairs})"
        )

    def episode_spec(self, rng: np.random.Generator, options: dict[str, Any]) -> dict[str, Any]:
        design = self.env.design
        ms = options.get("working_mode")
        mt = options.get("target_working_mode")
        start, target = options.get("start"), options.get("target")
        if ms is None:
            choices = list(self.pairs) if mt is None else self._start_choices(mt)
            if not choices:
                raise ValueError(f"no start mode has a certified mode change to {mt}")
            ms = choices[int(rng.integers(len(choices)))] if len(choices) > 1 else choices[0]
        if mt is None:
            choices = self._target_choices(ms)
            if not choices:
                raise ValueError(f"working_mode {ms} has no certified mode change")
            mt = choices[int(rng.integers(len(choices)))] if len(choices) > 1 else choices[0]
        if ms == mt:
            raise ValueError(f"target_working_mode {mt} equals working_mode {ms}")
        if start is not None:
            start = task.check_pose(design, start, ms, "start")
        if target is not None:
            target = task.check_pose(design, target, mt, "target")
        if start is not None and target is not None:
            self._require_path(start, ms, target, mt)
        else:
            if not self._requested_pair_viable(ms, mt):
                raise ValueError(self._no_pair_message(ms, mt))
            start, target = self._draw(rng, ms, mt, start, target)
        return {
            "task": self.name,
            "working_mode": [int(m) for m in ms],
            "start": pose_list(start),
            "target": pose_list(target),
            "target_working_mode": [int(m) for m in mt],
        }

    def _require_path(
        self, start: np.ndarray, ms: ModeTriple, target: np.ndarray, mt: ModeTriple
    ) -> JointPath:
        design = self.env.design
        asm = [
            int(kinematics.assembly_mode(design, p, kinematics.inverse(design, p, m).rho))
            for p, m in ((start, ms), (target, mt))
        ]
        if asm[0] != asm[1]:
            raise ValueError(
                f"start and target are in different assembly modes (sign det A {asm[0]} vs "
                f"{asm[1]}): the mode change would also need a parallel-singularity crossing"
            )
        path, reason = find_joint_path(design, start, ms, target, mt, self.limits)
        if path is None:
            raise ValueError(
                f"no certified path from start {tuple(start.tolist())} (mode {ms}) to target "
                f"{tuple(target.tolist())} (mode {mt}): the straight travel path fails "
                f"({reason}) and so does every upright-leg waypoint tried"
            )
        return path

    def _draw(
        self,
        rng: np.random.Generator,
        ms: ModeTriple,
        mt: ModeTriple,
        start: np.ndarray | None,
        target: np.ndarray | None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """A certified pair: starts drawn in ``ms`` (or the given ``start``), for each up to
        ``pair_tries`` targets of its assembly mode drawn in ``mt`` (or the given ``target``),
        the first whose straight travel line is certified (all of a start's candidates in one
        batch, :func:`first_straight_path`).  At most :data:`DRAW_ROUNDS` starts, or
        :data:`GIVEN_ROUNDS` when the start or the target is given, then ``ValueError``."""
        design, cfg = self.env.design, self.env.task_config
        length = design.characteristic_length
        free = start is None and target is None
        for _ in range(DRAW_ROUNDS if free else GIVEN_ROUNDS):
            if start is None:
                s, asm = self.pose_sampler(ms).draw(rng)
            else:
                s = start
                asm = float(
                    kinematics.assembly_mode(design, s, kinematics.inverse(design, s, ms).rho)
                )
            if target is None:
                if asm not in task.assembly_modes(design, mt, cfg):
                    if start is not None:
                        break  # the requested start's assembly mode has no target in mt
                    continue  # (no target to draw for this start: draw another)
                cands = self.pose_sampler(mt).draw_many(rng, asm, self.pair_tries)
            else:
                t_rho = kinematics.inverse(design, target, mt).rho
                t_asm = float(kinematics.assembly_mode(design, target, t_rho))
                cands = target[None, :] if t_asm == asm else np.zeros((0, 3))
            cands = cands[task.pose_distance(s[None, :], cands, length) >= cfg.min_distance]
            if len(cands):
                found = first_straight_path(design, s, ms, cands, mt, self.limits)
                if found is not None:
                    return s, cands[found[0]]
            if start is not None and target is not None:
                break
        if free:
            raise ValueError(
                f"no certified mode change from working mode {ms} to {mt} found after "
                f"{DRAW_ROUNDS} drawn starts; request another pair of working modes"
            )
        fixed = "start" if start is not None else "target"
        raise ValueError(
            f"no certified mode change from working mode {ms} to {mt} found for the requested "
            f"{fixed} in {GIVEN_ROUNDS} draws of the other end; give another {fixed} or leave "
            "it to the sampler"
        )

    def begin(self, spec: dict[str, Any]) -> tuple[np.ndarray, tuple[int, int, int]]:
        tx, ty, tth = spec["target"]
        self._target = (float(tx), float(ty), float(tth))
        self._target_mode = checks.mode_from(spec["target_working_mode"], "target_working_mode")
        rho = kinematics.inverse(self.env.design, self._target, self._target_mode).rho
        self._target_rho = (float(rho[0]), float(rho[1]), float(rho[2]))
        mode = checks.mode_from(spec["working_mode"], "working_mode")
        start = np.asarray(spec["start"], dtype=np.float64)
        self.start_travels(kinematics.inverse(self.env.design, start, mode).rho)
        return start, mode

    # ------------------------------------------------------------------ per step
    def reference(self, step: int) -> Pose:
        return self._target

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.travel_bounds(3)  # target travels, target working mode

    def observation_extra(
        self, step: int, state: SimState, measures: ConfigurationMeasures
    ) -> list[float]:
        return [*self._target_rho, *(float(m) for m in self._target_mode)]

    def is_success(self, state: SimState, errors: tuple[float, float]) -> bool:
        return super().is_success(state, errors) and leg_modes(state.leg_angles) == (
            self._target_mode
        )

    def step_info(self, step: int, state: SimState, errors: tuple[float, float]) -> dict[str, Any]:
        modes = leg_modes(state.leg_angles)
        to_flip = sum(a != b for a, b in zip(modes, self._target_mode, strict=True))
        return {
            "target_working_mode": self._target_mode,
            "in_target_mode": to_flip == 0,
            "legs_to_flip": to_flip,
        }


#: Starts the sampler draws for a pair of working modes before it gives up (``ValueError``);
#: the modes it draws have certified pairs among a few tries, so this is never reached in
#: practice.
DRAW_ROUNDS = 200
#: ... when the start or the target is requested (a budget: a requested pose with no certified
#: partner is rejected after this many candidate partners, ``pair_tries`` per round).
GIVEN_ROUNDS = 25
#: Candidate pairs the viability check of a pair of working modes certifies (two targets per
#: start, fixed internal seed).
VIABILITY_TRIES = 16


@lru_cache(maxsize=64)
def _viable_pairs(
    design: Design,
    modes: tuple[ModeTriple, ...],
    flips: int,
    limits: PathLimits,
    cfg: task.TaskConfig,
) -> tuple[tuple[ModeTriple, tuple[ModeTriple, ...]], ...]:
    """Start mode -> target modes (as pairs of tuples, cached per design and settings) with at
    least one certified pair among :data:`VIABILITY_TRIES` drawn with a fixed internal seed (so
    the list never depends on the episode's random stream)."""
    rng = np.random.default_rng(0)
    out: dict[ModeTriple, list[ModeTriple]] = {}
    pools: dict[ModeTriple, tuple[np.ndarray, np.ndarray] | None] = {}

    def pool(mode: ModeTriple) -> tuple[np.ndarray, np.ndarray] | None:
        if mode not in pools:
            try:
                pools[mode] = task.sample_poses(design, mode, rng, cfg, max_batches=20)
            except ValueError:
                pools[mode] = None
        return pools[mode]

    for ms in modes:
        starts = pool(ms)
        if starts is None:
            continue
        for mt in single_flip_modes(ms, flips):
            targets = pool(mt)
            if targets is not None and _first_certified(design, starts, targets, ms, mt, limits):
                out.setdefault(ms, []).append(mt)
    return tuple((ms, tuple(mts)) for ms, mts in out.items())


@lru_cache(maxsize=256)
def _pair_viable(
    design: Design, ms: ModeTriple, mt: ModeTriple, limits: PathLimits, cfg: task.TaskConfig
) -> bool:
    """Whether a certified pair from ``ms`` to ``mt`` turns up among
    :data:`VIABILITY_TRIES` drawn with a fixed internal seed (cached)."""
    rng = np.random.default_rng(0)
    try:
        starts = task.sample_poses(design, ms, rng, cfg, max_batches=20)
        targets = task.sample_poses(design, mt, rng, cfg, max_batches=20)
    except ValueError:
        return False
    return _first_certified(design, starts, targets, ms, mt, limits)


def _first_certified(
    design: Design,
    starts: tuple[np.ndarray, np.ndarray],
    targets: tuple[np.ndarray, np.ndarray],
    ms: ModeTriple,
    mt: ModeTriple,
    limits: PathLimits,
) -> bool:
    """Whether one of the first :data:`VIABILITY_TRIES` candidate pairs (each start with the
    first two targets of its assembly mode) has a certified straight travel line."""
    sp, sa = starts
    tp, ta = targets
    n = 0
    for i in range(len(sp)):
        same = np.flatnonzero(ta == sa[i])[:2][: VIABILITY_TRIES - n]
        if same.size and first_straight_path(design, sp[i], ms, tp[same], mt, limits):
            return True
        n += same.size
        if n >= VIABILITY_TRIES:
            return False
    return False
