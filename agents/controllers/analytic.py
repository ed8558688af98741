"""The paper's analytic controller: the "simple motions" of ``docs/mechanism.md``.

Solving ``A p_dot = B rho_dot`` row by row gives the slider rates of a platform twist from the
measured leg angles and platform angle alone
(:func:`planar3p_gym.machine.kinematics.simple_motion_basis`); :class:`AnalyticController`
turns the observed pose error into a twist with proportional gains and maps it to slider rates,
saturating uniformly and flooring ``|cos alpha_i|`` at ``serial_epsilon`` (why, and the two
modes in full: docs/controllers.md, "How the controller modules work").

* ``"simultaneous"`` (:data:`MODES`): the three simple motions superposed (resolved-rate
  control along the straight pose path);
* ``"sequential"``: the paper's way, one simple motion at a time (:data:`PHASES`), with
  hysteresis;
* calling convention: SB3's ``predict`` on the 31 entries every flat observation starts with
  (:meth:`AnalyticController.from_env` takes the id's observation size).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planar3p_agents.controllers.base import BatchPolicy
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks.observation import OBS_SIZE, SLICES

__all__ = [
    "MODES",
    "PHASES",
    "AnalyticController",
]

#: Controller modes.
MODES = ("simultaneous", "sequential")
#: Phases of the sequential mode, in order (the state carries their index).
PHASES = ("rotate", "vertical", "horizontal")
ROTATE, VERTICAL, HORIZONTAL = 0, 1, 2

FloatArray = NDArray[np.float64]


class AnalyticController(BatchPolicy):
    """Simple-motion controller with the calling convention of an SB3 policy.

    Args:
        design: the machine (its ``L_iG`` and ``max_speed``); default ``Design.fig8()``.
        mode: ``"simultaneous"`` (superposed simple motions, resolved-rate control) or
            ``"sequential"`` (rotation, then vertical, then horizontal translation).
        position_gain: ``k_p`` (1/s): commanded gripper speed per metre of position error.
        orientation_gain: ``k_theta`` (1/s): commanded angular velocity per radian of error.
        speed_fraction: the largest slider rate commanded, as a fraction of ``max_speed``.
        serial_epsilon: floor of ``|cos alpha_i|`` in the division by ``cos alpha_i``.
        serial_slow, serial_stop: a motion that brings a leg towards a serial singularity is
            slowed down once ``|cos alpha_i| < serial_slow``, linearly to a stop at
            ``serial_stop``, so the controller never pushes a leg across (which would change
            the working mode).
        rotation_done, rotation_reenter: sequential mode: the rotation phase ends when
            ``|e_theta| <= rotation_done`` and is re-entered when ``|e_theta| >
            rotation_reenter`` (rad).
        vertical_done, vertical_reenter: the same for ``|e_y|`` and the vertical phase (m).
        observation_size: length of the observations :meth:`predict` accepts (at least the
            31 entries of ``Planar3P-v0``, which are the ones read; default the class's
            ``obs_size``): the flat observation of the id the controller plays on.

    :meth:`predict` returns actions in ``[-1, 1]`` (slider rates over ``max_speed``), float32.
    """

    def __init__(
        self,
        design: Design | None = None,
        mode: str = "simultaneous",
        *,
        position_gain: float = 6.0,
        orientation_gain: float = 6.0,
        speed_fraction: float = 1.0,
        serial_epsilon: float = 0.01,
        serial_slow: float = 0.15,
        serial_stop: float = 0.05,
        rotation_done: float = math.radians(0.3),
        rotation_reenter: float = math.radians(0.8),
        vertical_done: float = 0.0006,
        vertical_reenter: float = 0.0012,
        observation_size: int | None = None,
    ) -> None:
        if mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
        self._use_design(design)
        for name, value in (
            ("position_gain", position_gain),
            ("orientation_gain", orientation_gain),
            ("speed_fraction", speed_fraction),
            ("rotation_done", rotation_done),
            ("rotation_reenter", rotation_reenter),
            ("vertical_done", vertical_done),
            ("vertical_reenter", vertical_reenter),
        ):
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0, got {value!r}")
        if not (math.isfinite(serial_epsilon) and 0 < serial_epsilon < 1):
            raise ValueError(f"serial_epsilon must be in (0, 1), got {serial_epsilon!r}")
        if not 0 < serial_stop < serial_slow < 1:
            raise ValueError(
                f"need 0 < serial_stop < serial_slow < 1, got {serial_stop!r}, {serial_slow!r}"
            )
        if speed_fraction > 1:
            raise ValueError(f"speed_fraction must be in (0, 1], got {speed_fraction!r}")
        if rotation_reenter < rotation_done or vertical_reenter < vertical_done:
            raise ValueError("re-entry thresholds must not be below the phase-done thresholds")
        self.mode = mode
        self.position_gain = float(position_gain)
        self.orientation_gain = float(orientation_gain)
        self.speed_fraction = float(speed_fraction)
        self.serial_epsilon = float(serial_epsilon)
        self.serial_slow = float(serial_slow)
        self.serial_stop = float(serial_stop)
        self.rotation_done = float(rotation_done)
        self.rotation_reenter = float(rotation_reenter)
        self.vertical_done = float(vertical_done)
        self.vertical_reenter = float(vertical_reenter)
        self._use_observation_size(observation_size)
        self._phase: NDArray[np.int64] | None = None

    #: Default length of the observations :meth:`predict` accepts (``observation_size``
    #: overrides it per controller; subclasses may need more entries).
    obs_size: int = OBS_SIZE

    @classmethod
    def from_env(cls, env: Any, mode: str = "simultaneous", **kwargs: Any) -> AnalyticController:
        """A controller for the design and the flat observation of ``env`` (an env of the
        package, possibly wrapped; :func:`planar3p_agents.controllers.layout.
        observation_layout`).  ``ValueError`` for a goal env (``Dict`` observation): use
        :func:`planar3p_agents.policies.factory.load_policy`, which adds the goal adapter."""
        from planar3p_agents.controllers.layout import observation_layout

        layout = observation_layout(env)
        if layout.goal:
            raise ValueError(
                f"{layout.env_id} has a Dict observation: use "
                f"planar3p_agents.policies.factory.load_policy(name, env)"
            )
        kwargs.setdefault("observation_size", layout.size)
        return cls(env.unwrapped.design, mode, **kwargs)

    def __repr__(self) -> str:
        return (
            f"AnalyticController(mode={self.mode!r}, position_gain={self.position_gain}, "
            f"orientation_gain={self.orientation_gain}, speed_fraction={self.speed_fraction})"
        )

    # ------------------------------------------------------------------ SB3-style API
    def reset(self, seed: Any = None) -> None:
        """Forget the remembered phases (a new episode starts in the rotation phase);
        ``seed`` is accepted for the benchmark's calling convention (nothing is random)."""
        self._phase = None

    def act(
        self, obs: FloatArray, state: Any, starts: NDArray[np.bool_], deterministic: bool
    ) -> tuple[np.ndarray, Any]:
        """Actions for the batch ``obs`` ``(n, obs_size)`` (through :meth:`predict`).

        ``state`` is the phase index per environment (sequential mode; ``None`` for the
        simultaneous mode, like an SB3 feed-forward policy).  If ``state`` is ``None`` the
        controller uses the phases it remembers from its last call (same batch size), so a
        plain loop that ignores the returned state still works.  ``starts`` (SB3's
        ``episode_start``) resets the phase of the environments that start a new episode.
        ``deterministic`` is accepted for compatibility (the controller is deterministic).
        """
        n = obs.shape[0]
        # A non-finite reading (a sensor fault) must not propagate into the command.
        obs2 = np.nan_to_num(obs, nan=0.0, posinf=0.0, neginf=0.0)
        phase = self._phases(state, starts, n)
        rates, phase = self._rates(obs2, phase)
        action = np.clip(rates / self.design.max_speed, -1.0, 1.0)
        action = np.where(np.isfinite(action), action, 0.0).astype(np.float32)
        if self.mode == "sequential":
            self._phase = phase.copy()
            return action, phase.copy()
        return action, None

    def __call__(self, observation: ArrayLike) -> np.ndarray:
        """The action for ``observation`` (stateless use; the sequential phase is remembered)."""
        return self.predict(observation)[0]

    # ------------------------------------------------------------------ internals
    def _phases(self, state: Any, starts: NDArray[np.bool_], n: int) -> NDArray[np.int64]:
        if self.mode != "sequential":
            return np.zeros(n, dtype=np.int64)
        if state is not None:
            phase = np.asarray(state, dtype=np.int64).reshape(-1).copy()
            if phase.shape != (n,):
                raise ValueError(f"state must hold one phase per observation ({n}), got {state!r}")
        elif self._phase is not None and self._phase.shape == (n,):
            phase = self._phase.copy()
        else:
            phase = np.zeros(n, dtype=np.int64)
        phase = np.clip(phase, ROTATE, HORIZONTAL)
        phase[starts] = ROTATE
        return phase

    def _rates(
        self, obs: FloatArray, phase: NDArray[np.int64]
    ) -> tuple[FloatArray, NDArray[np.int64]]:
        legs = obs[:, SLICES["legs"]].reshape(-1, 3, 2)
        cos_a = legs[..., 0]
        orient = obs[:, SLICES["orientation"]]
        err_p = obs[:, SLICES["position_error"]]
        err_th = obs[:, SLICES["orientation_error"]][:, 0]
        basis = kinematics.simple_motion_basis(
            self.design, cos_a, legs[..., 1], orient[:, 0], orient[:, 1], self.serial_epsilon
        )
        # The twist of each simple motion: columns x_dot, y_dot, theta_dot.
        n = obs.shape[0]
        motions = np.zeros((3, n, 3))
        motions[HORIZONTAL, :, 0] = self.position_gain * err_p[:, 0]
        motions[VERTICAL, :, 1] = self.position_gain * err_p[:, 1]
        motions[ROTATE, :, 2] = self.orientation_gain * err_th
        if self.mode == "sequential":
            errors = np.stack([np.abs(err_th), np.abs(err_p[:, 1])], axis=1)
            phase = self._advance(phase, errors)
            twist = motions[phase, np.arange(n)]
        else:
            twist = motions.sum(axis=0)
            feedforward = self._feedforward(obs)
            if feedforward is not None:
                twist = twist + feedforward
        rates = _to_rates(twist, basis)
        brake = self._brake(cos_a, orient[:, 1], twist, rates)
        rates = np.where(np.isfinite(rates), rates, 0.0)
        limit = self.speed_fraction * self.design.max_speed
        peak = np.max(np.abs(rates), axis=1, keepdims=True)
        scale = np.where(peak > limit, limit / np.maximum(peak, 1e-300), 1.0)
        return rates * (scale * brake[:, None]), phase

    def _feedforward(self, obs: FloatArray) -> FloatArray | None:
        """A twist ``(n, 3)`` added to the feedback twist (simultaneous mode); none here."""
        return None

    def _brake(
        self, cos_a: FloatArray, sin_th: FloatArray, twist: FloatArray, rates: FloatArray
    ) -> FloatArray:
        """Speed factor in ``[0, 1]`` per observation: 1 unless the motion brings a leg
        towards a serial singularity (``|cos alpha_i|`` decreasing) within ``serial_slow`` of
        it; then linear in ``|cos alpha_i|``, reaching 0 at ``serial_stop``.

        ``d cos(alpha_i)/dt = (x_dot - L_iG sin(theta) theta_dot - rho_dot_i) / L_i``.  The
        brake scales the whole motion, so the platform keeps its direction and halts before
        the leg flips over (which would change the working mode).  Motions away from the
        singularity are never braked.
        """
        k = np.asarray(self.design.joint_offsets)
        dux = twist[:, 0:1] - k * sin_th[:, None] * twist[:, 2:3] - rates
        # Exactly at the singularity any motion of the leg crosses it: brake that too.
        approaching = (cos_a * dux < 0.0) | ((cos_a == 0.0) & (dux != 0.0))
        g = np.clip(
            (np.abs(cos_a) - self.serial_stop) / (self.serial_slow - self.serial_stop), 0.0, 1.0
        )
        return np.where(approaching, g, 1.0).min(axis=1)

    def _advance(self, phase: NDArray[np.int64], errors: FloatArray) -> NDArray[np.int64]:
        """One step of the phase machine; ``errors`` is ``(n, 2)``: ``|e_theta|, |e_y|``.
        Satisfied phases are skipped; a phase is re-entered when its error grows past its
        re-entry threshold (the hysteresis keeps the machine from chattering)."""
        phase = phase.copy()
        e_th, e_y = errors[:, 0], errors[:, 1]
        phase[(phase == ROTATE) & (e_th <= self.rotation_done)] = VERTICAL
        phase[(phase == VERTICAL) & (e_y <= self.vertical_done)] = HORIZONTAL
        back_rot = (phase > ROTATE) & (e_th > self.rotation_reenter)
        phase[back_rot] = ROTATE
        phase[~back_rot & (phase > VERTICAL) & (e_y > self.vertical_reenter)] = VERTICAL
        return phase


def _to_rates(twist: FloatArray, basis: tuple[FloatArray, FloatArray, FloatArray]) -> FloatArray:
    """Slider rates ``(n, 3)`` of twists ``(n, 3)`` from
    :func:`~planar3p_gym.machine.kinematics.simple_motion_basis`."""
    hor, ver, rot = basis
    return twist[:, 0:1] * hor + twist[:, 1:2] * ver + twist[:, 2:3] * rot
