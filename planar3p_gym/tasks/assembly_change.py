"""Assembly-mode change: the task of ``Planar3PAssemblyChange-v0`` (cross a parallel
singularity with the dynamics; the id's page is
:class:`planar3p_gym.envs.assembly_change.Planar3PAssemblyChangeEnv`).

Start and target are in the same working mode and opposite assembly modes; a pair is kept when
its straight pose path crosses ``det A = 0`` exactly once within the margins and, by default,
when a simulated demonstration motion gets there.  The feasibility checks, the working modes
and why the registered machine is horizontal: docs/environments.md, "How the task modules
work".

* :class:`AssemblyChangeTask`, :class:`CrossingLimits`: the task and its checks' limits;
* re-exported for the task's users: :func:`crossing_path`, :func:`verify_crossing`
  (:mod:`planar3p_gym.tasks.crossing_checks`), :func:`demonstration_travels`,
  :class:`TravelCurve`, :func:`pose_path_travels` (:mod:`planar3p_gym.tasks.travel_motion`),
  :func:`gravity_alignment` (:mod:`planar3p_gym.tasks.singular_gravity`), ``SimFactory``.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import asdict
from typing import Any, ClassVar

import numpy as np
from numba import njit

from planar3p_gym import checks
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.scalar_kinematics import ConfigurationMeasures
from planar3p_gym.sim.physics import Planar3PSim, SimState
from planar3p_gym.tasks import sampling as task
from planar3p_gym.tasks.base import ModeTriple, Pose, Task, pose_list
from planar3p_gym.tasks.crossing_checks import (
    CrossingLimits,
    SimFactory,
    crossing_path,
    verify_crossing,
)
from planar3p_gym.tasks.observation import within_tolerances
from planar3p_gym.tasks.reach_step import TERMS_START
from planar3p_gym.tasks.rewards import weighted_terms
from planar3p_gym.tasks.singular_gravity import gravity_alignment
from planar3p_gym.tasks.travel_motion import TravelCurve, demonstration_travels, pose_path_travels
from planar3p_gym.tasks.travel_shaping import TravelShaping, check_travel_shaping

__all__ = [
    "AssemblyChangeTask",
    "CrossingLimits",
    "SimFactory",
    "TravelCurve",
    "assembly_rows",
    "count_crossing",
    "crossing_path",
    "demonstration_travels",
    "gravity_alignment",
    "pose_path_travels",
    "signed_margin",
    "verify_crossing",
]

#: Candidate pairs tried per working mode at construction to show that episodes exist.  With
#: 20, a mode whose true feasible rate is 0.28 passes the bar of :data:`MIN_FEASIBLE_RATE`
#: (0.5) with a probability of about 3 % (binomial).
BIND_TRIES = 20
#: ... drawn from this many independent samplers (fixed seeds 0, 1, ...).
BIND_SEEDS = 5
#: Smallest fraction of feasible candidates for a working mode to be used (below it sampling
#: would be slow and could fail).
MIN_FEASIBLE_RATE = 0.5
#: Starts the sampler draws before it gives up (``ValueError``; in a working mode that passed
#: :meth:`AssemblyChangeTask.mode_problem`, at least half the candidate pairs are feasible, so
#: this is never reached in practice) ...
DRAW_ROUNDS = 200
#: ... and when the start or the target is requested (``pair_tries`` candidates a round).
GIVEN_ROUNDS = 25
#: Verdicts of :meth:`AssemblyChangeTask.mode_problem`, per design, settings and working mode.
_MODE_PROBLEMS: dict[tuple[Any, ...], str | None] = {}
#: The verdict on a working mode without acceptable poses of both assembly modes.
_ONE_ASSEMBLY = "it has acceptable poses of one assembly mode only"


#: Each assembly-change task's check simulation (:meth:`AssemblyChangeTask._check_sim`).
_CHECK_SIMS: weakref.WeakKeyDictionary[AssemblyChangeTask, Planar3PSim] = (
    weakref.WeakKeyDictionary()
)


@njit(cache=True)
def signed_margin(sign: float, parallel_margin: float) -> float:
    """``sign det A`` (a zero counted as +1) times the parallel margin: the observation's
    signed parallel margin in ``[-1, 1]`` (0 where it is not finite)."""
    signed = (sign if sign != 0 else 1) * parallel_margin
    return signed if math.isfinite(signed) else 0.0


@njit(cache=True)
def count_crossing(sign: int, last_sign: int, crossings: int) -> tuple[int, int]:
    """The assembly mode the platform is in and the crossings counted, after a step whose
    ``sign det A`` is ``sign`` (a zero, at the singularity, changes nothing)."""
    if sign != 0 and sign != last_sign:
        return sign, crossings + 1
    return last_sign, crossings


@njit(cache=True)
def assembly_rows(
    rows: np.ndarray, states: np.ndarray, actions: np.ndarray, res: np.ndarray,
    target_assembly: np.ndarray, last_sign: np.ndarray, crossings: np.ndarray,
    tolerances: np.ndarray, w: np.ndarray, length: float, serial_barrier: bool,
    low: float, high: float, signed: np.ndarray, counts: np.ndarray,
) -> None:  # fmt: skip
    """The assembly-change task's part of a batched step, after the reach outputs ``res``
    (``(len(RESULT_FIELDS), n)``) of the environments ``rows`` (int64 ``(n,)``, of a batch of
    ``N``): for each stepped row ``j`` (environment ``i = rows[j]``, its state ``states[:,
    j]``), the observation's signed parallel margin (:func:`signed_margin`, float32 clipped to
    ``[low, high]``) into ``signed[j]``, the crossing counted (:func:`count_crossing` from
    ``last_sign[i]``, ``crossings[i]``) into ``counts[:, j]``, success in the target's assembly
    mode ``target_assembly[i]`` (the tolerances ``tolerances[i]``, ``(N, 3)``), and the reason
    (1 success, else 0: a crossing is no failure here) and the reward terms
    (:func:`~planar3p_gym.tasks.rewards.weighted_terms`, no parallel barrier) with their sum
    written back into ``res``, as :meth:`AssemblyChangeTask.termination` and its reward
    terms give them.  ``actions`` ``(N, 3)``: the clipped actions; ``w``: the reward
    weights; ``length``: the characteristic length (m)."""
    for j in range(rows.shape[0]):
        i = rows[j]
        sign = int(res[6, j])
        v = min(np.float32(signed_margin(res[6, j], res[4, j])), np.float32(high))
        signed[j] = max(v, np.float32(low))
        counts[0, j], counts[1, j] = count_crossing(sign, last_sign[i], crossings[i])
        success = sign == target_assembly[i] and within_tolerances(
            res[2, j], res[3, j], states[3:6, j], tolerances[i, 0], tolerances[i, 1],
            tolerances[i, 2],
        )  # fmt: skip
        terms = weighted_terms(
            w, res[2, j], res[3, j], length, 1.0, res[5, j] if serial_barrier else 1.0,
            actions[i, 0], actions[i, 1], actions[i, 2], success, False,
        )  # fmt: skip
        total = 0.0
        for t in range(len(terms)):
            total += terms[t]
            res[TERMS_START + t, j] = terms[t]
        res[0, j] = total
        res[1, j] = 1.0 if success else 0.0


class AssemblyChangeTask(TravelShaping, Task):
    """Reach a target pose in the other assembly mode (see the module docstring).

    Args:
        limits: :class:`CrossingLimits` of the feasibility checks (or a dict of its fields).
        pair_tries: target candidates tried per start pose before another start is drawn.
        travel_shaping: weight ``w >= 0`` of the optional reward term towards the target's
            slider travels (:mod:`planar3p_gym.tasks.travel_shaping`; 0: no such term).
    """

    name: ClassVar[str] = "assembly_change"
    hooks_family: ClassVar[str | None] = "assembly_change"
    observation_fields = (
        ("target_rho", 3, "slider travels of the target pose (m)"),
        ("target_assembly", 1, "the target's assembly mode (+-1)"),
        ("signed_parallel_margin", 1, "sign det A times the parallel margin, in [-1, 1]"),
    )
    option_keys: ClassVar[tuple[str, ...]] = ("start", "target", "working_mode")
    termination_reasons: ClassVar[tuple[str, ...]] = ("success", "physics_breakdown")
    failure_reasons: ClassVar[tuple[str, ...]] = ("physics_breakdown",)
    metric_keys: ClassVar[tuple[str, ...]] = (
        "target_assembly",
        "in_target_assembly",
        "crossings",
    )
    #: Passing the parallel singularity is the task: no parallel barrier in the reward.
    parallel_barrier: ClassVar[bool] = False
    compiled_measures: ClassVar[bool] = True

    def __init__(
        self,
        limits: CrossingLimits | dict | None = None,
        pair_tries: int = 8,
        travel_shaping: float = 0.0,
    ) -> None:
        self.limits = checks.config_from(limits, CrossingLimits, "crossing_limits")
        self.pair_tries = checks.count(pair_tries, "pair_tries")
        self.travel_shaping = check_travel_shaping(travel_shaping)

    # ------------------------------------------------------------------ set-up
    def arguments(self) -> dict[str, Any]:
        return {
            "limits": asdict(self.limits),
            "pair_tries": self.pair_tries,
            **self.shaping_arguments(),
        }

    def bind(self, env: Any) -> None:
        super().bind(env)
        self._target: Pose = (0.0, 0.0, 0.0)
        self._target_rho = (0.0, 0.0, 0.0)
        self._target_asm = 1
        #: The last nonzero ``sign det A`` seen (the assembly mode the platform is in) and the
        #: crossings counted so far in the episode (:meth:`termination` counts them).
        self.last_sign = 1
        self.crossings = 0
        verdicts = {m: self.mode_problem(m) for m in env.modes}
        self.modes = [m for m, problem in verdicts.items() if problem is None]
        if not self.modes:
            if all(problem == _ONE_ASSEMBLY for problem in verdicts.values()):
                raise ValueError(
                    f"no working mode among {env.modes} has acceptable poses in both assembly "
                    "modes on this design: no assembly change can be sampled"
                )
            raise ValueError(
                "too few feasible assembly changes on this design (fewer than "
                f"{MIN_FEASIBLE_RATE:.0%} of {BIND_TRIES} candidate pairs per working mode, fixed "
                "internal seed): the simulated demonstration crossing does not reach the target "
                "(under gravity the platform falls onto another branch of the direct "
                "kinematics; see the module docstring). Use "
                "gravity=0 (the default design of Planar3PAssemblyChange-v0) or "
                "crossing_limits={'verify': False}"
            )

    def _settings(self) -> tuple[Any, ...]:
        """What decides whether a working mode has assembly changes (the key of the cache of
        :meth:`mode_problem`): the design, the task's margins and limits, and the simulation
        the demonstration crossing runs in."""
        env = self.env
        return (
            env.design,
            env.task_config,
            self.limits,
            env.dt,
            env.substeps,
            env.solver_iterations,
            bool(getattr(env, "projection", False)),
            env.breakdown_distance,
        )

    def mode_problem(self, mode: ModeTriple) -> str | None:
        """Why working ``mode`` has no assembly changes to sample, or ``None``: it must have
        acceptable poses of both assembly modes (:func:`~planar3p_gym.tasks.sampling.
        assembly_modes`) and at least :data:`MIN_FEASIBLE_RATE` of :data:`BIND_TRIES` candidate
        pairs (fixed internal seeds) must pass :meth:`feasible`.  Bounded work (at most
        :data:`BIND_TRIES` simulated crossings), cached per design and settings, and the
        episode's random stream is not touched: the constructor's check of its working
        modes, and the check of a requested ``working_mode`` at reset."""
        key = (*self._settings(), mode)
        if key not in _MODE_PROBLEMS:
            _MODE_PROBLEMS[key] = self._find_mode_problem(mode)
        return _MODE_PROBLEMS[key]

    def _find_mode_problem(self, mode: ModeTriple) -> str | None:
        design, cfg = self.env.design, self.env.task_config
        if task.assembly_modes(design, mode, cfg) != {1.0, -1.0}:
            return _ONE_ASSEMBLY
        if self._feasible_rate(mode) < MIN_FEASIBLE_RATE:
            return (
                f"fewer than {MIN_FEASIBLE_RATE:.0%} of {BIND_TRIES} candidate assembly changes "
                f"in working mode {mode} pass the feasibility checks (fixed internal seed)"
            )
        return None

    def _feasible_rate(self, mode: ModeTriple) -> float:
        """Fraction of :data:`BIND_TRIES` candidate pairs (fixed internal seed: the episode's
        random stream is not touched) that are feasible."""
        hits = 0
        for seed in range(BIND_SEEDS):  # poses of one sampler batch are alike: several batches
            rng = np.random.default_rng(seed)
            sampler = task.PoseSampler(self.env.design, mode, self.env.task_config)
            for _ in range(BIND_TRIES // BIND_SEEDS):
                s, asm = sampler.draw(rng)
                t = sampler.draw_many(rng, -asm, 1)
                hits += bool(len(t)) and bool(self.feasible(s, t[0], mode)[0])
        return hits / (BIND_SEEDS * (BIND_TRIES // BIND_SEEDS))

    def _check_sim(self, pose: np.ndarray, mode: tuple[int, int, int]) -> Planar3PSim:
        """The task's check simulation (:meth:`make_sim`, built on first use and kept: each
        check moves it, :func:`verify_crossing` with ``sim``).  Kept in
        :data:`_CHECK_SIMS`, not as an attribute: the environment snapshots the task's
        attributes by deep copy (``get_state``, a rejected reset), and the simulation is a
        cache, not state (a moved simulation is bit for bit a new one)."""
        sim = _CHECK_SIMS.get(self)
        if sim is None or sim.closed:
            sim = _CHECK_SIMS[self] = self.make_sim(pose, mode)
        return sim

    def close(self) -> None:
        """Free the check simulation now (the environment's ``close`` calls this)."""
        sim = _CHECK_SIMS.pop(self, None)
        if sim is not None:
            sim.close()

    def make_sim(self, pose: np.ndarray, mode: tuple[int, int, int]) -> Planar3PSim:
        """A simulation with the environment's settings (what an episode runs on)."""
        env = self.env
        kwargs: dict[str, Any] = {
            "dt": env.dt,
            "substeps": env.substeps,
            "iterations": env.solver_iterations,
        }
        if getattr(env, "projection", False):
            kwargs["projection"] = True
        return Planar3PSim(env.design, pose, mode, **kwargs)

    # ------------------------------------------------------------------ options and sampling
    def check_options(self, options: dict[str, Any]) -> dict[str, Any]:
        if options.get("working_mode") is not None:
            options["working_mode"] = checks.mode_from(options["working_mode"], "working_mode")
            mode = options["working_mode"]
            problem = None if mode in self.modes else self.mode_problem(mode)
            if problem is not None:
                raise ValueError(
                    f"working_mode {mode} has no assembly change to draw: {problem} (this "
                    f"environment samples {self.modes})"
                )
        mode = options.get("working_mode")
        if mode is None and len(self.modes) == 1:
            mode = self.modes[0]
        if mode is not None:
            for name in ("start", "target"):
                if options.get(name) is not None:
                    options[name] = task.check_pose(self.env.design, options[name], mode, name)
        return options

    def _assembly(self, pose: np.ndarray, mode: ModeTriple) -> int:
        design = self.env.design
        return int(
            kinematics.assembly_mode(design, pose, kinematics.inverse(design, pose, mode).rho)
        )

    def feasible(self, start: np.ndarray, target: np.ndarray, mode: ModeTriple) -> tuple[bool, str]:
        """Whether ``(start, target)`` in ``mode`` passes the task's checks: ``(ok, reason)``."""
        design = self.env.design
        if self._assembly(start, mode) == self._assembly(target, mode):
            return False, "start and target are in the same assembly mode (sign det A)"
        ok, reason = crossing_path(design, start, target, mode, self.limits)
        if not ok:
            return False, f"the straight pose path fails the kinematic check ({reason})"
        if self.limits.verify:
            ok, fig = verify_crossing(
                design,
                start,
                target,
                mode,
                self.limits,
                None,
                self.env.breakdown_distance,
                sim=self._check_sim(start, mode),
            )
            if not ok:
                return False, (
                    "the simulated demonstration crossing does not reach the target "
                    f"(ends {fig['end_distance']:.4g} m away in assembly mode "
                    f"{fig['end_assembly']:+d})"
                )
        return True, "ok"

    def episode_spec(self, rng: np.random.Generator, options: dict[str, Any]) -> dict[str, Any]:
        design = self.env.design
        mode = options.get("working_mode")
        if mode is None:
            mode = (
                self.modes[int(rng.integers(len(self.modes)))]
                if len(self.modes) > 1
                else (self.modes[0])
            )
        start, target = options.get("start"), options.get("target")
        if start is not None:
            start = task.check_pose(design, start, mode, "start")
        if target is not None:
            target = task.check_pose(design, target, mode, "target")
        if start is not None and target is not None:
            ok, reason = self.feasible(start, target, mode)
            if not ok:
                raise ValueError(f"infeasible assembly change from start to target: {reason}")
        else:
            start, target = self._draw(rng, mode, start, target)
        return {
            "task": self.name,
            "working_mode": [int(m) for m in mode],
            "start": pose_list(start),
            "target": pose_list(target),
        }

    def _draw(
        self,
        rng: np.random.Generator,
        mode: ModeTriple,
        start: np.ndarray | None,
        target: np.ndarray | None,
    ) -> tuple[np.ndarray, np.ndarray]:
        sampler = self.pose_sampler(mode)
        design, cfg = self.env.design, self.env.task_config
        free = start is None and target is None
        for _ in range(DRAW_ROUNDS if free else GIVEN_ROUNDS):
            if start is None:
                s, asm = sampler.draw(rng)
            else:
                s, asm = start, float(self._assembly(start, mode))
            if target is None:
                if -asm not in task.assembly_modes(design, mode, cfg):
                    if start is not None:
                        break  # no target of the other assembly mode in this working mode
                    continue
                cands = sampler.draw_many(rng, -asm, self.pair_tries)
            else:
                cands = target[None, :]
            for t in cands:
                if self.feasible(s, t, mode)[0]:
                    return s, t
            if start is not None and target is not None:
                break
        if free:
            raise ValueError(
                f"no feasible assembly change found in working mode {mode} after {DRAW_ROUNDS} "
                "drawn starts"
            )
        fixed = "start" if start is not None else "target"
        raise ValueError(
            f"no feasible assembly change found for the requested {fixed} in working mode "
            f"{mode} in {GIVEN_ROUNDS} draws of the other end; give another {fixed} or leave "
            "it to the sampler"
        )

    def begin(self, spec: dict[str, Any]) -> tuple[np.ndarray, tuple[int, int, int]]:
        mode = checks.mode_from(spec["working_mode"], "working_mode")
        tx, ty, tth = spec["target"]
        self._target = (float(tx), float(ty), float(tth))
        rho = kinematics.inverse(self.env.design, self._target, mode).rho
        self._target_rho = (float(rho[0]), float(rho[1]), float(rho[2]))
        self._target_asm = self._assembly(np.asarray(self._target), mode)
        self.last_sign = -self._target_asm
        self.crossings = 0
        start = np.asarray(spec["start"], dtype=np.float64)
        self.start_travels(kinematics.inverse(self.env.design, start, mode).rho)
        return start, mode

    # ------------------------------------------------------------------ per step
    def reference(self, step: int) -> Pose:
        return self._target

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.travel_bounds(2)  # target travels, target assembly, signed parallel margin

    def observation_extra(
        self, step: int, state: SimState, measures: ConfigurationMeasures
    ) -> list[float]:
        return [
            *self._target_rho,
            float(self._target_asm),
            signed_margin(measures.det_sign, measures.parallel_margin),
        ]

    def termination(
        self,
        state: SimState,
        measures: ConfigurationMeasures,
        errors: tuple[float, float],
        assembly: int,
    ) -> str | None:
        sign = measures.det_sign
        self.last_sign, self.crossings = count_crossing(sign, self.last_sign, self.crossings)
        if sign == self._target_asm and self.is_success(state, errors):
            return "success"
        return None

    def step_info(self, step: int, state: SimState, errors: tuple[float, float]) -> dict[str, Any]:
        return {
            "target_assembly": self._target_asm,
            "in_target_assembly": self.last_sign == self._target_asm,
            "crossings": self.crossings,
        }
