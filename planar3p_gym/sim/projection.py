"""Post-stabilisation: put a simulated state exactly back on the mechanism's constraint manifold.

After each pymunk step the closed chain is slightly open and its velocities slightly violate
the joints; :class:`LoopProjector` removes both by a mass-weighted projection (the derivation,
the end stops, the rate limit and when it fails: docs/physics.md, "How the simulation modules
work").

* :func:`project_readout`: the one definition (plain floats, compiled by numba): Newton steps
  of the minimal correction on the three loop equations, velocities onto their tangent space,
  end stops held, slider rates limited, legs rebuilt;
* :class:`LoopProjector` / :func:`project_in_place`: it for one simulation; :func:`project_row`
  for one row of a batch (the native vector env's compiled step);
* :class:`Projected`: the result; ``closure_error`` is ``inf`` where no closed state near the
  simulated one exists (the environments end the episode with ``"physics_breakdown"``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.machine.design import Design

__all__ = [
    "HELD_CONDITION",
    "HELD_NEWTON_STEPS",
    "MAX_CLOSURE_ERROR",
    "MAX_NEWTON_STEPS",
    "POSITION_TOLERANCE",
    "RATE_ALLOWANCE",
    "RECOVERY_OFFSET",
    "STOP_CONTACT",
    "LoopProjector",
    "Projected",
    "project_in_place",
    "project_readout",
    "project_row",
]

#: Leg-length error (m) below which the position projection stops.
POSITION_TOLERANCE = 1e-11
#: Largest leg-length error (m) a successful projection leaves; a larger one (Newton has not
#: converged) makes the projection fail (:attr:`Projected.closure_error` is then ``inf``).
MAX_CLOSURE_ERROR = 1e-9
#: Slider rates above the servos' ``max_speed`` that the projection allows, in units of
#: ``max_speed``: the rate limit is ``(1 + RATE_ALLOWANCE) max_speed`` (1 m/s on the default
#: design).  A servo drives its slider at most at ``max_speed`` plus its following-error
#: correction (0.02 m/s); a saturated servo's slider is moved faster by the chain when a leg
#: stops against an end stop or near a parallel singularity (the unprojected model,
#: ``Planar3P-v0``, reaches 3.5 ``max_speed`` in 300 000 random and bang-bang steps).
RATE_ALLOWANCE = 4.0
#: A slider past an end stop is put back this far into it (m): touching, so the stop keeps
#: holding it during the next step.
STOP_CONTACT = 1e-9
#: Largest number of Newton steps of one position projection.
MAX_NEWTON_STEPS = 8
#: Newton steps allowed with servo-held sliders fixed before starting again with every slider
#: free (near a fold of the direct kinematics the held travels may have no pose nearby).
HELD_NEWTON_STEPS = 4
#: Where the constrained-dynamics numbers start in :attr:`LoopProjector.constants` (a 1.0
#: there, then the solver iterations to restore, the warm-start iterations, the energy slack
#: (J) and :func:`planar3p_gym.sim.recovery.recovery_constants`); shorter: no recovery.
RECOVERY_OFFSET = 24
#: Smallest ``det(G) / (G_11 G_22 G_33)`` of ``G = J W^-1 J^T`` with the servo-held sliders
#: fixed; below it (close to a parallel singularity, where it vanishes like the square of
#: ``det A``) the held sliders take their share of the correction.
HELD_CONDITION = 1e-6


class Projected(NamedTuple):
    """The state on the manifold (SI units).

    Attributes:
        bodies: ``x, y, angle, vx, vy, angular velocity`` of every body in the simulation's
            readout order (platform, then slider, drive and leg of each leg), to write back.
        rho: slider travels (m).
        rho_dot: travel rates (m/s).
        pose: ``(x, y, theta)`` of the gripper ``G`` (m, m, rad; ``theta`` not wrapped).
        twist: ``(x_dot, y_dot, theta_dot)`` of ``G`` (m/s, m/s, rad/s).
        leg_angles: ``alpha_i = atan2(u_iy, u_ix)`` (rad, in ``(-pi, pi]``).
        closure_error: largest leg-length error ``| |C_i - B_i| - L_i |`` after the projection
            (m); the joints at ``B_i`` and the rails are closed exactly by construction.
            ``inf`` when the projection failed (module docstring, "Failure").
        newton_steps: position Newton steps taken.
        geometry: ``(u_1x, u_1y, u_2x, u_2y, u_3x, u_3y, cos theta, sin theta)``: the leg
            vectors ``u_i = C_i - B_i`` (m) at the projected pose (what the configuration
            measures and the observation are computed from on the fast paths).
    """

    bodies: list[float]
    rho: tuple[float, float, float]
    rho_dot: tuple[float, float, float]
    pose: tuple[float, float, float]
    twist: tuple[float, float, float]
    leg_angles: tuple[float, float, float]
    closure_error: float
    newton_steps: int
    geometry: tuple[float, float, float, float, float, float, float, float]


@njit(cache=True)
def _at_stop(
    travel: float, rate: float, setpoint: float, stroke: float
) -> tuple[float, float, float]:
    """A slider found past an end of its stroke: ``(travel, rate, inverse mass)`` put back just
    into the stop (:data:`STOP_CONTACT`, m) and held (inverse mass 0).  It is at rest while its
    servo's ``setpoint`` (m) is beyond the stop (pushing into it), else it keeps only its
    velocity away from the stop (m/s)."""
    if travel < 0.0:
        return -STOP_CONTACT, (0.0 if setpoint <= 0.0 else max(rate, 0.0)), 0.0
    return stroke + STOP_CONTACT, (0.0 if setpoint >= stroke else min(rate, 0.0)), 0.0


class LoopProjector:
    """Mass-weighted projection of a simulated 3-PRR state onto its constraint manifold.

    Args:
        design: the machine (its masses give the metric, its geometry the loop equations).
        dt: the control period (s) of the simulation whose readouts are projected; with it,
            a projection that leaves a slider farther from where it was at the start of the
            step than the rate limit allows fails (module docstring, "Failure").  ``None``
            (the default): no such check (for readouts that are not simulation steps).
        following_error: the largest distance (m) between a slider and its drive's setpoint
            at the start of a step (the simulation's
            :data:`~planar3p_gym.physics.FOLLOWING_ERROR_LIMIT`); with ``dt``, where a slider
            was is known from its drive to within it.
        recovery: the simulation's constrained-dynamics numbers for the steps whose
            projection fails (:data:`RECOVERY_OFFSET`; needs ``dt``); ``None``: no recovery.
    """

    def __init__(
        self,
        design: Design,
        dt: float | None = None,
        following_error: float = 0.0,
        recovery: np.ndarray | None = None,
    ) -> None:
        self.design = design
        k = design.joint_offsets
        m_leg, m_p = design.leg_mass, design.platform_mass
        half = 0.5 * k[0]  # platform centre of mass, from G along e (m)
        lump = 0.5 * m_leg
        self.m_rho = design.slider_mass + lump
        self.m_platform = m_p + 3.0 * lump
        # Reference point Q: centre of mass of the platform and the three lumped half-legs.
        self.k_q = (m_p * half + lump * (k[0] + k[1] + k[2])) / self.m_platform
        self.r = tuple(ki - self.k_q for ki in k)
        self.d_centre = half - self.k_q  # platform centre from Q along e (m)
        self.i_q = (
            m_p * k[0] * k[0] / 12.0
            + m_p * self.d_centre * self.d_centre
            + lump * sum(ri * ri for ri in self.r)
        )
        self.legs = design.leg_lengths
        self.origins = design.rail_origins
        self.stroke = design.stroke
        #: Largest slider rate the projection leaves (m/s, :data:`RATE_ALLOWANCE`).
        self.rate_limit = (1.0 + RATE_ALLOWANCE) * design.max_speed
        #: The control period (s; 0 without one) and the farthest (m) a slider may end from
        #: its drive's setpoint at the start of the step (``inf``: no check).
        self.dt = 0.0 if dt is None else float(dt)
        self.reach = math.inf if dt is None else float(following_error) + self.rate_limit * self.dt
        l1, l2, l3 = self.legs
        #: The numbers :func:`project_readout` reads (its argument ``consts``).
        self.constants = np.array(
            [
                *self.origins, *self.r, *self.legs, l1 * l1, l2 * l2, l3 * l3,
                # Convergence test on f_i = |u_i|^2 - L_i^2 ~ 2 L_i (|u_i| - L_i).
                *(2.0 * li * POSITION_TOLERANCE for li in self.legs),
                self.d_centre, self.k_q, self.stroke, 1.0 / self.m_platform, 1.0 / self.i_q,
                1.0 / self.m_rho, self.rate_limit, self.dt, self.reach,
                *(() if recovery is None or dt is None else (1.0, *recovery)),
            ]
        )  # fmt: skip
        self.constants.flags.writeable = False
        #: The state array of the last :meth:`project` (:func:`project_readout`'s 23 values,
        #: theta not wrapped): what the fused reach step's compiled outputs read
        #: (:func:`planar3p_gym.tasks.reach_step.reach_outputs`).  Replaced by each call.
        self.last_state = np.zeros(23)

    def project(
        self,
        v: list[float],
        saturated: tuple[bool, bool, bool] = (True, True, True),
        setpoint_limit: float = math.inf,
    ) -> Projected:
        """Project the readout ``v`` (60 numbers: ``x, y, angle, vx, vy, w`` of the 10 bodies
        in readout order) onto the manifold; returns the new body values and the state.

        ``saturated[i]`` says whether servo ``i`` was at its force limit (its slider then
        moves with its own mass; otherwise its servo holds it, see the module docstring).
        Drive setpoints are left within ``setpoint_limit`` (m) of their sliders."""
        out, st, closure, steps = project_readout(
            np.asarray(v, dtype=np.float64),
            bool(saturated[0]),
            bool(saturated[1]),
            bool(saturated[2]),
            self.constants,
            float(setpoint_limit),
        )
        self.last_state = st
        s = st.tolist()
        return Projected(
            out.tolist(),
            (s[0], s[1], s[2]),
            (s[3], s[4], s[5]),
            (s[6], s[7], s[8]),
            (s[9], s[10], s[11]),
            (s[12], s[13], s[14]),
            float(closure),
            int(steps),
            (s[15], s[16], s[17], s[18], s[19], s[20], s[21], s[22]),
        )

    def project_in_place(
        self, v: np.ndarray, s0: bool, s1: bool, s2: bool, setpoint_limit: float
    ) -> tuple[np.ndarray, float]:
        """:meth:`project` of the readout array ``v`` (float64, at least 60 numbers), writing
        the bodies to write back into ``v[:60]`` itself; returns the state array
        (:func:`project_readout`'s 23 values, also kept as :attr:`last_state`) and the
        closure error (m).  ``s0, s1, s2``: the servo saturation flags."""
        st, closure = project_in_place(v, s0, s1, s2, self.constants, setpoint_limit)
        self.last_state = st
        return st, closure


@njit(cache=True)
def _leg_rows(
    qx: float, qy: float, c: float, s: float, r: float, a: float, p: float, ll: float
) -> tuple[float, float, float, float, float, float]:
    """One leg's terms of :func:`project_readout`'s Newton step, from the reference point
    ``(qx, qy)`` and ``(cos, sin)`` of theta, the joint's offset ``r`` and rail origin ``a``,
    the travel ``p`` and the squared leg length ``ll``: the leg vector ``(x, y)``, ``x^2``,
    ``|u|^2``, the residual ``|u|^2 - L^2`` and ``t = r (y cos - x sin)``."""
    x, y = qx + r * c - a - p, qy + r * s
    xx = x * x
    n = xx + y * y
    return x, y, xx, n, n - ll, r * (y * c - x * s)


@njit(cache=True)
def project_readout(
    v: np.ndarray, s0: bool, s1: bool, s2: bool, consts: np.ndarray, setpoint_limit: float
) -> tuple[np.ndarray, np.ndarray, float, int]:
    """:meth:`LoopProjector.project` of one readout ``v`` (60 float64) with the projector's
    constants ``consts`` (:attr:`LoopProjector.constants`), the servo saturation flags and the
    largest distance (m) a drive's setpoint may be left from its slider (``inf``: none).

    Returns ``(bodies, state, closure_error, newton_steps)``: the 60 body values to write back,
    and ``state`` = ``rho``, ``rho_dot``, ``pose`` (theta not wrapped), ``twist``, leg angles and
    the geometry ``(u_1x, u_1y, u_2x, u_2y, u_3x, u_3y, cos theta, sin theta)`` (23 values).
    """
    a1, a2, a3, r1, r2, r3 = consts[0], consts[1], consts[2], consts[3], consts[4], consts[5]
    l1, l2, l3, ll1, ll2, ll3 = consts[6], consts[7], consts[8], consts[9], consts[10], consts[11]
    ft1, ft2, ft3, dc, kq, stroke = (
        consts[12], consts[13], consts[14], consts[15], consts[16], consts[17]
    )  # fmt: skip
    ip, ii, free, rate_limit, dt, reach = (
        consts[18], consts[19], consts[20], consts[21], consts[22], consts[23]
    )  # fmt: skip
    i1 = free if s0 else 0.0
    i2 = free if s1 else 0.0
    i3 = free if s2 else 0.0
    hold = i1 == 0.0 or i2 == 0.0 or i3 == 0.0

    px, py, th, pvx, pvy, w = v[0], v[1], v[2], v[3], v[4], v[5]
    c, s = math.cos(th), math.sin(th)
    qx, qy = px - dc * c, py - dc * s
    qvx, qvy = pvx + dc * w * s, pvy - dc * w * c
    p1, p2, p3 = v[6] - a1, v[24] - a2, v[42] - a3
    d1, d2, d3 = v[9], v[27], v[45]
    # Whether every servo-held slider has been freed (no restart left); which sliders sit
    # on an end stop (held there for the rest of the projection).
    free_phase = not hold
    stop1 = stop2 = stop3 = False
    if not (0.0 <= p1 <= stroke and 0.0 <= p2 <= stroke and 0.0 <= p3 <= stroke):
        # A slider past an end stop (rare path): into the stop and held (the argument
        # after its rate is its servo's setpoint).
        if p1 < 0.0 or p1 > stroke:
            p1, d1, i1 = _at_stop(p1, d1, v[12] - a1, stroke)
            stop1 = True
        if p2 < 0.0 or p2 > stroke:
            p2, d2, i2 = _at_stop(p2, d2, v[30] - a2, stroke)
            stop2 = True
        if p3 < 0.0 or p3 > stroke:
            p3, d3, i3 = _at_stop(p3, d3, v[48] - a3, stroke)
            stop3 = True
        hold = True

    # All three held: the rho block of J W^-1 J^T and the travel updates vanish; skipping
    # them gives the same numbers (0 * x added to a float leaves it unchanged).
    held3 = i1 == 0.0 and i2 == 0.0 and i3 == 0.0
    start = (p1, p2, p3, qx, qy, th, c, s)
    # (Held only by the end stops: the steps of the last attempt.)
    limit = HELD_NEWTON_STEPS if hold and not free_phase else MAX_NEWTON_STEPS
    steps = 0
    failed = False
    while True:
        # Leg vectors u_i = C_i - B_i, |u_i|^2 and the loop residuals f_i = |u_i|^2 - L_i^2;
        # row i of J: -x_i at rho_i, then (x_i, y_i, t_i); G = J W^-1 J^T (symmetric).
        x1, y1, xx1, n1, f1, t1 = _leg_rows(qx, qy, c, s, r1, a1, p1, ll1)
        x2, y2, xx2, n2, f2, t2 = _leg_rows(qx, qy, c, s, r2, a2, p2, ll2)
        x3, y3, xx3, n3, f3, t3 = _leg_rows(qx, qy, c, s, r3, a3, p3, ll3)
        if held3:  # every slider held (the usual case): x_i^2 i_i = 0 drops out exactly
            g11 = n1 * ip + t1 * t1 * ii
            g22 = n2 * ip + t2 * t2 * ii
            g33 = n3 * ip + t3 * t3 * ii
        else:
            g11 = xx1 * i1 + n1 * ip + t1 * t1 * ii
            g22 = xx2 * i2 + n2 * ip + t2 * t2 * ii
            g33 = xx3 * i3 + n3 * ip + t3 * t3 * ii
        g12 = (x1 * x2 + y1 * y2) * ip + t1 * t2 * ii
        g13 = (x1 * x3 + y1 * y3) * ip + t1 * t3 * ii
        g23 = (x2 * x3 + y2 * y3) * ip + t2 * t3 * ii
        # Adjugate and determinant (G is positive definite where J has full rank).
        h11 = g22 * g33 - g23 * g23
        h12 = g13 * g23 - g12 * g33
        h13 = g12 * g23 - g13 * g22
        det = g11 * h11 + g12 * h12 + g13 * h13
        converged = -ft1 <= f1 <= ft1 and -ft2 <= f2 <= ft2 and -ft3 <= f3 <= ft3
        if hold and (det <= HELD_CONDITION * g11 * g22 * g33 or (not converged and steps >= limit)):
            if free_phase:
                # Only sliders on their end stops are held, and the platform with the free
                # sliders cannot close the loop with them there: the projection fails.
                failed = True
                break
            # Too close to a parallel singularity for the platform alone (or no pose near
            # for the held travels): start again with every slider free but those on an
            # end stop.
            p1, p2, p3, qx, qy, th, c, s = start
            i1 = 0.0 if stop1 else free
            i2 = 0.0 if stop2 else free
            i3 = 0.0 if stop3 else free
            hold = stop1 or stop2 or stop3
            held3 = stop1 and stop2 and stop3
            free_phase = True
            limit = steps + MAX_NEWTON_STEPS
            continue
        if converged and (
            (i1 != 0.0 and not 0.0 <= p1 <= stroke)
            or (i2 != 0.0 and not 0.0 <= p2 <= stroke)
            or (i3 != 0.0 and not 0.0 <= p3 <= stroke)
        ):
            # The end stops are constraints of the projection: a free slider that the
            # correction put past a stop is fixed at the stop (velocity into it removed,
            # :func:`_at_stop`) and the correction solved again from the start with it held.
            e1, e2, e3, qx, qy, th, c, s = start
            if i1 != 0.0 and not 0.0 <= p1 <= stroke:
                e1, d1, i1 = _at_stop(p1, d1, v[12] - a1, stroke)
                stop1 = True
            if i2 != 0.0 and not 0.0 <= p2 <= stroke:
                e2, d2, i2 = _at_stop(p2, d2, v[30] - a2, stroke)
                stop2 = True
            if i3 != 0.0 and not 0.0 <= p3 <= stroke:
                e3, d3, i3 = _at_stop(p3, d3, v[48] - a3, stroke)
                stop3 = True
            start = (e1, e2, e3, qx, qy, th, c, s)
            p1, p2, p3 = e1, e2, e3
            hold = True
            held3 = i1 == 0.0 and i2 == 0.0 and i3 == 0.0
            limit = steps + (MAX_NEWTON_STEPS if free_phase else HELD_NEWTON_STEPS)
            continue
        if converged or steps >= limit or det <= 0.0:
            break
        h22 = g11 * g33 - g13 * g13
        h23 = g12 * g13 - g11 * g23
        h33 = g11 * g22 - g12 * g12
        # lambda = G^-1 f / 2, dq = -W^-1 J^T lambda.
        k = 0.5 / det
        m1 = (h11 * f1 + h12 * f2 + h13 * f3) * k
        m2 = (h12 * f1 + h22 * f2 + h23 * f3) * k
        m3 = (h13 * f1 + h23 * f2 + h33 * f3) * k
        if not held3:
            p1 += x1 * m1 * i1
            p2 += x2 * m2 * i2
            p3 += x3 * m3 * i3
        qx -= (x1 * m1 + x2 * m2 + x3 * m3) * ip
        qy -= (y1 * m1 + y2 * m2 + y3 * m3) * ip
        th -= (t1 * m1 + t2 * m2 + t3 * m3) * ii
        c, s = math.cos(th), math.sin(th)
        steps += 1
    closure = max(abs(math.sqrt(n1) - l1), abs(math.sqrt(n2) - l2), abs(math.sqrt(n3) - l3))
    if (
        failed
        or not closure <= MAX_CLOSURE_ERROR
        or det <= 0.0
        # Each slider within reach of where it was at the start of the step: its drive's
        # setpoint then (now less the commanded velocity times dt).
        or not abs(p1 - (v[12] - a1 - v[15] * dt)) <= reach
        or not abs(p2 - (v[30] - a2 - v[33] * dt)) <= reach
        or not abs(p3 - (v[48] - a3 - v[51] * dt)) <= reach
    ):
        # No closed state with the sliders on their stroke near the simulated one: the
        # step is reported as failed (closure error inf, a physics breakdown), with every
        # travel put within its stroke and the velocities left as simulated.
        failed = True
        closure = math.inf
        if not 0.0 <= p1 <= stroke:
            p1, d1, i1 = _at_stop(p1, d1, v[12] - a1, stroke)
        if not 0.0 <= p2 <= stroke:
            p2, d2, i2 = _at_stop(p2, d2, v[30] - a2, stroke)
        if not 0.0 <= p3 <= stroke:
            p3, d3, i3 = _at_stop(p3, d3, v[48] - a3, stroke)
        x1, y1, _, n1, _, _ = _leg_rows(qx, qy, c, s, r1, a1, p1, ll1)
        x2, y2, _, n2, _, _ = _leg_rows(qx, qy, c, s, r2, a2, p2, ll2)
        x3, y3, _, n3, _, _ = _leg_rows(qx, qy, c, s, r3, a3, p3, ll3)
    else:
        # Velocities: q_dot' = q_dot - W^-1 J^T G^-1 J q_dot, with J at the projected q.
        h22 = g11 * g33 - g13 * g13
        h23 = g12 * g13 - g11 * g23
        h33 = g11 * g22 - g12 * g12
        k = 1.0 / det
        j1 = (qvx - d1) * x1 + qvy * y1 + w * t1
        j2 = (qvx - d2) * x2 + qvy * y2 + w * t2
        j3 = (qvx - d3) * x3 + qvy * y3 + w * t3
        m1 = (h11 * j1 + h12 * j2 + h13 * j3) * k
        m2 = (h12 * j1 + h22 * j2 + h23 * j3) * k
        m3 = (h13 * j1 + h23 * j2 + h33 * j3) * k
        d1 += x1 * m1 * i1
        d2 += x2 * m2 * i2
        d3 += x3 * m3 * i3
        qvx -= (x1 * m1 + x2 * m2 + x3 * m3) * ip
        qvy -= (y1 * m1 + y2 * m2 + y3 * m3) * ip
        w -= (t1 * m1 + t2 * m2 + t3 * m3) * ii
    if not (
        -rate_limit <= d1 <= rate_limit
        and -rate_limit <= d2 <= rate_limit
        and -rate_limit <= d3 <= rate_limit
    ):
        # A slider faster than the servos and the stops allow: the velocities scaled down
        # as a whole (still tangent to the manifold; the kinetic energy only falls).
        top = max(abs(d1), abs(d2), abs(d3))
        k = rate_limit / top if rate_limit < top < math.inf else 0.0
        d1, d2, d3, qvx, qvy, w = d1 * k, d2 * k, d3 * k, qvx * k, qvy * k, w * k

    # Bodies from the projected coordinates.  Leg i: midpoint of B_i C_i, along u_i, the
    # rigid motion of its two ends (B_i moves at (d_i, 0), C_i at Q_dot + r_i w e_perp).
    ws, wc = w * s, w * c  # theta_dot e_perp = (-ws, wc)
    b1, b2, b3 = a1 + p1, a2 + p2, a3 + p3
    c1x, c1y = qvx - r1 * ws, qvy + r1 * wc
    c2x, c2y = qvx - r2 * ws, qvy + r2 * wc
    c3x, c3y = qvx - r3 * ws, qvy + r3 * wc
    al1, al2, al3 = math.atan2(y1, x1), math.atan2(y2, x2), math.atan2(y3, x3)
    # (Element by element, not one 60-entry array literal: the same numbers, and numba
    # compiles it in a fraction of the time.)
    out = np.empty(60)
    out[0], out[1], out[2] = qx + dc * c, qy + dc * s, th
    out[3], out[4], out[5] = qvx - dc * ws, qvy + dc * wc, w
    bs, ds, xs, ys, als = (b1, b2, b3), (d1, d2, d3), (x1, x2, x3), (y1, y2, y3), (al1, al2, al3)
    cxs, cys, ns = (c1x, c2x, c3x), (c1y, c2y, c3y), (n1, n2, n3)
    for leg in range(3):  # (offsets computed, not literals: one compiled _leg_bodies, not three)
        _leg_bodies(
            out, 6 + 18 * leg, v, bs[leg], ds[leg], xs[leg], ys[leg], als[leg], cxs[leg],
            cys[leg], ns[leg],
        )  # fmt: skip
    # Drive setpoints (x at 12, 30, 48) within ``setpoint_limit`` of their sliders (6 before).
    for o in (12, 30, 48):
        if out[o] - out[o - 6] > setpoint_limit:
            out[o] = out[o - 6] + setpoint_limit
        elif out[o - 6] - out[o] > setpoint_limit:
            out[o] = out[o - 6] - setpoint_limit
    state = np.empty(23)
    state[0], state[1], state[2], state[3], state[4], state[5] = p1, p2, p3, d1, d2, d3
    state[6], state[7], state[8] = qx - kq * c, qy - kq * s, th
    state[9], state[10], state[11] = qvx + kq * ws, qvy - kq * wc, w
    state[12], state[13], state[14] = al1, al2, al3
    state[15], state[16], state[17], state[18], state[19], state[20] = x1, y1, x2, y2, x3, y3
    state[21], state[22] = c, s
    return out, state, closure, steps


@njit(cache=True)
def _leg_bodies(
    out: np.ndarray, o: int, v: np.ndarray, b: float, d: float, x: float, y: float,
    al: float, cx: float, cy: float, n: float,
) -> None:  # fmt: skip
    """A leg's 18 body values of :func:`project_readout` into ``out[o:o + 18]``: its slider
    at ``(b, 0)`` moving at ``d`` (m, m/s; the angle as read), its drive as read from ``v``,
    and its leg: the midpoint of ``B_i C_i`` (leg vector ``(x, y)``, angle ``al``, squared
    length ``n``), the mean of its ends' velocities (``C_i`` at ``(cx, cy)``) and its angular
    velocity."""
    out[o], out[o + 1], out[o + 2], out[o + 3], out[o + 4], out[o + 5] = (
        b, 0.0, v[o + 2], d, 0.0, 0.0
    )  # fmt: skip
    for q in range(o + 6, o + 12):
        out[q] = v[q]
    out[o + 12], out[o + 13], out[o + 14] = b + 0.5 * x, 0.5 * y, al
    out[o + 15], out[o + 16] = 0.5 * (d + cx), 0.5 * cy
    out[o + 17] = (x * cy - y * (cx - d)) / n


@njit(cache=True)
def project_in_place(
    v: np.ndarray, s0: bool, s1: bool, s2: bool, consts: np.ndarray, setpoint_limit: float
) -> tuple[np.ndarray, float]:
    """:func:`project_readout` of ``v[:60]`` with the bodies written back into ``v[:60]``:
    ``(state, closure_error)``."""
    out, state, closure, _ = project_readout(v, s0, s1, s2, consts, setpoint_limit)
    for k in range(60):
        v[k] = out[k]
    return state, closure


@njit(cache=True)
def project_row(
    readout: np.ndarray,
    s0: bool,
    s1: bool,
    s2: bool,
    consts: np.ndarray,
    setpoint_limit: float,
    states: np.ndarray,
    closure: np.ndarray,
    k: int,
) -> None:
    """:func:`project_readout` of ``readout[:60]`` for a batch: the bodies written back into
    ``readout[:60]``, the state into column ``k`` of ``states`` (theta wrapped into
    ``(-pi, pi]``, as :class:`~planar3p_gym.sim.physics.SimState` holds it) and the closure
    error (m) into ``closure[k]``."""
    out, state, err, _ = project_readout(readout, s0, s1, s2, consts, setpoint_limit)
    readout[:60] = out
    state[8] = wrap_angle(state[8])
    states[:, k] = state
    closure[k] = err
