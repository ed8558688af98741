"""The projection over a batch of simulations, in numpy.

:class:`BatchProjector` is :meth:`planar3p_gym.sim.projection.LoopProjector.project` applied to
``N`` simulations at once (the reach step's outputs over the batch are
:class:`planar3p_gym.tasks.reach_step.BatchReach`, which compiles the single env's formulas in a
loop): every
per-simulation scalar of those functions becomes an array over the batch (legs stacked as
arrays of shape ``(3, N)``) and every operation is the same, in the same order.  Elementwise
``+ - * /`` and ``sqrt`` are correctly rounded in both, so the results are the same numbers,
bit for bit; transcendental functions (``cos``, ``sin``, ``atan2``, ``acos``, ``tanh``,
``exp``), whose numpy implementations may round differently from :mod:`math` (they do on
CPUs with AVX-512), are evaluated with :mod:`math`, element by element (:func:`_map`).  The
Newton iteration's data-dependent control flow (convergence, the restart with free sliders,
the step limits) is followed per simulation with masks: a simulation that has stopped keeps
its coordinates, and re-evaluating the loop equations at unchanged coordinates gives the
same values, so its final quantities are those it stopped with.  The rare paths off the common
one (a free slider that the correction would move past an end stop, a failed projection, a
slider above the rate limit) are detected with the same tests and those simulations are
projected by :meth:`LoopProjector.project` itself, one by one.

``tests/test_vector_env.py`` checks the native vector env, which steps through these,
against single environments, bit for bit.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from planar3p_gym.sim.physics import FOLLOWING_ERROR_LIMIT
from planar3p_gym.sim.physics import _wrap as _wrap_float
from planar3p_gym.sim.projection import (
    HELD_CONDITION,
    HELD_NEWTON_STEPS,
    MAX_CLOSURE_ERROR,
    MAX_NEWTON_STEPS,
    POSITION_TOLERANCE,
    STOP_CONTACT,
    LoopProjector,
)

__all__ = ["BatchProjector", "BatchState"]

_TWO_PI = 2.0 * math.pi


def _map(f: Any, a: np.ndarray) -> np.ndarray:
    """``f`` (a :mod:`math` function of one float) applied to every element of ``a``."""
    return np.array(list(map(f, a.ravel().tolist()))).reshape(a.shape)


def _atan2(y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """:func:`math.atan2` element by element."""
    return np.array(list(map(math.atan2, y.ravel().tolist(), x.ravel().tolist()))).reshape(y.shape)


def _wrap(angle: np.ndarray) -> np.ndarray:
    """:func:`planar3p_gym.sim.physics._wrap`: into ``(-pi, pi]`` (numpy's ``%`` on floats is
    Python's)."""
    return math.pi - (math.pi - angle) % _TWO_PI


class BatchState:
    """The projected states of a batch (arrays over the ``N`` simulations, SI units).

    Attributes:
        rho, rho_dot: ``(3, N)`` slider travels (m) and rates (m/s).
        pose: ``(3, N)``: ``x, y`` of ``G`` (m) and ``theta`` wrapped into ``(-pi, pi]``.
        twist: ``(3, N)`` velocity of ``G`` (m/s) and ``theta_dot`` (rad/s).
        leg_angles: ``(3, N)`` ``alpha_i`` (rad).
        closure: ``(N,)`` largest leg-length error (m).
        ux, uy: ``(3, N)`` leg vectors ``u_i = C_i - B_i`` (m); ``c, s``: ``(N,)``
            ``cos, sin theta``.
        finite: ``(N,)`` whether every number of the state is finite.
    """

    __slots__ = (
        "c",
        "closure",
        "finite",
        "leg_angles",
        "pose",
        "rho",
        "rho_dot",
        "s",
        "twist",
        "ux",
        "uy",
    )

    def __init__(self, **values: np.ndarray) -> None:
        for key, value in values.items():
            setattr(self, key, value)


class BatchProjector:
    """:meth:`LoopProjector.project` of ``projector`` over a batch (module docstring)."""

    def __init__(self, projector: LoopProjector) -> None:
        p = projector
        self.origins = np.array(p.origins).reshape(3, 1)
        self.r = np.array(p.r).reshape(3, 1)
        self.legs = np.array(p.legs).reshape(3, 1)
        self.ll = self.legs * self.legs
        self.ft = 2.0 * self.legs * POSITION_TOLERANCE
        self.dc, self.kq, self.stroke = p.d_centre, p.k_q, p.stroke
        self.ip, self.ii, self.free = 1.0 / p.m_platform, 1.0 / p.i_q, 1.0 / p.m_rho
        self.rate_limit, self.dt, self.reach = p.rate_limit, p.dt, p.reach
        self.scalar = p

    def project(self, buf: np.ndarray, saturated: np.ndarray) -> BatchState:
        """Project the readouts in ``buf`` (shape ``(N, >= 60)``: ``x, y, angle, vx, vy, w``
        of the bodies in readout order, one simulation a row) onto the manifold, write the
        bodies to write back into ``buf[:, :60]`` (drive setpoints pulled to within
        :data:`~planar3p_gym.sim.physics.FOLLOWING_ERROR_LIMIT` of their sliders, as
        :meth:`Planar3PSim._project` does), and return the states.  ``saturated``: ``(3, N)``
        booleans."""
        v = buf[:, :60].T.copy()  # (60, N): one contiguous row per number
        n = v.shape[1]
        a, r, legs = self.origins, self.r, self.legs
        dc, kq, stroke = self.dc, self.kq, self.stroke
        ip, ii, free = self.ip, self.ii, self.free
        inv = np.where(saturated, free, 0.0)  # (3, N) inverse masses of the sliders
        hold = ~saturated.all(axis=0)
        free_phase = ~hold  # (LoopProjector.project's free_phase)
        # Simulations whose projection leaves the common path (a slider that the correction
        # puts past an end stop, a failure, a slider above the rate limit): LoopProjector
        # itself projects them (below), so they get its numbers whatever path it takes.
        scalar = np.zeros(n, dtype=bool)

        th = v[2].copy()
        w = v[5].copy()
        c, s = _map(math.cos, th), _map(math.sin, th)
        qx, qy = v[0] - dc * c, v[1] - dc * s
        qvx, qvy = v[3] + dc * w * s, v[4] - dc * w * c
        p = v[[6, 24, 42]] - a
        d = v[[9, 27, 45]].copy()
        out = (p < 0.0) | (p > stroke)
        if out.any():  # a slider past an end stop (rare): LoopProjector's _at_stop
            for i, j in zip(*np.nonzero(out), strict=True):
                setpoint = v[12 + 18 * i, j] - a[i, 0]
                if p[i, j] < 0.0:
                    p[i, j] = -STOP_CONTACT
                    d[i, j] = 0.0 if setpoint <= 0.0 else max(d[i, j], 0.0)
                else:
                    p[i, j] = stroke + STOP_CONTACT
                    d[i, j] = 0.0 if setpoint >= stroke else min(d[i, j], 0.0)
                inv[i, j] = 0.0
            hold = hold | out.any(axis=0)
        stopped = out

        start = (p.copy(), qx.copy(), qy.copy(), th.copy(), c.copy(), s.copy())
        limit = np.where(hold & ~free_phase, HELD_NEWTON_STEPS, MAX_NEWTON_STEPS)
        steps = np.zeros(n, dtype=np.int64)
        active = np.ones(n, dtype=bool)
        roll = [1, 2, 0]
        with np.errstate(all="ignore"):
            while True:
                x = qx + r * c - a - p
                y = qy + r * s
                xx = x * x
                nn = xx + y * y
                f = nn - self.ll
                t = r * (y * c - x * s)
                g = xx * inv + nn * ip + t * t * ii  # g11, g22, g33
                # g12, g23, g13 (x3 x1 = x1 x3: products commute exactly)
                o = (x * x[roll] + y * y[roll]) * ip + t * t[roll] * ii
                g11, g22, g33 = g
                g12, g23, g13 = o
                h11 = g22 * g33 - g23 * g23
                h12 = g13 * g23 - g12 * g33
                h13 = g12 * g23 - g13 * g22
                det = g11 * h11 + g12 * h12 + g13 * h13
                converged = ((-self.ft <= f) & (f <= self.ft)).all(axis=0)
                trigger = (
                    active
                    & hold
                    & ((det <= HELD_CONDITION * g11 * g22 * g33) | (~converged & (steps >= limit)))
                )
                restart = trigger & ~free_phase
                # A failure, or a converged correction with a free slider past an end stop.
                leave = (trigger & free_phase) | (
                    active
                    & ~trigger
                    & converged
                    & ((inv != 0.0) & ((p < 0.0) | (p > stroke))).any(axis=0)
                )
                if leave.any():
                    scalar |= leave
                    active = active & ~leave
                if restart.any():
                    p0, qx0, qy0, th0, c0, s0 = start
                    p = np.where(restart, p0, p)
                    qx, qy = np.where(restart, qx0, qx), np.where(restart, qy0, qy)
                    th = np.where(restart, th0, th)
                    c, s = np.where(restart, c0, c), np.where(restart, s0, s)
                    inv = np.where(restart, np.where(stopped, 0.0, free), inv)
                    hold = np.where(restart, stopped.any(axis=0), hold)
                    free_phase = free_phase | restart
                    limit = np.where(restart, steps + MAX_NEWTON_STEPS, limit)
                active = active & (restart | ~(converged | (steps >= limit) | (det <= 0.0)))
                move = active & ~restart
                if not move.any():
                    if active.any():
                        continue
                    break
                h22 = g11 * g33 - g13 * g13
                h23 = g12 * g13 - g11 * g23
                h33 = g11 * g22 - g12 * g12
                k = 0.5 / det
                f1, f2, f3 = f
                m = np.stack(
                    (
                        (h11 * f1 + h12 * f2 + h13 * f3) * k,
                        (h12 * f1 + h22 * f2 + h23 * f3) * k,
                        (h13 * f1 + h23 * f2 + h33 * f3) * k,
                    )
                )
                xm, ym, tm = x * m, y * m, t * m
                p = np.where(move, p + xm * inv, p)
                qx = np.where(move, qx - (xm[0] + xm[1] + xm[2]) * ip, qx)
                qy = np.where(move, qy - (ym[0] + ym[1] + ym[2]) * ip, qy)
                th_new = th - (tm[0] + tm[1] + tm[2]) * ii
                moved = np.nonzero(move)[0]
                th = np.where(move, th_new, th)
                c, s = c.copy(), s.copy()
                c[moved] = _map(math.cos, th[moved])
                s[moved] = _map(math.sin, th[moved])
                steps += move
            root = np.sqrt(nn)
            err = np.abs(root - legs)
            closure = np.maximum(np.maximum(err[0], err[1]), err[2])
            # LoopProjector.project's failure tests: closure, det, the reach of each slider
            # from its drive's setpoint at the start of the step.
            was = v[[12, 30, 48]] - a - v[[15, 33, 51]] * self.dt
            scalar |= (
                ~(closure <= MAX_CLOSURE_ERROR)
                | (det <= 0.0)
                | ~(np.abs(p - was) <= self.reach).all(axis=0)
            )

            # Velocities onto the tangent space where det > 0.
            h22 = g11 * g33 - g13 * g13
            h23 = g12 * g13 - g11 * g23
            h33 = g11 * g22 - g12 * g12
            k = 1.0 / det
            j = (qvx - d) * x + qvy * y + w * t
            j1, j2, j3 = j
            m = np.stack(
                (
                    (h11 * j1 + h12 * j2 + h13 * j3) * k,
                    (h12 * j1 + h22 * j2 + h23 * j3) * k,
                    (h13 * j1 + h23 * j2 + h33 * j3) * k,
                )
            )
            xm, ym, tm = x * m, y * m, t * m
            ok = det > 0.0
            d = np.where(ok, d + xm * inv, d)
            qvx = np.where(ok, qvx - (xm[0] + xm[1] + xm[2]) * ip, qvx)
            qvy = np.where(ok, qvy - (ym[0] + ym[1] + ym[2]) * ip, qvy)
            w = np.where(ok, w - (tm[0] + tm[1] + tm[2]) * ii, w)
            limit_ = self.rate_limit
            scalar |= ~((-limit_ <= d) & (d <= limit_)).all(axis=0)

            ws, wc = w * s, w * c
            b = a + p
            cx, cy = qvx - r * ws, qvy + r * wc
            al = _atan2(y, x)
            rows = np.empty((60, n))
            rows[0], rows[1], rows[2] = qx + dc * c, qy + dc * s, th
            rows[3], rows[4], rows[5] = qvx - dc * ws, qvy + dc * wc, w
            for i, o in enumerate((6, 24, 42)):
                rows[o] = b[i]
                rows[o + 1] = 0.0
                rows[o + 2] = v[o + 2]
                rows[o + 3] = d[i]
                rows[o + 4] = 0.0
                rows[o + 5] = 0.0
                rows[o + 6 : o + 12] = v[o + 6 : o + 12]
                rows[o + 12] = b[i] + 0.5 * x[i]
                rows[o + 13] = 0.5 * y[i]
                rows[o + 14] = al[i]
                rows[o + 15] = 0.5 * (d[i] + cx[i])
                rows[o + 16] = 0.5 * cy[i]
                rows[o + 17] = (x[i] * cy[i] - y[i] * (cx[i] - d[i])) / nn[i]
            pose = np.stack((qx - kq * c, qy - kq * s, _wrap(th)))
            twist = np.stack((qvx + kq * ws, qvy - kq * wc, w))
            for j in np.nonzero(scalar)[0].tolist():
                pr = self.scalar.project(
                    v[:, j].tolist(), tuple(bool(b) for b in saturated[:, j].tolist())
                )
                rows[:, j] = pr.bodies
                p[:, j], d[:, j], al[:, j], twist[:, j] = (
                    pr.rho,
                    pr.rho_dot,
                    pr.leg_angles,
                    pr.twist,
                )
                pose[:, j] = (pr.pose[0], pr.pose[1], _wrap_float(pr.pose[2]))
                closure[j] = pr.closure_error
                x1, y1, x2, y2, x3, y3, c[j], s[j] = pr.geometry
                x[:, j], y[:, j] = (x1, x2, x3), (y1, y2, y3)
            # Drive setpoints within the following-error limit of their sliders.
            for o in (12, 30, 48):
                slider_x = rows[o - 6]
                ahead = rows[o] - slider_x > FOLLOWING_ERROR_LIMIT
                behind = ~ahead & (slider_x - rows[o] > FOLLOWING_ERROR_LIMIT)
                rows[o] = np.where(
                    ahead,
                    slider_x + FOLLOWING_ERROR_LIMIT,
                    np.where(behind, slider_x - FOLLOWING_ERROR_LIMIT, rows[o]),
                )
            buf[:, :60] = rows.T
            total = (
                p.sum(axis=0)
                + d.sum(axis=0)
                + pose.sum(axis=0)
                + twist.sum(axis=0)
                + al.sum(axis=0)
                + closure
            )
        return BatchState(
            rho=p,
            rho_dot=d,
            pose=pose,
            twist=twist,
            leg_angles=al,
            closure=closure,
            ux=x,
            uy=y,
            c=c,
            s=s,
            finite=np.isfinite(total),
        )
