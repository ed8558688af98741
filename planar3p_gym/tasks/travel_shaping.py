"""An optional reward term towards the target's slider travels (a training aid).

In the mode- and assembly-change tasks the target pose lies in another working or assembly mode,
so the pose error alone pulls the platform towards the target pose *in the current mode*, a
dead end.  ``travel = -w * sum_i |rho_i - rho_i^t| / L`` (``rho`` the slider travels after the
step, ``rho^t`` the target's travels in its mode, ``L`` the design's characteristic length, m)
pulls towards the travels that end in the target's mode.  It changes only the reward, never the
success test; the default weight 0 adds no term.
"""

from __future__ import annotations

import math
from typing import Any

from planar3p_gym import checks
from planar3p_gym.tasks.rewards import MAX_WEIGHT

__all__ = ["TravelShaping", "check_travel_shaping"]


def check_travel_shaping(value: Any) -> float:
    """``value`` as a weight in ``[0, MAX_WEIGHT]`` (dimensionless, per step), else
    ``ValueError``."""
    return checks.number(value, "travel_shaping", low=0.0, high=MAX_WEIGHT)


class TravelShaping:
    """Mixin of a :class:`~planar3p_gym.tasks.base.Task` that keeps the target's travels in
    ``self._target_rho`` (m): with ``self.travel_shaping > 0`` its reward gains the ``travel``
    term.  The task calls :meth:`start_travels` when an episode begins."""

    travel_shaping: float = 0.0
    _target_rho: tuple[float, float, float]
    env: Any

    def shaping_arguments(self) -> dict[str, Any]:
        """``{"travel_shaping": w}`` when the term is on, else ``{}`` (for
        :meth:`Task.arguments`)."""
        return {"travel_shaping": self.travel_shaping} if self.travel_shaping else {}

    def start_travels(self, rho: Any) -> None:
        """The travels at the episode's start (m): the term's fallback while no finite state
        has been seen (a step that breaks the physics down keeps the last finite travels)."""
        self._shaping_rho = (float(rho[0]), float(rho[1]), float(rho[2]))

    def reward_terms(self, **kwargs: Any) -> dict[str, float]:
        terms: dict[str, float] = super().reward_terms(**kwargs)  # type: ignore[misc]
        if self.travel_shaping:
            rho = kwargs["state"].rho
            if all(math.isfinite(r) for r in rho):
                self._shaping_rho = rho
            distance = sum(
                abs(a - b) for a, b in zip(self._shaping_rho, self._target_rho, strict=True)
            )
            length = self.env.design.characteristic_length
            terms["travel"] = -self.travel_shaping * distance / length
        return terms
