"""On-off control: a continuous controller's slider rates turned into the prototype's motor
commands (stop, forward, backward) by a dead-band bang-bang law.

The paper's prototype drove its sliders with DC motors switched on and off; its controller ran
each motor at its rated speed in the direction of the slider's required motion and stopped it
when that motion was small.  :class:`OnOffController` does this with any controller of the
package (by default the simultaneous simple motions,
:class:`~planar3p_agents.controllers.analytic.AnalyticController`), with two dead bands:

* **task space**: every motor stops while the observed position and orientation errors are
  within ``position_band`` and ``orientation_band`` (half the reach task's tolerances by
  default), so the machine comes to rest inside the tolerance instead of chattering around
  the target;
* **per slider**: slider ``i`` runs (forward where the commanded rate ``u_i`` is positive,
  backward where negative) only while ``|u_i|`` is at least ``relative`` times the largest
  ``|u_j|`` and above ``deadband`` (a fraction of ``max_speed``): the sliders that the
  continuous law barely moves stay still, so the motion keeps roughly its direction.

On-off motion is coarse: one control step at the rated speed moves a slider by
``on_off_speed max_speed dt`` (0.4 mm by default), which near a parallel singularity moves
the gripper by millimetres; there the law may cycle without settling.  Actions are
``MultiDiscrete([3, 3, 3])`` entries or, for the ``Discrete(27)`` variant, their base-3 index
(:func:`planar3p_gym.envs.actuation.on_off_action`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from planar3p_gym import checks
from planar3p_gym.tasks.observation import SLICES

__all__ = ["DEFAULT_DEADBAND", "OnOffController"]

#: Default per-slider dead band (fraction of ``max_speed``).
DEFAULT_DEADBAND = 0.005
_PLACES = np.array([9, 3, 1], dtype=np.int64)
_POS = SLICES["position_error"]
_ANG = SLICES["orientation_error"].start


class OnOffController:
    """Dead-band bang-bang motor commands from a continuous controller (module docstring).

    Args:
        inner: a policy with SB3's ``predict`` whose actions are slider rates in ``[-1, 1]``,
            on the flat observations of the package (which start with the 31 entries of
            :mod:`planar3p_gym.tasks.observation`).
        discrete: return ``Discrete(27)`` indices instead of ``MultiDiscrete([3, 3, 3])``
            triples.
        position_band: all motors stop within this position error (m).
        orientation_band: ... and this orientation error (rad).
        relative: a slider runs only if its rate is at least this share of the largest one.
        deadband: ... and above this fraction of ``max_speed``.
    """

    def __init__(
        self,
        inner: Any,
        *,
        discrete: bool = False,
        position_band: float = 0.001,
        orientation_band: float = math.radians(0.5),
        relative: float = 0.3,
        deadband: float = DEFAULT_DEADBAND,
    ) -> None:
        if not callable(getattr(inner, "predict", None)):
            raise ValueError(f"inner must have a predict method, got {inner!r}")
        if not isinstance(discrete, (bool, np.bool_)):
            raise ValueError(f"discrete must be True or False, got {discrete!r}")
        self.position_band = checks.number(position_band, "position_band", low=0.0, unit="m")
        self.orientation_band = checks.number(
            orientation_band, "orientation_band", low=0.0, unit="rad"
        )
        self.relative = checks.number(relative, "relative", low=0.0, high=1.0)
        self.deadband = checks.number(deadband, "deadband", low=0.0, high=1.0, high_open=True)
        self.inner = inner
        self.discrete = bool(discrete)

    def __repr__(self) -> str:
        return f"OnOffController({self.inner!r}, discrete={self.discrete})"

    def reset(self, seed: Any = None) -> None:
        """Reset the inner controller's memory, if it has one."""
        reset = getattr(self.inner, "reset", None)
        if callable(reset):
            reset()

    def predict(
        self,
        observation: ArrayLike,
        state: Any = None,
        episode_start: ArrayLike | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        """Motor commands (``int64``: ``(3,)`` / ``(n, 3)``, or ``()`` / ``(n,)`` indices with
        ``discrete``) for observation(s) ``(d,)`` or ``(n, d)``, and the inner state."""
        rates, new_state = self.inner.predict(observation, state, episode_start, deterministic)
        u = np.atleast_2d(np.asarray(rates, dtype=np.float64))
        obs = np.atleast_2d(np.asarray(observation, dtype=np.float64))
        at_rest = (np.hypot(obs[:, _POS.start], obs[:, _POS.start + 1]) <= self.position_band) & (
            np.abs(obs[:, _ANG]) <= self.orientation_band
        )
        mag = np.abs(u)
        run = (mag >= self.relative * mag.max(axis=1, keepdims=True)) & (mag > self.deadband)
        run &= ~at_rest[:, None]
        digits = np.where(run, np.where(u > 0.0, 1, 2), 0).astype(np.int64)
        out = digits @ _PLACES if self.discrete else digits
        return (out[0] if np.ndim(rates) == 1 else out), new_state
