"""What the machine measures: joint encoders with noise and quantisation, and the pose the nominal
model computes from them.

The prototype of the paper measures joint angles and computes the gripper pose from them; here
each slider has a linear encoder (its travel ``rho_i``), each leg an angle encoder (its angle
``alpha_i`` from the rail), and the joint ``C_1`` an encoder of the angle ``beta`` between leg 1
and the platform.  A reading is the true value plus Gaussian noise, rounded to the encoder's
resolution.  The pose follows from leg 1 as a serial chain with the *nominal* design (the
paper's ``theta = beta + alpha_1 - pi``, :func:`pose_from_joints`); slider rates and the twist
are backward differences of successive readings over the control period (what a controller
sampling encoders has), zero at the first reading.

Written here rather than taken from a library: the readings are a few lines of numpy on the
simulation's own state, and the pose needs this machine's kinematics (Gymnasium's observation
wrappers add noise to an observation, not to the joints it is computed from).

The noise is drawn from the generator the caller passes (the environment's ``np_random``), in a
fixed order (three travels, three leg angles, ``beta``), and only for a nonzero noise level.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

import numpy as np
from numba import njit

from planar3p_gym import checks
from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.machine.design import Design
from planar3p_gym.sim.physics import SimState

__all__ = [
    "LAST_SIZE",
    "READING_SIZE",
    "REALISTIC_SENSORS",
    "Encoders",
    "SensorConfig",
    "joint_angle_beta",
    "pose_from_joints",
    "read_encoders",
]


@dataclass(frozen=True)
class SensorConfig:
    """Noise and resolution of the joint encoders (SI units; 0 = exact).

    Attributes:
        slider_noise: standard deviation of the travel readings' noise (m).
        slider_resolution: resolution of the linear encoders (m); readings are multiples of it.
        angle_noise: standard deviation of the angle readings' noise (rad).
        angle_resolution: resolution of the angle encoders (rad).
    """

    slider_noise: float = 0.0
    slider_resolution: float = 0.0
    angle_noise: float = 0.0
    angle_resolution: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            unit = "m" if f.name.startswith("slider") else "rad"
            high = 0.01 if unit == "m" else 0.1
            value = checks.number(
                getattr(self, f.name), f"SensorConfig.{f.name}", low=0.0, high=high, unit=unit
            )
            object.__setattr__(self, f.name, value)

    def to_dict(self) -> dict[str, float]:
        """Plain-Python dictionary of the fields."""
        return asdict(self)

    def as_array(self) -> np.ndarray:
        """The fields in order, as :func:`read_encoders` takes them (float64, 4)."""
        return np.array(
            (self.slider_noise, self.slider_resolution, self.angle_noise, self.angle_resolution)
        )


#: The encoders of ``Planar3PReal-v0``: 10 um linear encoders with 5 um noise, 4096-count angle
#: encoders (0.088 deg) with 0.02 deg noise.
REALISTIC_SENSORS = SensorConfig(
    slider_noise=5e-6,
    slider_resolution=1e-5,
    angle_noise=math.radians(0.02),
    angle_resolution=2.0 * math.pi / 4096,
)


@njit(cache=True)
def joint_angle_beta(pose: tuple[float, float, float], alpha_1: float) -> float:
    """The joint angle ``beta`` at ``C_1`` (rad, in ``(-pi, pi]``): from the ray ``C_1 -> B_1``
    to the platform's axis ``e(theta)``, so that ``theta = beta + alpha_1 - pi``."""
    return wrap_angle(pose[2] - alpha_1 + math.pi)


@njit(cache=True)
def _pose_from_leg(
    L1: float, k1: float, a1: float, rho_1: float, alpha_1: float, beta: float
) -> tuple[float, float, float]:
    """:func:`pose_from_joints` of leg 1's length ``L1``, joint offset ``k1`` and rail origin
    ``a1`` (m)."""
    cx = a1 + rho_1 + L1 * math.cos(alpha_1)
    cy = L1 * math.sin(alpha_1)
    theta = wrap_angle(beta + alpha_1 - math.pi)
    return (cx - k1 * math.cos(theta), cy - k1 * math.sin(theta), theta)


def pose_from_joints(
    design: Design, rho_1: float, alpha_1: float, beta: float
) -> tuple[float, float, float]:
    """The gripper pose ``(x, y, theta)`` (m, m, rad) from the travel of slider 1 (m) and the
    angles ``alpha_1`` and ``beta`` (rad), by leg 1 as a serial chain of ``design``:
    ``C_1 = B_1 + L_1 e(alpha_1)``, ``theta = beta + alpha_1 - pi``, ``G = C_1 - L_1G e(theta)``."""
    L1, k1, a1 = design.leg_lengths[0], design.joint_offsets[0], design.rail_origins[0]
    return _pose_from_leg(L1, k1, a1, rho_1, alpha_1, beta)


#: Entries of :func:`read_encoders`' ``out``: the travels, their rates, the pose, the twist and
#: the leg angles as read (SI units).
READING_SIZE = 15
#: Entries of an encoders' last reading (:func:`read_encoders`' ``last``): 1.0 once there is
#: one, then its travels and its pose.
LAST_SIZE = 7


@njit(cache=True)
def read_encoders(
    rho: np.ndarray, leg_angles: np.ndarray, pose: np.ndarray, noise: np.ndarray,
    config: np.ndarray, leg_1: np.ndarray, dt: float, last: np.ndarray, out: np.ndarray,
) -> None:  # fmt: skip
    """One reading of the true travels ``rho``, leg angles and ``pose`` (theta wrapped; SI
    units, 3 each) with the drawn ``noise`` (7: the travels', then the four angles'; read only
    for a nonzero noise level), through the nominal leg 1 (``leg_1``: its length, joint offset
    and rail origin, m) (module docstring).  ``config``: :meth:`SensorConfig.as_array`;
    ``dt``: time between readings (s); ``last``: the last reading (:data:`LAST_SIZE`, updated
    here); writes :data:`READING_SIZE` values into ``out``."""
    values = np.empty(7)
    for k in range(3):
        values[k] = rho[k]
        values[3 + k] = leg_angles[k]
    values[6] = joint_angle_beta((pose[0], pose[1], pose[2]), leg_angles[0])
    for first, stop, level, resolution in (
        (0, 3, config[0], config[1]),
        (3, 7, config[2], config[3]),
    ):
        for k in range(first, stop):
            if level > 0.0:
                values[k] = values[k] + noise[k]
            if resolution > 0.0:
                values[k] = resolution * round(values[k] / resolution)
    for k in range(3):
        out[k] = values[k]
        out[12 + k] = wrap_angle(values[3 + k])
    x, y, theta = _pose_from_leg(leg_1[0], leg_1[1], leg_1[2], values[0], out[12], values[6])
    out[6], out[7], out[8] = x, y, theta
    if last[0] == 0.0:
        for k in range(3):
            out[3 + k] = 0.0
            out[9 + k] = 0.0
    else:
        for k in range(3):
            out[3 + k] = (values[k] - last[1 + k]) / dt
        out[9] = (x - last[4]) / dt
        out[10] = (y - last[5]) / dt
        out[11] = wrap_angle(theta - last[6]) / dt
    last[0] = 1.0
    for k in range(3):
        last[1 + k] = values[k]
    last[4], last[5], last[6] = x, y, theta


class Encoders:
    """The encoders of one machine and the nominal model that turns their readings into a state.

    :meth:`measure` returns a :class:`~planar3p_gym.sim.physics.SimState` of the measured
    quantities (travels, rates, pose, twist, leg angles); its other fields (time, forces,
    saturation, closure error) are the true state's, which the environment never observes from
    it.  State between readings: the last reading (for the differences), see :meth:`reset`.

    Args:
        design: the nominal design (the model the machine's controller knows).
        config: noise and resolution.
        dt: time between readings (s).
    """

    def __init__(self, design: Design, config: SensorConfig, dt: float) -> None:
        self.design = design
        self.config = config
        self.dt = float(dt)
        self._last: tuple[tuple[float, ...], tuple[float, float, float]] | None = None
        self._config = config.as_array()
        #: The nominal leg 1's length, joint offset and rail origin (m), as
        #: :func:`read_encoders` takes them.
        self.leg_1 = np.array(
            (design.leg_lengths[0], design.joint_offsets[0], design.rail_origins[0])
        )

    def reset(self) -> None:
        """Forget the last reading (the next one has zero rates)."""
        self._last = None

    def get_state(self) -> tuple | None:
        """The last reading (plain data)."""
        return self._last

    def set_state(self, state: tuple | None) -> None:
        """Restore :meth:`get_state`."""
        self._last = state

    def draw_noise(self, rng: np.random.Generator) -> np.ndarray:
        """The noise of one reading (7: the travels', then the four angles'), drawn from
        ``rng`` in the order :func:`read_encoders` adds it, only for a nonzero noise level
        (zeros for the others)."""
        cfg = self.config
        noise = np.zeros(7)
        if cfg.slider_noise > 0.0:
            noise[:3] = rng.normal(0.0, cfg.slider_noise, size=3)
        if cfg.angle_noise > 0.0:
            noise[3:] = rng.normal(0.0, cfg.angle_noise, size=4)
        return noise

    def last_array(self) -> np.ndarray:
        """:meth:`get_state` as :func:`read_encoders`' ``last`` (:data:`LAST_SIZE`)."""
        last = np.zeros(LAST_SIZE)
        if self._last is not None:
            last[0] = 1.0
            last[1:4], last[4:7] = self._last
        return last

    @staticmethod
    def last_of(last: np.ndarray) -> tuple | None:
        """:meth:`get_state` of :func:`read_encoders`' ``last``."""
        if last[0] == 0.0:
            return None
        r0, r1, r2, x, y, th = last[1:].tolist()
        return ((r0, r1, r2), (x, y, th))

    def measure(self, state: SimState, rng: np.random.Generator) -> SimState:
        """A reading of the true ``state`` (noise from ``rng``) as a measured state
        (:func:`read_encoders`)."""
        noise = self.draw_noise(rng)
        last = self.last_array()
        out = np.empty(READING_SIZE)
        read_encoders(
            np.array(state.rho), np.array(state.leg_angles), np.array(state.pose), noise,
            self._config, self.leg_1, self.dt, last, out,
        )  # fmt: skip
        self._last = self.last_of(last)
        r = out.tolist()
        return state._replace(
            rho=(r[0], r[1], r[2]),
            rho_dot=(r[3], r[4], r[5]),
            pose=(r[6], r[7], r[8]),
            twist=(r[9], r[10], r[11]),
            leg_angles=(r[12], r[13], r[14]),
        )
