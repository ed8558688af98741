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

from planar3p_gym import checks
from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.machine.design import Design
from planar3p_gym.sim.physics import SimState

__all__ = ["REALISTIC_SENSORS", "Encoders", "SensorConfig", "joint_angle_beta", "pose_from_joints"]


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


#: The encoders of ``Planar3PReal-v0``: 10 um linear encoders with 5 um noise, 4096-count angle
#: encoders (0.088 deg) with 0.02 deg noise.
REALISTIC_SENSORS = SensorConfig(
    slider_noise=5e-6,
    slider_resolution=1e-5,
    angle_noise=math.radians(0.02),
    angle_resolution=2.0 * math.pi / 4096,
)


def joint_angle_beta(pose: tuple[float, float, float], alpha_1: float) -> float:
    """The joint angle ``beta`` at ``C_1`` (rad, in ``(-pi, pi]``): from the ray ``C_1 -> B_1``
    to the platform's axis ``e(theta)``, so that ``theta = beta + alpha_1 - pi``."""
    return wrap_angle(pose[2] - alpha_1 + math.pi)


def pose_from_joints(
    design: Design, rho_1: float, alpha_1: float, beta: float
) -> tuple[float, float, float]:
    """The gripper pose ``(x, y, theta)`` (m, m, rad) from the travel of slider 1 (m) and the
    angles ``alpha_1`` and ``beta`` (rad), by leg 1 as a serial chain of ``design``:
    ``C_1 = B_1 + L_1 e(alpha_1)``, ``theta = beta + alpha_1 - pi``, ``G = C_1 - L_1G e(theta)``."""
    L1, k1, a1 = design.leg_lengths[0], design.joint_offsets[0], design.rail_origins[0]
    cx = a1 + rho_1 + L1 * math.cos(alpha_1)
    cy = L1 * math.sin(alpha_1)
    theta = wrap_angle(beta + alpha_1 - math.pi)
    return (cx - k1 * math.cos(theta), cy - k1 * math.sin(theta), theta)


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

    def reset(self) -> None:
        """Forget the last reading (the next one has zero rates)."""
        self._last = None

    def get_state(self) -> tuple | None:
        """The last reading (plain data)."""
        return self._last

    def set_state(self, state: tuple | None) -> None:
        """Restore :meth:`get_state`."""
        self._last = state

    def _read(self, values: list[float], noise: float, resolution: float, rng) -> list[float]:
        if noise > 0.0:
            values = (np.asarray(values) + rng.normal(0.0, noise, size=len(values))).tolist()
        if resolution > 0.0:
            values = [resolution * round(v / resolution) for v in values]
        return values

    def measure(self, state: SimState, rng: np.random.Generator) -> SimState:
        """A reading of the true ``state`` (noise from ``rng``) as a measured state."""
        cfg = self.config
        rho = self._read(list(state.rho), cfg.slider_noise, cfg.slider_resolution, rng)
        angles = [*state.leg_angles, joint_angle_beta(state.pose, state.leg_angles[0])]
        angles = self._read(angles, cfg.angle_noise, cfg.angle_resolution, rng)
        alphas = tuple(wrap_angle(a) for a in angles[:3])
        pose = pose_from_joints(self.design, rho[0], alphas[0], angles[3])
        last = self._last
        if last is None:
            rates = (0.0, 0.0, 0.0)
            twist = (0.0, 0.0, 0.0)
        else:
            (r0, p0), h = last, self.dt
            rates = tuple((rho[i] - r0[i]) / h for i in range(3))
            twist = (
                (pose[0] - p0[0]) / h,
                (pose[1] - p0[1]) / h,
                wrap_angle(pose[2] - p0[2]) / h,
            )
        self._last = (tuple(rho), pose)
        return state._replace(
            rho=(rho[0], rho[1], rho[2]),
            rho_dot=rates,
            pose=pose,
            twist=twist,
            leg_angles=alphas,
        )
