"""Single-configuration kinematic measures, for the simulation loop.

The margins are those of :mod:`planar3p_gym.machine.margins` (their one definition); the
vectorised functions of :mod:`planar3p_gym.machine.kinematics` are the reference they are
tested against.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from planar3p_gym.machine.design import Design
from planar3p_gym.machine.margins import leg_margins

__all__ = ["ConfigurationMeasures", "ScalarKinematics", "configuration_measures"]


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


@njit(cache=True)
def configuration_measures(
    x: float, y: float, th: float, r0: float, r1: float, r2: float, consts: np.ndarray
) -> tuple[float, float, int, float, float, float]:
    """``(parallel margin, serial margin, sign det A, alpha_1, alpha_2, alpha_3)`` at the pose
    ``(x, y, th)`` (m, m, rad) and the travels ``r0, r1, r2`` (m) of the machine whose
    ``consts`` are :attr:`ScalarKinematics.consts` (the joint offsets, the leg lengths and the
    rail origins (m), the characteristic length (m)): the one definition of the measures, for
    a single step and for a batch of them."""
    c, s = math.cos(th), math.sin(th)
    k1, k2, k3, l1, l2, l3 = consts[0], consts[1], consts[2], consts[3], consts[4], consts[5]
    o1, o2, o3, ref = consts[6], consts[7], consts[8], consts[9]
    # Leg vectors u_i = C_i - B_i (m), unrolled: this runs once per control step.
    ux1, uy1 = x + k1 * c - o1 - r0, y + k1 * s
    ux2, uy2 = x + k2 * c - o2 - r1, y + k2 * s
    ux3, uy3 = x + k3 * c - o3 - r2, y + k3 * s
    parallel, serial, sign, _, _, _ = leg_margins(
        ux1, uy1, ux2, uy2, ux3, uy3, c, s, k1, k2, k3, l1, l2, l3, ref
    )
    return (
        parallel, serial, sign, math.atan2(uy1, ux1), math.atan2(uy2, ux2),
        math.atan2(uy3, ux3),
    )  # fmt: skip


class ScalarKinematics:
    """Measures of single configurations of ``design`` (see :class:`ConfigurationMeasures`)."""

    def __init__(self, design: Design) -> None:
        self.design = design
        self._k = design.joint_offsets
        self._legs = design.leg_lengths
        self._origins = design.rail_origins
        self._ref = design.characteristic_length
        #: The machine's numbers :func:`configuration_measures` takes (float64, 10).
        self.consts = np.array((*self._k, *self._legs, *self._origins, self._ref), dtype=np.float64)

    def measures(
        self, pose: tuple[float, float, float], rho: tuple[float, float, float]
    ) -> ConfigurationMeasures:
        """Margins, assembly mode and leg angles at ``pose`` (m, m, rad) and ``rho`` (m)."""
        parallel, serial, sign, a1, a2, a3 = configuration_measures(
            pose[0], pose[1], pose[2], rho[0], rho[1], rho[2], self.consts
        )
        return ConfigurationMeasures(parallel, serial, sign, (a1, a2, a3))
