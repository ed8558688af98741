"""Delay-aware on-off control: each motor runs while the travel still to go, after the commands
in flight and the servo's coasting, exceeds half of what one step of running moves it.

The bang-bang law of :mod:`planar3p_agents.controllers.on_off` decides from the observed error
alone.  On the machine as built a command executes one step after it is sent, and the servo's
setpoint lags the command, so a slider keeps moving for a while after its stop was decided; at
0.4 mm a step the law then overshoots and cycles around the target.
:class:`PredictiveOnOffController` predicts that travel and rounds to the motor's quantum:

* the travel a slider needs, ``d_i``: the simple motions' slider rates for the observed pose
  error (:class:`~planar3p_agents.controllers.analytic.AnalyticController`) over its gain, i.e.
  the first-order inverse kinematics of the error (exact wherever the rates do not saturate);
* the travel it will still make if stopped now: the commands in flight (``delay`` steps of
  ``q = on_off_speed max_speed dt`` each) plus ``rho_dot_i servo_lag`` (what a first-order lag
  of time constant ``servo_lag`` still moves from the observed rate);
* motor ``i`` runs towards the rest ``r_i`` of ``d_i`` while ``|r_i| > q / 2`` (one more step
  brings it closer) and ``|r_i|`` is at least ``relative`` times the largest (far from the
  target the motion keeps roughly its direction); all motors stop while the observed errors are
  within ``position_band`` and ``orientation_band``.

The controller remembers the commands it sent (its state, reset at each episode start).  With
a learned :class:`~planar3p_agents.controllers.pose_correction.PoseCorrection` it acts on the
errors corrected for the pose reading's bias.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planar3p_agents.controllers.analytic import AnalyticController
from planar3p_agents.controllers.base import BatchPolicy
from planar3p_agents.controllers.pose_correction import PoseCorrection
from planar3p_gym import checks
from planar3p_gym.envs.actuation import ON_OFF_COMMANDS, ON_OFF_SPEED
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks.observation import OBS_SIZE, SLICES

__all__ = ["PredictiveOnOffController", "digits_of", "signs_of"]

_PLACES = np.array([9, 3, 1], dtype=np.int64)
#: The signed command of each motor command, the environment's encoding (``ON_OFF_COMMANDS``),
#: and the motor command of each sign (indexed by ``sign + 1``).
_SIGNS = np.asarray(ON_OFF_COMMANDS).astype(np.int64)
_DIGIT_OF_SIGN = np.empty(3, dtype=np.int64)
_DIGIT_OF_SIGN[_SIGNS + 1] = np.arange(_SIGNS.size)
_POS = SLICES["position_error"]
_ANG = SLICES["orientation_error"].start
_RATES = SLICES["rho_dot"]


def digits_of(signed: ArrayLike) -> NDArray[np.int64]:
    """Motor commands (0 stop, 1 forward, 2 backward) of signed ones (the sign of each entry)."""
    return _DIGIT_OF_SIGN[np.sign(np.asarray(signed)).astype(np.int64) + 1]


def signs_of(digits: ArrayLike) -> NDArray[np.int64]:
    """Signed commands (0, 1, -1) of motor commands (0 stop, 1 forward, 2 backward)."""
    return _SIGNS[np.asarray(digits, dtype=np.int64)]


class PredictiveOnOffController(BatchPolicy):
    """Delay- and lag-aware on-off motor commands (module docstring).

    Args:
        design: the nominal machine (default ``Design.fig8()``).
        delay: control steps between sending a command and its execution (0 to 2).
        servo_lag: assumed time constant of the servo's lag (s).
        dt: control step (s).
        on_off_speed: rated speed of the motors, a fraction of ``max_speed``.
        position_band, orientation_band: all motors stop within these errors (m, rad).
        relative: a motor runs only if its rest is at least this share of the largest.
        discrete: return ``Discrete(27)`` indices instead of ``MultiDiscrete([3, 3, 3])``.
        observation_size: length of the observations accepted (at least 31).
        correction: a learned correction of the pose reading, or ``None``.
    """

    obs_size = OBS_SIZE

    def __init__(
        self,
        design: Design | None = None,
        *,
        delay: int = 1,
        servo_lag: float = 0.02,
        dt: float = 0.02,
        on_off_speed: float = ON_OFF_SPEED,
        position_band: float = 0.001,
        orientation_band: float = math.radians(0.5),
        relative: float = 0.3,
        discrete: bool = False,
        observation_size: int | None = None,
        correction: PoseCorrection | None = None,
    ) -> None:
        self._use_design(design)
        self._use_observation_size(observation_size)
        self.delay = checks.integer(delay, "delay", low=0, high=2)
        self.servo_lag = checks.number(servo_lag, "servo_lag", low=0.0, unit="s")
        self.dt = checks.number(dt, "dt", low=0.0, low_open=True, unit="s")
        self.on_off_speed = checks.number(
            on_off_speed, "on_off_speed", low=0.0, high=1.0, low_open=True
        )
        self.position_band = checks.number(position_band, "position_band", low=0.0, unit="m")
        self.orientation_band = checks.number(
            orientation_band, "orientation_band", low=0.0, unit="rad"
        )
        self.relative = checks.number(relative, "relative", low=0.0, high=1.0)
        if not isinstance(discrete, (bool, np.bool_)):
            raise ValueError(f"discrete must be True or False, got {discrete!r}")
        self.discrete = bool(discrete)
        if correction is not None and not isinstance(correction, PoseCorrection):
            raise ValueError(f"correction must be a PoseCorrection or None, got {correction!r}")
        self.correction = correction
        self.inner = AnalyticController(self.design, observation_size=self.obs_size)
        #: Travel of one step of running (m).
        self.quantum = self.on_off_speed * self.design.max_speed * self.dt
        self._sent: NDArray[np.int64] | None = None

    @classmethod
    def from_env(cls, env: Any, **kwargs: Any) -> PredictiveOnOffController:
        """A controller for the on-off env ``env`` (possibly wrapped): its nominal design,
        control step, rated speed, shortest action delay and action encoding."""
        from gymnasium import spaces

        base = env.unwrapped
        latency = getattr(base, "latency", None)
        kwargs.setdefault("delay", int(latency.action_delay[0]) if latency is not None else 0)
        kwargs.setdefault("dt", float(base.dt))
        kwargs.setdefault("on_off_speed", float(getattr(base, "on_off_speed", ON_OFF_SPEED)))
        kwargs.setdefault("discrete", isinstance(env.action_space, spaces.Discrete))
        kwargs.setdefault("observation_size", int(env.observation_space.shape[0]))
        return cls(base.design, **kwargs)

    def __repr__(self) -> str:
        return (
            f"PredictiveOnOffController(delay={self.delay}, servo_lag={self.servo_lag}, "
            f"discrete={self.discrete}, corrected={self.correction is not None})"
        )

    def reset(self, seed: Any = None) -> None:
        """Forget the commands sent (a new episode starts with none in flight)."""
        self._sent = None

    def act(
        self, obs: NDArray[np.float64], state: Any, starts: NDArray[np.bool_], deterministic: bool
    ) -> tuple[np.ndarray, Any]:
        """Commands for the batch ``obs``; ``state`` is the signed commands in flight
        ``(n, delay, 3)`` (``None``: those remembered from the last call, else none)."""
        n = obs.shape[0]
        sent = self._in_flight(state, starts, n)
        signed = self.signed_commands(obs, sent.sum(axis=1))
        new = np.concatenate([sent[:, 1:], signed[:, None, :]], axis=1) if self.delay else sent
        self._sent = new.copy()
        digits = digits_of(signed)
        out = digits @ _PLACES if self.discrete else digits
        return out, new.copy()

    def signed_commands(
        self, obs: NDArray[np.float64], in_flight: NDArray[np.int64]
    ) -> NDArray[np.int64]:
        """Signed commands ``(n, 3)`` (1 forward, -1 backward, 0 stop) for observations
        ``(n, >= 31)`` and the sum ``(n, 3)`` of the signed commands in flight."""
        obs2 = np.nan_to_num(obs, nan=0.0, posinf=0.0, neginf=0.0)
        if self.correction is not None:
            obs2 = self.correction.corrected(obs2)
        rates = self.inner.predict(obs2)[0].astype(np.float64)
        need = rates * self.design.max_speed / self.inner.position_gain
        coast = self.quantum * in_flight + obs2[:, _RATES] * self.servo_lag
        rest = need - coast
        mag = np.abs(rest)
        run = (mag > 0.5 * self.quantum) & (mag >= self.relative * mag.max(axis=1, keepdims=True))
        at_rest = (np.hypot(obs2[:, _POS.start], obs2[:, _POS.start + 1]) <= self.position_band) & (
            np.abs(obs2[:, _ANG]) <= self.orientation_band
        )
        run &= ~at_rest[:, None]
        return np.where(run, np.sign(rest), 0.0).astype(np.int64)

    def _in_flight(self, state: Any, starts: NDArray[np.bool_], n: int) -> NDArray[np.int64]:
        shape = (n, self.delay, 3)
        if state is not None:
            sent = np.asarray(state, dtype=np.int64).copy()
            if sent.shape != shape:
                raise ValueError(f"state must have shape {shape}, got {sent.shape}")
        elif self._sent is not None and self._sent.shape == shape:
            sent = self._sent.copy()
        else:
            sent = np.zeros(shape, dtype=np.int64)
        sent[starts] = 0
        return sent
