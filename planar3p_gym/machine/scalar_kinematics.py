"""Single-configuration kinematic measures in plain Python floats, for the simulation loop.

The vectorised functions of :mod:`planar3p_gym.machine.kinematics` are the reference; these give the
same numbers (tests check the agreement) without numpy's per-call overhead, which dominates
for one 3x3 configuration per control step.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from planar3p_gym.machine.design import Design

__all__ = ["ConfigurationMeasures", "ScalarKinematics"]


class ConfigurationMeasures(NamedTuple):
    """Singularity measures of one configuration.

    Attributes:
        parallel_margin: inverse condition number of ``A_bar`` in ``[0, 1]``.
        serial_margin: ``min_i |cos alpha_i|`` in ``[0, 1]``.
        det_sign: ``sign(det A)``: +1, -1, or 0 exactly at a parallel singularity.
        leg_angles: ``alpha_i`` (rad).
    """

    parallel_margin: float
    serial_margin: float
    det_sign: int
    leg_angles: tuple[float, float, float]


class ScalarKinematics:
    """Measures of single configurations of ``design`` (see :class:`ConfigurationMeasures`)."""

    def __init__(self, design: Design) -> None:
        self.design = design
        self._k = design.joint_offsets
        self._legs = design.leg_lengths
        self._origins = design.rail_origins
        self._ref = design.characteristic_length

    def measures(
        self, pose: tuple[float, float, float], rho: tuple[float, float, float]
    ) -> ConfigurationMeasures:
        """Margins, assembly mode and leg angles at ``pose`` (m, m, rad) and ``rho`` (m)."""
        x, y, th = pose
        c, s = math.cos(th), math.sin(th)
        (k1, k2, k3), (l1, l2, l3), (o1, o2, o3), ref = (
            self._k,
            self._legs,
            self._origins,
            self._ref,
        )
        # Leg vectors u_i = C_i - B_i (m), unrolled: this runs once per control step.
        ux1, uy1 = x + k1 * c - o1 - rho[0], y + k1 * s
        ux2, uy2 = x + k2 * c - o2 - rho[1], y + k2 * s
        ux3, uy3 = x + k3 * c - o3 - rho[2], y + k3 * s
        rows = [
            (ux1 / l1, uy1 / l1, k1 * (uy1 * c - ux1 * s) / (l1 * ref)),
            (ux2 / l2, uy2 / l2, k2 * (uy2 * c - ux2 * s) / (l2 * ref)),
            (ux3 / l3, uy3 / l3, k3 * (uy3 * c - ux3 * s) / (l3 * ref)),
        ]
        det = _det(rows)
        n1, n2, n3 = math.hypot(ux1, uy1), math.hypot(ux2, uy2), math.hypot(ux3, uy3)
        serial = min(
            1.0,
            abs(ux1) / n1 if n1 > 0.0 else 0.0,
            abs(ux2) / n2 if n2 > 0.0 else 0.0,
            abs(ux3) / n3 if n3 > 0.0 else 0.0,
        )
        return ConfigurationMeasures(
            _inverse_condition(rows, det),
            serial,
            int(det > 0.0) - int(det < 0.0),
            (math.atan2(uy1, ux1), math.atan2(uy2, ux2), math.atan2(uy3, ux3)),
        )


def _det(m: list[tuple[float, float, float]]) -> float:
    (a, b, c), (d, e, f), (g, h, i) = m
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


def _inverse_condition(m: list[tuple[float, float, float]], det: float) -> float:
    """``sigma_min / sigma_max`` of a 3x3 matrix from the eigenvalues of ``M^T M``.

    The largest eigenvalue comes from the closed-form trigonometric solution; the smallest from
    the sum and product of the other two, which stays accurate near zero.
    """
    (a, b, c), (d, e, f), (g, h, i) = m
    s00 = a * a + d * d + g * g
    s11 = b * b + e * e + h * h
    s22 = c * c + f * f + i * i
    s01 = a * b + d * e + g * h
    s02 = a * c + d * f + g * i
    s12 = b * c + e * f + h * i
    q = (s00 + s11 + s22) / 3.0
    p1 = s01 * s01 + s02 * s02 + s12 * s12
    p2 = (s00 - q) ** 2 + (s11 - q) ** 2 + (s22 - q) ** 2 + 2.0 * p1
    if p2 <= 1e-300:
        return 1.0 if q > 0.0 else 0.0
    p = math.sqrt(p2 / 6.0)
    b00, b11, b22 = (s00 - q) / p, (s11 - q) / p, (s22 - q) / p
    b01, b02, b12 = s01 / p, s02 / p, s12 / p
    r = 0.5 * (
        b00 * (b11 * b22 - b12 * b12)
        - b01 * (b01 * b22 - b12 * b02)
        + b02 * (b01 * b12 - b11 * b02)
    )
    phi = math.acos(max(-1.0, min(1.0, r))) / 3.0
    lam1 = q + 2.0 * p * math.cos(phi)
    if lam1 <= 0.0:
        return 0.0
    # lambda_2 + lambda_3 and lambda_2 * lambda_3 = det^2 / lambda_1 are both accurate, so the
    # smaller root of t^2 - sum t + prod (in its cancellation-free form) is too, even when
    # lambda_2 and lambda_3 are both tiny (A_bar of rank about 1).
    total = max(3.0 * q - lam1, 0.0)
    prod = det * det / lam1
    disc = math.sqrt(max(total * total - 4.0 * prod, 0.0))
    denom = total + disc
    lam3 = 2.0 * prod / denom if denom > 0.0 else 0.0
    return math.sqrt(max(lam3, 0.0) / lam1)
