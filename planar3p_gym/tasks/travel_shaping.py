"""An optional reward term towards the target's slider travels (a training aid).

In the mode- and assembly-change tasks the target pose lies in another working or assembly mode,
so the pose error alone pulls the platform towards the target pose *in the current mode*, a
dead end.  ``travel = -w * sum_i |rho_i - rho_i^t| / L`` (``rho`` the slider travels after the
step, ``rho^t`` the target's travels in its mode, ``L`` the design's characteristic length, m)
pulls towards the travels that end in the target's mode.  It changes only the reward, never the
success test; the default weight 0 adds no term.

- :func:`travel_term`: the term (compiled), the one definition the single env's hook
  (:meth:`TravelShaping.step_travel`) and the native vector env's batched steps
  (:func:`travel_rows`) compute;
- :class:`TravelShaping`: the tasks' mixin that adds it to their reward.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from planar3p_gym import checks
from planar3p_gym.tasks.rewards import MAX_WEIGHT

__all__ = ["TravelShaping", "check_travel_shaping", "travel_rows", "travel_term"]


def check_travel_shaping(value: Any) -> float:
    """``value`` as a weight in ``[0, MAX_WEIGHT]`` (dimensionless, per step), else
    ``ValueError``."""
    return checks.number(value, "travel_shaping", low=0.0, high=MAX_WEIGHT)


@njit(cache=True)
def travel_term(
    weight: float, r0: float, r1: float, r2: float, t0: float, t1: float, t2: float,
    length: float,
) -> float:  # fmt: skip
    """``-weight * sum_i |r_i - t_i| / length``: the travel term of travels ``r`` (m) to the
    target's ``t`` (m), ``length`` the characteristic length (m)."""
    distance = 0.0
    distance += abs(r0 - t0)
    distance += abs(r1 - t1)
    distance += abs(r2 - t2)
    return -weight * distance / length


@njit(cache=True)
def travel_rows(
    rows: np.ndarray, states: np.ndarray, res: np.ndarray, weight: float,
    target_rho: np.ndarray, length: float, travel: np.ndarray,
) -> None:  # fmt: skip
    """The travel term of a batched step: for each row ``j`` (environment ``rows[j]``, its
    travels ``states[0:3, j]``, m) the term to its target's travels ``target_rho[rows[j]]``
    (``(N, 3)``, m) into ``travel[j]`` and added to its reward ``res[0, j]`` (after the other
    terms, as the single env sums them).  Rows whose physics broke down take the reference
    kernel's step instead."""
    for j in range(rows.shape[0]):
        i = rows[j]
        t = travel_term(
            weight, states[0, j], states[1, j], states[2, j], target_rho[i, 0],
            target_rho[i, 1], target_rho[i, 2], length,
        )  # fmt: skip
        travel[j] = t
        res[0, j] += t


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

    @property
    def target_travels(self) -> tuple[float, float, float]:
        """The target's slider travels in its mode (m), which the term pulls towards."""
        return self._target_rho

    def step_travel(self, rho: tuple[float, float, float]) -> float:
        """The travel term of a step to travels ``rho`` (m; :func:`travel_term`); finite
        travels become the fallback of later steps."""
        if all(math.isfinite(r) for r in rho):
            self._shaping_rho = rho
        r0, r1, r2 = self._shaping_rho
        t0, t1, t2 = self._target_rho
        length = self.env.design.characteristic_length
        return travel_term(float(self.travel_shaping), r0, r1, r2, t0, t1, t2, length)

    def reward_terms(self, **kwargs: Any) -> dict[str, float]:
        terms: dict[str, float] = super().reward_terms(**kwargs)  # type: ignore[misc]
        if self.travel_shaping:
            terms["travel"] = self.step_travel(kwargs["state"].rho)
        return terms
