"""Playing episodes: the runner of the benchmark and what it measures per episode.

:func:`run_episode` plays one :class:`~planar3p_agents.evaluation.reach_suites.EpisodeSpec` with any
object that has an SB3-style ``predict`` and returns an :class:`EpisodeResult` (outcome, errors,
margins, saturation, mechanical energy, closure error, and why a timeout did not succeed);
:func:`evaluate` plays a suite.  SB3's ``evaluate_policy`` returns only returns and lengths;
this runner also replays fixed episodes through ``reset(options=...)``, seeds each policy per
episode (so run order does not matter) and records the per-step quantities above.
SI units unless a name says otherwise.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from planar3p_agents.evaluation.reach_suites import EpisodeSpec, Suite, suite_id
from planar3p_gym.envs.end_reason import TIME_LIMIT
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks import sampling as task
from planar3p_gym.tasks.observation import SLICES

__all__ = [
    "BOUNDED_TASKS",
    "FAILURE_CAUSES",
    "EpisodeResult",
    "episode_bound",
    "episode_seed",
    "evaluate",
    "reset_episode",
    "run_episode",
    "speed_bound",
]

#: How an episode ended (``EpisodeResult.cause``): success, the two failures the environment
#: reports, and the diagnoses of a timeout from the final state.  A task that has no success
#: (tracking) ends its timed-out episodes as ``"completed"`` instead.
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


@dataclass
class EpisodeResult:
    """Outcome and measurements of one episode (SI units unless the name says otherwise).

    ``cause`` is one of :data:`FAILURE_CAUSES`.  ``max_closure_error`` is the largest
    loop-closure error of the simulation during the episode (m).  ``trajectory`` (poses,
    ``(steps + 1, 3)``) is kept only when asked for and is not part of :meth:`row`.
    ``task_metrics`` holds the metrics a task reports at the end of an episode (e.g. tracking
    errors, m or rad as named); empty for the reach task.  ``success_defined`` is false for a
    task without a success test (tracking).  ``speed_bound`` (s) is :func:`speed_bound` of the
    episode on its own machine (:func:`episode_bound`; NaN for a task whose target is not in
    the start's working mode, or without one) and ``time_over_bound`` the time to success
    divided by it (NaN unless successful).
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
    slider_line_reaches: bool
    trajectory: np.ndarray | None = None
    task_metrics: dict[str, float] = field(default_factory=dict)
    success_defined: bool = True
    speed_bound: float = math.nan
    time_over_bound: float = math.nan

    def row(self) -> dict[str, Any]:
        """Plain values for CSV/JSON: the fields without the trajectory (and
        ``success_defined``), then the task metrics (if any) as further columns."""
        out = asdict(self)
        out.pop("trajectory")
        out.pop("success_defined")
        out.update(out.pop("task_metrics"))
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
    return np.random.SeedSequence([int(seed), 0xE915, suite_id(suite), int(index)])


#: Tasks whose target is in the start's working mode: :func:`episode_bound` applies.
BOUNDED_TASKS = ("reach", "goal")


def speed_bound(design: Design, start: Any, target: Any, mode: Any) -> float:
    """The physical limit of a reach episode (s): ``max_i |rho_i(target) - rho_i(start)| /
    max_speed``, the travels by inverse kinematics in working mode ``mode`` (no slider can move
    faster than ``max_speed``, so no policy reaches the target sooner).  NaN if an end does not
    close in ``mode``."""
    m = np.asarray(mode, dtype=np.float64)
    r0 = kinematics.inverse(design, np.asarray(start, dtype=np.float64), m).rho
    r1 = kinematics.inverse(design, np.asarray(target, dtype=np.float64), m).rho
    bound = float(np.max(np.abs(r1 - r0)) / design.max_speed)
    return bound if math.isfinite(bound) else math.nan


def episode_bound(
    design: Design, spec: EpisodeSpec, machine: Mapping[str, Any] | None = None
) -> float:
    """:func:`speed_bound` of ``spec`` if its target is in its start's working mode (a reach
    suite, or a task of :data:`BOUNDED_TASKS`), else NaN.  ``machine`` is the episode's drawn
    machine as a randomised environment reports it at reset (``info["machine"]``): the bound
    is then that machine's (its travels and speed limit), not the nominal ``design``'s."""
    if spec.target is None:
        return math.nan
    if spec.options is not None and spec.options.get("task") not in BOUNDED_TASKS:
        return math.nan
    if machine is not None:
        design = Design.from_dict(dict(machine["design"]))
    return speed_bound(design, spec.start, spec.target, spec.working_mode)


def reset_episode(env: Any, spec: EpisodeSpec, seed: int) -> tuple[Any, dict[str, Any]]:
    """``env.reset`` for episode ``spec`` as the benchmark plays it (environment seed ``seed +
    spec.index`` and the episode's options): ``(observation, info)``."""
    return env.reset(seed=int(seed) + spec.index, options=spec.reset_options())


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
    """Play ``spec`` in ``env`` (``Planar3P-v0``, or the task id of a task suite, made with
    ``gymnasium.make``, so with its time limit) with ``policy`` (anything with SB3's
    ``predict``).  A policy with a ``reset(seed=)`` method is reset first with
    :func:`episode_seed`.  The task's metrics (``Task.metric_keys``) are read from the last
    ``info`` of the episode."""
    base = env.unwrapped
    design: Design = base.design
    dt = float(base.dt)
    stroke = design.stroke
    _reset_policy(policy, episode_seed(seed, spec.suite, spec.index))
    obs, info = reset_episode(env, spec, seed)
    machine = info.get("machine")
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
        if not mode_changed and spec.options is None:  # reach: leg angles of the observation
            cos_a = np.asarray(obs[legs], dtype=np.float64)[0::2]
            mode_changed = bool(np.any(cos_a * mode < -1e-3))
        elif not mode_changed:  # a task suite: the environment's own report
            mode_changed = bool(info.get("working_mode_changed", False))
        if terminated or truncated:
            reason = info["termination_reason"]
            break
    success = bool(info["is_success"])
    task_obj = getattr(base, "task", None)
    can_succeed = "success" in getattr(task_obj, "termination_reasons", ("success",))
    if reason is None:
        reason = TIME_LIMIT
        cause = _diagnose(info, design, base.task_config) if can_succeed else "completed"
    else:
        cause = reason
    bound = episode_bound(design, spec, machine)
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
        slider_line_reaches=bool(spec.path.get("slider_line_reaches", False)),
        trajectory=np.array(poses) if poses is not None else None,
        success_defined=can_succeed,
        task_metrics=_metrics(info, getattr(getattr(base, "task", None), "metric_keys", ())),
        speed_bound=bound,
        time_over_bound=steps * dt / bound if success and bound > 0 else math.nan,
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


def _metrics(info: dict[str, Any], keys: tuple[str, ...]) -> dict[str, float]:
    """The numeric outcome metrics among ``keys`` in ``info``: not the ones that describe the
    episode's target (``target_*``), nor non-numeric ones (e.g. a mode)."""
    out = {}
    for k in keys:
        if k.startswith("target_"):
            continue
        v = info.get(k)
        if isinstance(v, (bool, int, float, np.bool_, np.integer, np.floating)):
            out[k] = float(v)
    return out
