"""The crossing-fidelity study: play an assembly-change episode while booking the physics --
the servos' signed work, the mechanical energy, the energy the solver and the projection add,
and the loop-closure error -- over the episode and within the crossing (used by
:mod:`planar3p_agents.controllers.crossing` and the repository's
``scripts/task_baselines.py``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["CROSSING_MARGIN", "crossing_fidelity", "mechanical_energy"]

#: ``cpPinJoint`` layout after its ``cpConstraint`` header, in doubles from ``anchorA``:
#: anchorA (2), anchorB (2), dist, r1 (2), r2 (2), n (2), nMass, jnAcc, bias.
_PIN_N, _PIN_JN = 9, 12


#: Steps with a parallel margin below this count as the crossing in :func:`crossing_fidelity`.
CROSSING_MARGIN = 0.05


class _ServoReader:
    """Signed servo impulses, read from Chipmunk's ``cpPinJoint`` struct (``jnAcc`` along the
    unit vector ``n``): pymunk's public ``impulse`` is its absolute value, and the energy
    balance needs the sign.  The field offsets are located once from the known anchors and
    length, and every read is checked against the public ``impulse`` (``ValueError`` if the
    layout does not match, e.g. another pymunk build)."""

    def __init__(self, servo: Any) -> None:
        from pymunk._chipmunk_cffi import ffi

        self._ffi = ffi
        self._servo = servo
        self._ptr = ffi.cast("double *", servo._constraint)
        ax, ay = servo.anchor_a
        bx, by = servo.anchor_b
        pattern = [ax, ay, bx, by, servo.distance]
        for start in range(0, 40):
            if [self._ptr[start + j] for j in range(5)] == pattern:
                self._base = start
                break
        else:
            raise ValueError("cannot locate cpPinJoint fields (unexpected pymunk build)")

    def impulse_x(self) -> float:
        """Signed x impulse (N s) the servo applied to its slider in the last physics step."""
        p, b = self._ptr, self._base
        jn, nx = p[b + _PIN_JN], p[b + _PIN_N]
        if abs(abs(jn) - self._servo.impulse) > 1e-12 * max(1.0, abs(jn)):
            raise ValueError("cpPinJoint layout check failed: jnAcc does not match impulse")
        return jn * nx


def mechanical_energy(bodies: Any, gravity: float) -> float:
    """Kinetic plus potential energy (J) of pymunk bodies (infinite moments of inertia, i.e.
    bodies that cannot turn, contribute no rotational energy); potential ``m g y``."""
    e = 0.0
    for b in bodies:
        v = b.velocity
        e += 0.5 * b.mass * (v.x * v.x + v.y * v.y) + b.mass * gravity * b.position.y
        if math.isfinite(b.moment):
            e += 0.5 * b.moment * b.angular_velocity**2
    return e


class _RecordingSpace:
    """A pymunk space whose ``step`` also books the servos' work and the energy per step."""

    def __init__(self, space: Any, sim: Any) -> None:
        self._space = space
        self._readers = [_ServoReader(s) for s in sim.servos]
        self._sliders = sim.sliders
        self._bodies = (sim.platform, *sim.sliders, *sim.legs)
        self._g = sim.design.gravity
        self.work = 0.0
        self.energy_before = mechanical_energy(self._bodies, self._g)

    def step(self, h: float) -> None:
        self._space.step(h)
        for reader, slider in zip(self._readers, self._sliders, strict=True):
            self.work += reader.impulse_x() * slider.velocity.x

    def energy(self) -> float:
        return mechanical_energy(self._bodies, self._g)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._space, name)


def crossing_fidelity(env: Any, policy: Any, seed: int) -> dict[str, float]:
    """Play one seeded episode of an assembly-change environment with ``policy`` while
    measuring the physics.

    Returns: ``success``, ``steps``, ``crossings``; the loop-closure error (m) over the episode
    and within the crossing (steps with parallel margin below :data:`CROSSING_MARGIN`); and the
    energy balance:
    ``servo_work`` (J, signed servo impulses times slider velocities, summed per physics step),
    ``energy_gap`` (J, change of mechanical energy over the simulation steps minus the servos'
    work: the work of the solver's position corrections, the rails' end stops and unconverged
    iterations; 0 for an exact model), ``projection_energy`` (J, energy changed by the
    projection, if on), both also relative to the servos' total absolute work, and
    ``worst_step_gap`` (J, largest gap of one control step); ``energy_gap_crossing`` and
    ``projection_energy_crossing`` (J) sum the same over the crossing's steps (parallel margin
    below :data:`CROSSING_MARGIN`).
    """
    base = env.unwrapped
    obs, info = env.reset(seed=seed)
    sim = base.sim
    rec = _RecordingSpace(sim.space, sim)
    marks = {"before_projection": math.nan}

    def book_projection() -> None:
        marks["before_projection"] = rec.energy()

    # pymunk's public-API steps (the same results), so that each physics step can be booked.
    sim.step_through_api(book_projection if base.projection else None)
    sim.space = rec
    if hasattr(policy, "reset"):
        policy.reset()
    start = np.ones(1, dtype=bool)
    gap = proj = abs_work = worst = gap_cross = proj_cross = 0.0
    closure = cross_closure = 0.0
    steps = crossings = 0
    success = False
    while True:
        action, _ = policy.predict(obs, episode_start=start)
        start = np.zeros(1, dtype=bool)
        e0, w0 = rec.energy(), rec.work
        obs, _, terminated, truncated, info = env.step(action)
        steps += 1
        e1 = rec.energy()
        mid = marks["before_projection"] if base.projection else e1
        step_work = rec.work - w0
        abs_work += abs(step_work)
        step_gap = (mid - e0) - step_work
        gap += step_gap
        proj += e1 - mid
        worst = max(worst, abs(step_gap))
        closure = max(closure, float(info["closure_error"]))
        if float(info["parallel_margin"]) < CROSSING_MARGIN:
            cross_closure = max(cross_closure, float(info["closure_error"]))
            gap_cross += step_gap
            proj_cross += e1 - mid
        crossings = int(info.get("crossings", 0))
        if terminated or truncated:
            success = bool(info["is_success"])
            break
    scale = abs_work if abs_work > 0 else 1.0
    return {
        "success": float(success),
        "steps": float(steps),
        "crossings": float(crossings),
        "max_closure_error": closure,
        "max_closure_error_crossing": cross_closure,
        "servo_work": rec.work,
        "servo_abs_work": abs_work,
        "energy_gap": gap,
        "energy_gap_relative": gap / scale,
        "projection_energy": proj,
        "projection_energy_relative": proj / scale,
        "worst_step_gap": worst,
        "energy_gap_crossing": gap_cross,
        "projection_energy_crossing": proj_cross,
    }
