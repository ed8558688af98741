"""Constrained dynamics for the control steps pymunk's solver cannot close: a parallel singularity.

Where the projection finds no closed state near pymunk's (the servo-held chain locks at a
parallel singularity), :func:`recover` takes the control step again from its start with a
direct solution of the same model and hands the state back to pymunk (the method:
docs/physics.md, "How the simulation modules work"; why hand-written: the problem is 15
coordinates, 12 equations and 3 bounded impulses, solved in compiled code once per rare step).

* :func:`recover`: the step in adaptive substeps (``False``: a real breakdown);
* :func:`recovery_constants`: the bodies' masses and moments, pymunk's;
* :data:`SUBSTEPS`, :data:`SERVO_COMPLIANCE`, :data:`PIVOT_RIDGE`: its settings.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = [
    "ENERGY_SLACK",
    "MAX_HALVINGS",
    "PIVOT_RIDGE",
    "RECOVERY_FIELDS",
    "SERVO_COMPLIANCE",
    "SUBSTEPS",
    "energy",
    "excess_energy",
    "recover",
    "recovery_constants",
]

#: Mechanical energy (J) a projected step may make beyond the servos' work before it is taken
#: again by :func:`recover` (docs/physics.md: ordinary steps stay below 0.01 J; the steps
#: that lock at a parallel singularity make up to hundreds of joules).
ENERGY_SLACK = 1e-3
#: Substeps of a recovered control step (0.5 ms at 50 Hz).
SUBSTEPS = 40
#: How many times a substep may be halved when its projection does not converge.
MAX_HALVINGS = 12
#: Servo compliance relative to the largest diagonal entry of the servos' matrix.
SERVO_COMPLIANCE = 1e-9
#: Ridge of the pivots' matrix relative to its largest diagonal entry.
PIVOT_RIDGE = 1e-13
#: Pivot separation (m) below which a position projection has converged.
PIVOT_TOLERANCE = 1e-13
#: Newton steps of one position projection.
PIVOT_NEWTON_STEPS = 30
#: A slider this close to an end of its stroke (m) is on the stop.
ON_STOP = 1e-8

#: The numbers :func:`recovery_constants` gives, in order.
RECOVERY_FIELDS = (
    "origin_1", "origin_2", "origin_3", "leg_1", "leg_2", "leg_3",
    "point_1", "point_2", "point_3", "stroke", "platform_mass", "platform_moment",
    "slider_mass", "leg_mass_1", "leg_mass_2", "leg_mass_3", "leg_moment_1", "leg_moment_2",
    "leg_moment_3", "gravity_x", "gravity_y", "max_force", "servo_max_bias", "servo_error_bias",
    "slider_viscous", "joint_viscous", "slider_coulomb", "joint_coulomb",
)  # fmt: skip


def recovery_constants(
    origins: tuple[float, float, float],
    legs: tuple[float, float, float],
    points: tuple[float, float, float],
    stroke: float,
    platform: tuple[float, float],
    slider_mass: float,
    leg_bodies: tuple[tuple[float, float], ...],
    gravity: tuple[float, float],
    max_force: float,
    servo_max_bias: float,
    servo_error_bias: float,
    slider_viscous: float,
    joint_viscous: float,
    slider_coulomb: float,
    joint_coulomb: float,
) -> np.ndarray:
    """The numbers :func:`recover` reads (:data:`RECOVERY_FIELDS`): the rail origins, leg
    lengths and the platform's joint points from its centre along its axis (m), the stroke (m),
    the platform's mass (kg) and moment (kg m^2), the slider mass (kg), each leg's mass and
    moment, gravity (m/s^2), the servos' force limit (N), largest correction speed (m/s) and
    error bias (fraction of an error left after 1 s), the viscous coefficients (N s/m,
    N m s/rad) and the dry friction of the sliders (N) and the joints (N m)."""
    values = [
        *origins, *legs, *points, stroke, *platform, slider_mass,
        *(m for m, _ in leg_bodies), *(i for _, i in leg_bodies), *gravity, max_force,
        servo_max_bias, servo_error_bias, slider_viscous, joint_viscous, slider_coulomb,
        joint_coulomb,
    ]  # fmt: skip
    out = np.array(values, dtype=np.float64)
    assert out.shape == (len(RECOVERY_FIELDS),)
    return out


@njit(cache=True)
def _pivots(z: np.ndarray, rc: np.ndarray, phi: np.ndarray, jac: np.ndarray) -> float:
    """The 12 pivot separations ``phi`` (m) at the coordinates ``z`` and their Jacobian ``jac``
    (12 x 15); returns the largest separation.  Rows ``4 i .. 4 i + 3``: ``B_i`` (x, y) then
    ``C_i`` (x, y); columns: slider ``i`` at ``i``, leg ``i`` at ``3 + 3 i`` (x, y, angle), the
    platform at 12 (x, y, angle)."""
    jac[:, :] = 0.0
    px, py, th = z[12], z[13], z[14]
    ct, st = math.cos(th), math.sin(th)
    worst = 0.0
    for i in range(3):
        hl = 0.5 * rc[3 + i]
        d = rc[6 + i]
        o = 3 + 3 * i
        lx, ly, ph = z[o], z[o + 1], z[o + 2]
        cp, sp = math.cos(ph), math.sin(ph)
        r = 4 * i
        phi[r] = lx - hl * cp - z[i]
        phi[r + 1] = ly - hl * sp
        phi[r + 2] = lx + hl * cp - px - d * ct
        phi[r + 3] = ly + hl * sp - py - d * st
        jac[r, o], jac[r, o + 2], jac[r, i] = 1.0, hl * sp, -1.0
        jac[r + 1, o + 1], jac[r + 1, o + 2] = 1.0, -hl * cp
        jac[r + 2, o], jac[r + 2, o + 2], jac[r + 2, 12], jac[r + 2, 14] = (
            1.0, -hl * sp, -1.0, d * st
        )  # fmt: skip
        jac[r + 3, o + 1], jac[r + 3, o + 2], jac[r + 3, 13], jac[r + 3, 14] = (
            1.0, hl * cp, -1.0, -d * ct
        )  # fmt: skip
        for k in range(4):
            a = abs(phi[r + k])
            if not a <= worst:  # (a NaN makes the largest NaN)
                worst = a
    return worst


def _pivot_structure() -> tuple[np.ndarray, ...]:
    """Where the pivots' Jacobian (:func:`_pivots`) can be non-zero: a ``(12, 15)`` mask, each
    row's columns and each column's rows (ascending, padded with -1) and their counts.  Read
    from :func:`_pivots` itself (its Python function, nothing compiled at import) at a generic
    configuration, every coordinate and number distinct and no angle a multiple of pi/2.  The
    sums over the Jacobian skip its structural zeros, whose products are exact zeros that
    leave a finite sum unchanged: the same numbers in fewer operations."""
    jac = np.empty((12, 15))
    _pivots.py_func(
        np.arange(1.0, 16.0) / 11.0,
        np.arange(1.0, len(RECOVERY_FIELDS) + 1.0) / 7.0,
        np.empty(12),
        jac,
    )
    nonzero = jac != 0.0
    row_cols = np.full((12, 4), -1, dtype=np.int64)
    col_rows = np.full((15, 6), -1, dtype=np.int64)
    for row in range(12):
        cols = np.flatnonzero(nonzero[row])
        row_cols[row, : cols.size] = cols
    for col in range(15):
        rows = np.flatnonzero(nonzero[:, col])
        col_rows[col, : rows.size] = rows
    return nonzero, row_cols, nonzero.sum(axis=1), col_rows, nonzero.sum(axis=0)


_NONZERO, _ROW_COLS, _ROW_COUNT, _COL_ROWS, _COL_COUNT = _pivot_structure()


@njit(cache=True)
def _factor(jac: np.ndarray, minv: np.ndarray, chol: np.ndarray) -> None:
    """Cholesky factor (lower, in ``chol``) of ``J diag(minv) J^T`` plus its ridge (the
    products over the Jacobian's structural non-zeros, :func:`_pivot_structure`)."""
    n = jac.shape[0]
    top = 0.0
    for a in range(n):
        for b in range(a + 1):
            s = 0.0
            for c in range(_ROW_COUNT[a]):
                k = _ROW_COLS[a, c]
                if _NONZERO[b, k]:
                    s += jac[a, k] * minv[k] * jac[b, k]
            chol[a, b] = s
        top = max(top, chol[a, a])
    ridge = PIVOT_RIDGE * top
    for a in range(n):
        chol[a, a] += ridge
    for j in range(n):
        s = chol[j, j]
        for k in range(j):
            s -= chol[j, k] * chol[j, k]
        d = math.sqrt(s) if s > 0.0 else math.nan
        chol[j, j] = d
        for i in range(j + 1, n):
            s = chol[i, j]
            for k in range(j):
                s -= chol[i, k] * chol[j, k]
            chol[i, j] = s / d


@njit(cache=True)
def _jac_times(jac: np.ndarray, v: np.ndarray, out: np.ndarray) -> None:
    """``out = J v`` over the Jacobian's structural non-zeros (:func:`_pivot_structure`)."""
    for i in range(jac.shape[0]):
        s = 0.0
        for c in range(_ROW_COUNT[i]):
            k = _ROW_COLS[i, c]
            s += jac[i, k] * v[k]
        out[i] = s


@njit(cache=True)
def _correct(
    jac: np.ndarray, minv: np.ndarray, chol: np.ndarray, rhs: np.ndarray, x: np.ndarray,
    y: np.ndarray,
) -> None:  # fmt: skip
    """``x -= diag(minv) J^T (J diag(minv) J^T)^-1 rhs`` (the factor from :func:`_factor`; ``y``
    a work array of 12): the mass-weighted minimal change of ``x`` whose image under ``J`` is
    ``-rhs``."""
    n = chol.shape[0]
    for i in range(n):
        s = rhs[i]
        for k in range(i):
            s -= chol[i, k] * y[k]
        y[i] = s / chol[i, i]
    for i in range(n - 1, -1, -1):
        s = y[i]
        for k in range(i + 1, n):
            s -= chol[k, i] * y[k]
        y[i] = s / chol[i, i]
    for k in range(jac.shape[1]):
        if minv[k] != 0.0:
            s = 0.0
            for c in range(_COL_COUNT[k]):
                i = _COL_ROWS[k, c]
                s += jac[i, k] * y[i]
            x[k] -= minv[k] * s


@njit(cache=True)
def _project_velocity(
    jac: np.ndarray, minv: np.ndarray, chol: np.ndarray, u: np.ndarray, rhs: np.ndarray,
    y: np.ndarray,
) -> None:  # fmt: skip
    """``u`` onto the pivots' tangent space ``J u = 0`` in the mass metric (in place; ``rhs``,
    ``y``: work arrays of 12)."""
    _jac_times(jac, u, rhs)
    _correct(jac, minv, chol, rhs, u, y)


@njit(cache=True)
def _solve_small(
    a: np.ndarray, b: np.ndarray, free: np.ndarray, k: int, x: np.ndarray, m: np.ndarray
) -> bool:
    """Solve ``a[free][:, free] x_f = b[free]`` (``k`` free indices, at most 3) by Gaussian
    elimination with partial pivoting, in the work array ``m`` (3 x 4, zeroed here); ``x[free]``
    receives the solution.  False if singular."""
    m[:, :] = 0.0
    for r in range(k):
        for c in range(k):
            m[r, c] = a[free[r], free[c]]
        m[r, 3] = b[free[r]]
    for c in range(k):
        p = c
        for r in range(c + 1, k):
            if abs(m[r, c]) > abs(m[p, c]):
                p = r
        if m[p, c] == 0.0:
            return False
        if p != c:
            for q in range(4):
                m[c, q], m[p, q] = m[p, q], m[c, q]
        for r in range(c + 1, k):
            f = m[r, c] / m[c, c]
            for q in range(c, 4):
                m[r, q] -= f * m[c, q]
    for r in range(k - 1, -1, -1):
        s = m[r, 3]
        for c in range(r + 1, k):
            s -= m[r, c] * x[free[c]]
        x[free[r]] = s / m[r, r]
    return True


@njit(cache=True)
def _box_qp(
    a: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray, x: np.ndarray,
    free: np.ndarray, y: np.ndarray, rhs: np.ndarray, work: np.ndarray,
) -> None:  # fmt: skip
    """The minimiser ``x`` of ``x^T a x / 2 + b^T x`` over the box ``lo <= x <= hi`` (3 values,
    ``a`` positive definite; infinite bounds allowed; ``free`` (int64), ``y``, ``rhs`` (3) and
    ``work`` (3 x 4): work arrays, each entry written before it is read).  Each of the 27
    choices of free, at its lower and at its upper bound per variable gives a point (the free
    variables solved, then clamped into the box); every point is feasible and one of them is
    the minimiser, so the lowest objective among them is the exact solution, with no
    tolerance to tune."""
    best = math.inf
    for code in range(27):
        c = code
        k = 0
        skip = False
        for i in range(3):
            s = c % 3
            c //= 3
            if s == 0:
                free[k] = i
                k += 1
            elif s == 1:
                if lo[i] == -math.inf:
                    skip = True
                y[i] = lo[i]
            else:
                if hi[i] == math.inf:
                    skip = True
                y[i] = hi[i]
        if skip:
            continue
        for r in range(3):  # the fixed variables' part moved to the right-hand side
            s = -b[r]
            for q in range(3):
                is_free = False
                for f in range(k):
                    if free[f] == q:
                        is_free = True
                if not is_free:
                    s -= a[r, q] * y[q]
            rhs[r] = s
        if k and not _solve_small(a, rhs, free, k, y, work):
            continue
        for i in range(3):
            y[i] = min(max(y[i], lo[i]), hi[i])
        obj = 0.0
        for r in range(3):
            s = 0.5 * a[r, r] * y[r] + b[r]
            for q in range(r):
                s += a[r, q] * y[q]
            obj += s * y[r]
        if obj < best:
            best = obj
            x[:] = y


@njit(cache=True)
def _workspace() -> tuple[np.ndarray, ...]:
    """The work arrays of :func:`_substep`, allocated once for all the substeps of a step:
    the separations (12), the Jacobian (12 x 15), its factor (12 x 12), the rail impulses'
    responses (3 x 15), their matrix (3 x 3), float rows (11 x 15), the stops' flags (9,
    bool) and the small problems' free indices (3, int64) and matrix (3 x 4)."""
    return (
        np.empty(12), np.empty((12, 15)), np.empty((12, 12)), np.empty((3, 15)),
        np.empty((3, 3)), np.empty((11, 15)), np.empty(9, dtype=np.bool_),
        np.empty(3, dtype=np.int64), np.empty((3, 4)),
    )  # fmt: skip


@njit(cache=True)
def _substep(
    z: np.ndarray, u: np.ndarray, sd: np.ndarray, cmd: np.ndarray, h: float, rc: np.ndarray,
    minv: np.ndarray, impulses: np.ndarray, ws: tuple[np.ndarray, ...],
) -> bool:  # fmt: skip
    """One substep of ``h`` (s) of the module's scheme on ``z``, ``u`` (coordinates and
    velocities, 15 each) and the drives' setpoints ``sd`` (m), commands ``cmd`` (m/s); the
    rail impulses (N s) into ``impulses``; ``ws``: :func:`_workspace`.  False (and ``z``,
    ``u`` spoilt) if the position projection did not converge."""
    a0, stroke = rc[0:3], rc[9]
    gx, gy = rc[19], rc[20]
    fmax, max_bias, error_bias = rc[21], rc[22], rc[23]
    cs, cj = rc[24], rc[25]
    phi, jac, chol, resp, a, rows, flags, free, work = ws
    # Float rows: the solve's work (0), a column (1), the servo targets, box bounds, linear
    # term and solution (2-6), the held inverse masses (7); 8-10: the joint friction's.
    y, col, target, lo, hi, b, x, held = (
        rows[0], rows[1], rows[2], rows[3], rows[4], rows[5], rows[6], rows[7]
    )  # fmt: skip
    at_lo, at_hi, stopped = flags[0:3], flags[3:6], flags[6:9]
    # Applied forces for h: gravity, viscous friction (explicit, as pymunk's model applies it).
    wp = u[14]
    for i in range(3):
        f = rc[12] * gx - cs * u[i]
        u[i] += h * minv[i] * f
        o = 3 + 3 * i
        wl = u[o + 2]
        u[o] += h * gx
        u[o + 1] += h * gy
        u[o + 2] += h * minv[o + 2] * (-cj * wl - cj * (wl - wp))
        u[14] += h * minv[14] * cj * (wl - wp)
    u[12] += h * gx
    u[13] += h * gy
    # Velocity onto the pivots' tangent space; the rail impulses' responses p_i in it.
    _pivots(z, rc, phi, jac)
    _factor(jac, minv, chol)
    _project_velocity(jac, minv, chol, u, col, y)
    resp[:, :] = 0.0
    for i in range(3):
        resp[i, i] = minv[i]
        for r in range(12):
            col[r] = jac[r, i] * minv[i]
        _correct(jac, minv, chol, col, resp[i], y)
    scale = 0.0
    for i in range(3):
        for j in range(3):
            a[i, j] = resp[j, i]
        scale = max(scale, a[i, i])
    # Servo targets: command plus the error correction towards the setpoint (pymunk's bias).
    coef = 1.0 - error_bias**h
    for i in range(3):
        corr = min(max((sd[i] - z[i]) * coef / h, -max_bias), max_bias)
        target[i] = cmd[i] + corr
        rho = z[i] - a0[i]
        at_lo[i] = rho <= ON_STOP
        at_hi[i] = rho >= stroke - ON_STOP
        a[i, i] += SERVO_COMPLIANCE * scale
    jmax = fmax * h
    dry = rc[26] * h  # a slider's dry friction impulse (N s)
    x[:3] = 0.0
    # A slider on a stop that the chain pulls into it harder than its servo pushes away is
    # held by the stop (its servo at the limit): solved again with it held, until none is.
    stopped[:] = False
    for _ in range(4):
        for i in range(3):
            # The servo's impulse with the slider's dry friction: against the target motion
            # (either way at a target of rest), added to what holds a slider on a stop.
            t = target[i]
            shift = -dry if t > 0.0 else (dry if t < 0.0 else 0.0)
            low, high = -jmax + shift - (dry if t == 0.0 else 0.0), jmax + shift
            high += dry if t == 0.0 else 0.0
            if at_lo[i] and t <= 0.0:  # pushed into its lower stop: held there
                t, low, high = 0.0, -jmax - dry, math.inf
            elif at_hi[i] and t >= 0.0:
                t, low, high = 0.0, -math.inf, jmax + dry
            elif stopped[i]:
                t, low, high = (
                    (0.0, jmax - dry, math.inf) if at_lo[i] else (0.0, -math.inf, dry - jmax)
                )
            lo[i], hi[i] = low, high
            b[i] = u[i] - t
        _box_qp(a, b, lo, hi, x, free, y, col, work)
        again = False
        for i in range(3):
            v = u[i] + _dot3(a[i], x)
            if not stopped[i] and (
                (at_lo[i] and target[i] > 0.0 and v < 0.0)
                or (at_hi[i] and target[i] < 0.0 and v > 0.0)
            ):
                stopped[i] = again = True
        if not again:
            break
    for i in range(3):
        impulses[i] = x[i]
        for k in range(15):
            u[k] += resp[i, k] * x[i]
    if rc[27] > 0.0:
        _joint_friction(jac, minv, chol, u, rc[27] * h, rows[8], rows[9], rows[10], y)
    # Positions; a slider past a stop put on it (velocity into it removed) and held.
    for k in range(15):
        z[k] += h * u[k]
    for i in range(3):
        sd[i] += h * cmd[i]
    held[:] = minv
    for i in range(3):
        rho = z[i] - a0[i]
        if rho <= 0.0 or (at_lo[i] and rho <= ON_STOP):
            z[i] = a0[i]
            u[i] = max(u[i], 0.0)
            held[i] = 0.0
        elif rho >= stroke or (at_hi[i] and rho >= stroke - ON_STOP):
            z[i] = a0[i] + stroke
            u[i] = min(u[i], 0.0)
            held[i] = 0.0
    converged = False
    for _ in range(PIVOT_NEWTON_STEPS):
        worst = _pivots(z, rc, phi, jac)
        if not worst <= 1.0:  # (NaN too)
            return False
        if worst <= PIVOT_TOLERANCE:
            converged = True
            break
        _factor(jac, held, chol)
        _correct(jac, held, chol, phi, z, y)
    if not converged:
        return False
    _factor(jac, held, chol)
    _project_velocity(jac, held, chol, u, col, y)
    ok = True
    for k in range(15):
        ok = ok and math.isfinite(z[k]) and math.isfinite(u[k])
    return ok


@njit(cache=True)
def _joint_friction(
    jac: np.ndarray, minv: np.ndarray, chol: np.ndarray, u: np.ndarray, dry: float,
    w: np.ndarray, r: np.ndarray, col: np.ndarray, y: np.ndarray,
) -> None:  # fmt: skip
    """The revolute joints' dry friction for a substep, at most ``dry`` (N m s) each: joint
    ``B_i`` turns leg ``i`` against its (non-rotating) slider, ``C_i`` leg ``i`` against the
    platform.  One pass over the six joints, each impulse the one that stops the joint's
    relative rotation in the pivots' tangent space, clamped to ``dry``: each one removes
    kinetic energy (a sequential-impulse approximation of the coupled problem, which the
    servos' next substep corrects).  ``w``, ``r`` (15), ``col``, ``y`` (12): work arrays."""
    for joint in range(6):
        i = joint // 2
        w[:] = 0.0
        w[5 + 3 * i] = 1.0
        if joint % 2:
            w[14] = -1.0
        for k in range(15):
            r[k] = minv[k] * w[k]
        _jac_times(jac, r, col)
        _correct(jac, minv, chol, col, r, y)
        eff = 0.0
        rel = 0.0
        for k in range(15):
            eff += w[k] * r[k]
            rel += w[k] * u[k]
        if not eff > 0.0:
            continue
        j = min(max(-rel / eff, -dry), dry)
        for k in range(15):
            u[k] += r[k] * j


@njit(cache=True)
def _dot3(row: np.ndarray, x: np.ndarray) -> float:
    return row[0] * x[0] + row[1] * x[1] + row[2] * x[2]


@njit(cache=True)
def energy(v: np.ndarray, rc: np.ndarray) -> float:
    """Mechanical energy (J) of the readout ``v`` (60 body values): the bodies' kinetic energy
    (pymunk's masses and moments in ``rc``) and their potential energy in gravity."""
    gx, gy = rc[19], rc[20]
    e = 0.5 * rc[10] * (v[3] * v[3] + v[4] * v[4]) + 0.5 * rc[11] * v[5] * v[5]
    e -= rc[10] * (gx * v[0] + gy * v[1])
    for i in range(3):
        o = 6 + 18 * i
        e += 0.5 * rc[12] * v[o + 3] * v[o + 3] - rc[12] * gx * v[o]
        m = rc[13 + i]
        e += 0.5 * m * (v[o + 15] * v[o + 15] + v[o + 16] * v[o + 16])
        e += 0.5 * rc[16 + i] * v[o + 17] * v[o + 17] - m * (gx * v[o + 12] + gy * v[o + 13])
    return e


@njit(cache=True)
def excess_energy(start: np.ndarray, end: np.ndarray, dt: float, rc: np.ndarray) -> float:
    """How much more mechanical energy (J) the readout ``end`` has than ``start`` a control
    step of ``dt`` (s) before, beyond the most the servos can have done: ``max_force`` times
    each slider's path, bounded by its travel and its mean speed (the longer)."""
    work = 0.0
    for i in range(3):
        o = 6 + 18 * i
        path = max(abs(end[o] - start[o]), 0.5 * (abs(start[o + 3]) + abs(end[o + 3])) * dt)
        work += rc[21] * path
    return energy(end, rc) - energy(start, rc) - work


@njit(cache=True)
def recover(
    start: np.ndarray,
    v0: float,
    v1: float,
    v2: float,
    dt: float,
    h: float,
    rc: np.ndarray,
    out: np.ndarray,
    forces: np.ndarray,
) -> bool:
    """Take a control step of ``dt`` (s) from the readout ``start`` (60 body values, as read at
    the step's start) with the drive commands ``v0, v1, v2`` (m/s) by the module's scheme and
    the machine's numbers ``rc`` (:func:`recovery_constants`); the readout after it into
    ``out[:60]`` (drives at their new setpoints, moving at the commands) and the servos'
    summed and largest impulses into ``forces[:6]`` (N s, the largest one scaled to pymunk's
    physics step ``h``, s, so that saturation reads as in a pymunk step).  Returns False where
    no step can be taken (``out`` and ``forces`` are then not meaningful)."""
    z = np.empty(15)
    u = np.empty(15)
    minv = np.empty(15)
    sd = np.empty(3)
    cmd = np.array([v0, v1, v2])
    for i in range(3):
        o = 6 + 18 * i
        z[i], u[i] = start[o], start[o + 3]
        sd[i] = start[o + 6]
        lo = 3 + 3 * i
        for k in range(3):
            z[lo + k], u[lo + k] = start[o + 12 + k], start[o + 15 + k]
        minv[i] = 1.0 / rc[12]
        minv[lo] = minv[lo + 1] = 1.0 / rc[13 + i]
        minv[lo + 2] = 1.0 / rc[16 + i]
    for k in range(3):
        z[12 + k], u[12 + k] = start[k], start[3 + k]
    minv[12] = minv[13] = 1.0 / rc[10]
    minv[14] = 1.0 / rc[11]
    forces[:6] = 0.0
    impulses = np.zeros(3)
    # Time in units of the finest substep: a substep at level n covers 2^(MAX_HALVINGS - n).
    fine = dt / (SUBSTEPS * 2**MAX_HALVINGS)
    left = SUBSTEPS * 2**MAX_HALVINGS
    level = 0
    z0, u0, sd0 = z.copy(), u.copy(), sd.copy()
    ws = _workspace()
    while left > 0:
        units = 2 ** (MAX_HALVINGS - level)
        while units > left:
            units //= 2
            level += 1
        hs = units * fine
        z0[:] = z
        u0[:] = u
        sd0[:] = sd
        if _substep(z, u, sd, cmd, hs, rc, minv, impulses, ws):
            left -= units
            for i in range(3):
                j = abs(impulses[i])
                forces[i] += j
                j *= h / hs
                if j > forces[3 + i]:
                    forces[3 + i] = j
            if level > 0 and left % (2 * units) == 0:
                level -= 1
            continue
        z[:] = z0
        u[:] = u0
        sd[:] = sd0
        if level == MAX_HALVINGS:
            return False
        level += 1
    # The readout: platform, then slider, drive and leg of each leg.
    for k in range(3):
        out[k], out[3 + k] = z[12 + k], u[12 + k]
    for i in range(3):
        o = 6 + 18 * i
        lo = 3 + 3 * i
        out[o], out[o + 1], out[o + 2] = z[i], 0.0, start[o + 2]
        out[o + 3], out[o + 4], out[o + 5] = u[i], 0.0, 0.0
        out[o + 6], out[o + 7], out[o + 8] = sd[i], start[o + 7], start[o + 8]
        out[o + 9], out[o + 10], out[o + 11] = cmd[i], start[o + 10], start[o + 11]
        for k in range(3):
            out[o + 12 + k], out[o + 15 + k] = z[lo + k], u[lo + k]
    return True
