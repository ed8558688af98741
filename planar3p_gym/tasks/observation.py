"""The observation vector of ``Planar3P-v0``: layout, bounds and construction.

A flat ``float32`` vector, SI units, every entry documented and bounded (values are clipped to
the bounds, which bind only in physically extreme states); the layout index by index is on every
id's page (docs/environments.md has it with the reasons for the ``fine_error`` block).

* :data:`OBS_FIELDS`, :data:`SLICES`, :data:`OBS_SIZE`: the 31 entries (name, size, meaning);
* :data:`TRAVEL_GOAL_FIELDS`: the joint-space goal ``travel_goal=True`` appends (reach only);
* :func:`bounds`, :func:`observation_space`: the bounds; :func:`write_reach_values`,
  :func:`build_observation`: the one construction; :func:`within_tolerances`: the success test;
  :func:`pose_errors`: the errors to the reference pose.
"""

from __future__ import annotations

import math

import numpy as np
from gymnasium import spaces
from numba import njit

from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.machine.design import Design
from planar3p_gym.machine.norm import hypot

__all__ = [
    "OBS_FIELDS",
    "OBS_SIZE",
    "SLICES",
    "TRAVEL_GOAL_FIELDS",
    "TRAVEL_GOAL_SIZE",
    "build_observation",
    "clip_float32",
    "observation_of",
    "observation_space",
    "pose_errors",
    "travel_goal_bounds",
    "travel_goal_entries",
    "within_tolerances",
    "write_reach_values",
]

#: ``(name, size, description)`` of each block, in order.
OBS_FIELDS: tuple[tuple[str, int, str], ...] = (
    ("rho", 3, "slider travels rho_i (m)"),
    ("rho_dot", 3, "slider travel rates (m/s)"),
    ("position", 2, "gripper point G = (x, y) (m)"),
    ("orientation", 2, "cos theta, sin theta"),
    ("velocity", 2, "velocity of G (m/s)"),
    ("angular_velocity", 1, "theta_dot (rad/s)"),
    ("legs", 6, "cos alpha_i, sin alpha_i for legs 1, 2, 3"),
    ("target_position", 2, "target gripper point (m)"),
    ("target_orientation", 2, "cos, sin of the target angle"),
    ("position_error", 2, "target position minus G (m)"),
    ("orientation_error", 1, "target angle minus theta, wrapped to (-pi, pi] (rad)"),
    ("parallel_margin", 1, "inverse condition number of A_bar, in [0, 1]"),
    ("serial_margin", 1, "min_i |cos alpha_i|, in [0, 1]"),
    ("fine_error", 3, "tanh of (dx, dy, L_ref dtheta) / FINE_ERROR_SCALE"),
)


def _slices() -> dict[str, slice]:
    out, start = {}, 0
    for name, size, _ in OBS_FIELDS:
        out[name] = slice(start, start + size)
        start += size
    return out


#: Name of a block -> its slice in the observation vector.
SLICES: dict[str, slice] = _slices()
#: Length of the observation vector.
OBS_SIZE: int = sum(size for _, size, _ in OBS_FIELDS)

#: ``(name, size, description)`` of the joint-space goal appended with ``travel_goal=True``.
TRAVEL_GOAL_FIELDS: tuple[tuple[str, int, str], ...] = (
    ("target_rho", 3, "slider travels of the target in the episode's working mode (m)"),
    ("fine_travel_error", 3, "tanh of (target_rho - rho) / FINE_ERROR_SCALE"),
)
#: Length of the joint-space goal block.
TRAVEL_GOAL_SIZE: int = sum(size for _, size, _ in TRAVEL_GOAL_FIELDS)

#: Length scale of the ``fine_error`` block (m).
FINE_ERROR_SCALE = 0.01

#: Speeds are bounded by this multiple of the design's speed limit (the servos hold the
#: sliders to the limit; the platform can move faster near singularities).
SPEED_BOUND_FACTOR = 20.0


def bounds(design: Design) -> tuple[np.ndarray, np.ndarray]:
    """Finite ``(low, high)`` float32 bounds of the observation for ``design``."""
    x0, x1, _, h = design.search_rectangle
    reach = max(design.leg_lengths) + design.platform_length
    vmax = SPEED_BOUND_FACTOR * design.max_speed
    wmax = vmax / design.characteristic_length
    span = (x1 - x0) + 2.0 * reach
    low, high = [], []

    def add(lo: float, hi: float, n: int) -> None:
        low.extend([lo] * n)
        high.extend([hi] * n)

    add(-0.05 * design.stroke, 1.05 * design.stroke, 3)  # rho (end stops may yield a little)
    add(-vmax, vmax, 3)
    for lo, hi in ((x0 - reach, x1 + reach), (-h - reach, h + reach)):
        add(lo, hi, 1)
    add(-1.0, 1.0, 2)
    add(-vmax, vmax, 2)
    add(-wmax, wmax, 1)
    add(-1.0, 1.0, 6)
    for lo, hi in ((x0 - reach, x1 + reach), (-h - reach, h + reach)):
        add(lo, hi, 1)
    add(-1.0, 1.0, 2)
    add(-span, span, 2)
    add(-math.pi, math.pi, 1)
    add(0.0, 1.0, 2)
    add(-1.0, 1.0, 3)
    return np.array(low, dtype=np.float32), np.array(high, dtype=np.float32)


def travel_goal_bounds(design: Design) -> tuple[np.ndarray, np.ndarray]:
    """Finite ``(low, high)`` float32 bounds of the joint-space goal block for ``design``
    (the target's travels lie on the stroke; the fine travel errors in ``[-1, 1]``)."""
    low = [0.0] * 3 + [-1.0] * 3
    high = [design.stroke] * 3 + [1.0] * 3
    return np.array(low, dtype=np.float32), np.array(high, dtype=np.float32)


def travel_goal_entries(rho: np.ndarray, target_rho: np.ndarray) -> np.ndarray:
    """The joint-space goal block, float32 ``(..., 6)``, of slider travels ``rho`` (m) and
    the target's travels ``target_rho`` (m), both ``(..., 3)``.

    ``rho`` is taken from the observation itself (its float32 ``rho`` entries), so that the
    block is the same whichever code path built the rest of the observation."""
    rho = np.asarray(rho, dtype=np.float64)
    target = np.asarray(target_rho, dtype=np.float64)
    fine = np.tanh((target - rho) / FINE_ERROR_SCALE)
    return np.concatenate([target, fine], axis=-1).astype(np.float32)


def observation_space(design: Design) -> spaces.Box:
    """The ``Box`` observation space for ``design``."""
    low, high = bounds(design)
    return spaces.Box(low, high, dtype=np.float32)


@njit(cache=True)
def write_reach_values(
    out: np.ndarray,
    rho: np.ndarray, rho_dot: np.ndarray, pose: np.ndarray, c: float, s: float,
    twist: np.ndarray, legs_cs: np.ndarray, target: np.ndarray, tc: float, ts: float,
    parallel_margin: float, serial_margin: float, length: float,
) -> tuple[float, float, float]:  # fmt: skip
    """Write the 31 values of the observation (module docstring; float64, not yet clipped)
    into ``out`` and return the errors ``(dx, dy, dtheta)`` (m, m, rad): the one definition of
    the layout, used by :func:`build_observation`, the fused reach step and the vector env.

    ``rho``, ``rho_dot``, ``pose``, ``twist``, ``target`` are 3 values each (SI units),
    ``(c, s)`` the platform's and ``(tc, ts)`` the target's ``cos, sin``, ``legs_cs`` the 6
    values ``cos alpha_i, sin alpha_i``, ``length`` the characteristic length (m).
    """
    dx, dy = target[0] - pose[0], target[1] - pose[1]
    dth = wrap_angle(target[2] - pose[2])
    for j in range(3):
        out[j] = rho[j]
        out[3 + j] = rho_dot[j]
        out[10 + j] = twist[j]
    out[6], out[7], out[8], out[9] = pose[0], pose[1], c, s
    for j in range(6):
        out[13 + j] = legs_cs[j]
    out[19], out[20], out[21], out[22] = target[0], target[1], tc, ts
    out[23], out[24], out[25] = dx, dy, dth
    out[26], out[27] = parallel_margin, serial_margin
    out[28] = math.tanh(dx / FINE_ERROR_SCALE)
    out[29] = math.tanh(dy / FINE_ERROR_SCALE)
    out[30] = math.tanh(length * dth / FINE_ERROR_SCALE)
    return dx, dy, dth


@njit(cache=True)
def pose_errors(
    tx: float, ty: float, tth: float, x: float, y: float, theta: float
) -> tuple[float, float]:
    """Position (m) and orientation (rad, wrapped) errors of the pose ``(x, y, theta)`` to the
    target ``(tx, ty, tth)``: the distance rounded as Python's ``math.hypot`` rounds it
    (:func:`planar3p_gym.machine.norm.hypot`), and ``tth - theta`` wrapped."""
    return hypot(tx - x, ty - y), wrap_angle(tth - theta)


@njit(cache=True)
def within_tolerances(
    position_error: float, orientation_error: float, rho_dot: np.ndarray,
    position_tolerance: float, orientation_tolerance: float, rest_speed: float,
) -> bool:  # fmt: skip
    """The success test of a pose-reaching step: within ``position_tolerance`` (m) and
    ``orientation_tolerance`` (rad) of the target with every slider slower than
    ``rest_speed`` (m/s) (:attr:`planar3p_gym.tasks.sampling.TaskConfig.success_tolerances`)."""
    return (
        position_error <= position_tolerance
        and abs(orientation_error) <= orientation_tolerance
        and max(abs(rho_dot[0]), abs(rho_dot[1]), abs(rho_dot[2])) <= rest_speed
    )


@njit(cache=True)
def clip_float32(values: np.ndarray, low: np.ndarray, high: np.ndarray, out: np.ndarray) -> None:
    """``values`` (float64) rounded to float32 and clipped to ``[low, high]`` (float32), into
    ``out`` (float32): elementwise what ``np.maximum(np.minimum(values.astype(np.float32),
    high), low)`` gives, NaN kept (the one definition of the observation's clipping)."""
    for j in range(values.shape[0]):
        v = np.float32(values[j])
        if v > high[j]:
            v = high[j]
        if v < low[j]:
            v = low[j]
        out[j] = v


@njit(cache=True)
def observation_of(x: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """:func:`build_observation` of its arguments packed into ``x`` (21 float64: ``rho``,
    ``rho_dot``, ``pose``, ``twist``, leg angles, ``target``, the two margins, ``length``)."""
    a1, a2, a3 = x[12], x[13], x[14]
    legs_cs = np.empty(6)
    legs_cs[0], legs_cs[1], legs_cs[2] = math.cos(a1), math.sin(a1), math.cos(a2)
    legs_cs[3], legs_cs[4], legs_cs[5] = math.sin(a2), math.cos(a3), math.sin(a3)
    values = np.empty(OBS_SIZE)
    write_reach_values(
        values, x[0:3], x[3:6], x[6:9], math.cos(x[8]), math.sin(x[8]), x[9:12], legs_cs,
        x[15:18], math.cos(x[17]), math.sin(x[17]), x[18], x[19], x[20],
    )  # fmt: skip
    out = np.empty(OBS_SIZE, np.float32)
    clip_float32(values, low, high, out)
    return out


def build_observation(
    rho: tuple[float, float, float],
    rho_dot: tuple[float, float, float],
    pose: tuple[float, float, float],
    twist: tuple[float, float, float],
    leg_angles: tuple[float, float, float],
    target: tuple[float, float, float],
    parallel_margin: float,
    serial_margin: float,
    low: np.ndarray,
    high: np.ndarray,
    length: float,
) -> np.ndarray:
    """The observation vector (float32, clipped to ``[low, high]``, float32 bounds) of one
    state; ``length`` is the design's characteristic length (m).  One compiled call
    (:func:`write_reach_values`, :func:`clip_float32`)."""
    x = np.array(
        (*rho, *rho_dot, *pose, *twist, *leg_angles, *target, parallel_margin, serial_margin,
         length),
        dtype=np.float64,
    )  # fmt: skip
    return observation_of(x, low, high)
