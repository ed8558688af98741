"""Statics: the actuator forces that hold the mechanism at rest against gravity.

By virtual work with ``p_dot = A^-1 B rho_dot``, the forces along the rails are
``F = g B A^-T c``, where ``c`` maps the platform twist to the rate of change of
``sum m_k y_k`` (the platform, a uniform rod from ``G`` to ``C_1``, and the legs, uniform rods
from ``B_i`` to ``C_i``; the sliders do not rise).  They grow like ``1 / parallel margin`` near
a parallel singularity: a pose whose forces exceed ``design.max_force`` cannot be held, whatever
its margin.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design

__all__ = ["holding_forces", "holding_forces_at"]


def holding_forces(design: Design, poses: ArrayLike, mode: ArrayLike) -> NDArray[np.float64]:
    """Actuator forces (N, signed, along the rails) that hold poses ``(..., 3)`` (m, m, rad) at
    rest in working mode ``mode``, shape ``(..., 3)``; NaN where a pose is unreachable."""
    p = np.asarray(poses, dtype=np.float64)
    rho, _ = kinematics.inverse(design, p, np.asarray(mode, dtype=np.float64))
    return holding_forces_at(design, p, rho)


def holding_forces_at(design: Design, poses: ArrayLike, rho: ArrayLike) -> NDArray[np.float64]:
    """:func:`holding_forces` of configurations given by their poses ``(..., 3)`` and slider
    travels ``rho`` (m, ``(..., 3)``, NaN rows for unreachable poses give NaN forces)."""
    p = np.asarray(poses, dtype=np.float64)
    rho = np.asarray(rho, dtype=np.float64)
    A, B = kinematics.jacobians(design, p, np.nan_to_num(rho))
    k = np.asarray(design.joint_offsets)
    c = np.zeros(p.shape)
    c[..., 1] = design.platform_mass + 1.5 * design.leg_mass
    c[..., 2] = (0.5 * design.platform_mass * k[0] + 0.5 * design.leg_mass * k.sum()) * np.cos(
        p[..., 2]
    )
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        z = np.linalg.solve(np.swapaxes(A, -1, -2), c[..., None])[..., 0]
    f = design.gravity * np.diagonal(B, axis1=-2, axis2=-1) * z
    return np.where(np.isfinite(rho).all(axis=-1, keepdims=True), f, np.nan)
