"""Latency: the control steps between an action and its effect, and between a state and its
observation.

A :class:`LatencyConfig` gives the range of each delay in whole control steps (0 to
:data:`MAX_DELAY`); an environment draws each delay once per episode, uniformly from its range
(no random number for a fixed delay).  With an action delay ``n`` the machine executes at step
``t`` the action chosen at step ``t - n`` (a stop during the first ``n`` steps); with an
observation delay ``m`` the policy sees at step ``t`` the observation of step ``t - m`` (the
reset's observation during the first ``m`` steps).  Success, reward and termination are judged
on the current true state.  :class:`DelayLine` is a fixed-length first-in first-out buffer (a
:class:`collections.deque` with ``maxlen``, which drops the oldest item itself).
"""

from __future__ import annotations

from collections import deque
from dataclasses import asdict, dataclass, fields
from typing import Any

import numpy as np

from planar3p_gym import checks

__all__ = ["MAX_DELAY", "REALISTIC_LATENCY", "DelayLine", "LatencyConfig"]

#: Largest delay accepted (control steps).
MAX_DELAY = 2


def _steps(value: Any, name: str) -> tuple[int, int]:
    """``value`` as an inclusive range ``(low, high)`` of delays in steps: an integer or a pair."""
    if isinstance(value, (list, tuple)):
        if len(value) != 2:
            raise ValueError(f"{name} must be an integer or a pair (low, high), got {value!r}")
        low = checks.integer(value[0], f"{name}[0]", low=0, high=MAX_DELAY)
        high = checks.integer(value[1], f"{name}[1]", low=0, high=MAX_DELAY)
        if high < low:
            raise ValueError(f"{name} must have low <= high, got {value!r}")
        return (low, high)
    n = checks.integer(value, name, low=0, high=MAX_DELAY)
    return (n, n)


@dataclass(frozen=True)
class LatencyConfig:
    """Ranges of the per-episode delays (control steps, inclusive; an integer is a fixed delay).

    Attributes:
        action_delay: steps between choosing an action and the machine executing it.
        observation_delay: steps between a state and the policy observing it.
    """

    action_delay: tuple[int, int] | int = (0, 0)
    observation_delay: tuple[int, int] | int = (0, 0)

    def __post_init__(self) -> None:
        for f in fields(self):
            object.__setattr__(
                self, f.name, _steps(getattr(self, f.name), f"LatencyConfig.{f.name}")
            )

    @property
    def is_zero(self) -> bool:
        """True when there is no delay."""
        return self.action_delay == (0, 0) and self.observation_delay == (0, 0)

    def to_dict(self) -> dict[str, list[int]]:
        """Plain-Python dictionary of the fields."""
        return {k: list(v) for k, v in asdict(self).items()}

    def sample(self, rng: np.random.Generator) -> tuple[int, int]:
        """``(action delay, observation delay)`` of one episode, drawn from ``rng`` (uniform
        integers; no draw for a fixed delay)."""
        out = []
        for low, high in (self.action_delay, self.observation_delay):  # type: ignore[misc]
            out.append(low if low == high else int(rng.integers(low, high + 1)))
        return out[0], out[1]


class DelayLine:
    """Delays a stream by ``delay`` items: :meth:`push` returns the item pushed ``delay`` pushes
    earlier (the fill value before that)."""

    def __init__(self, delay: int, fill: Any) -> None:
        self.delay = int(delay)
        self._items: deque[Any] = deque([fill] * self.delay, maxlen=self.delay + 1)

    def push(self, item: Any) -> Any:
        """Add ``item``; return the item ``delay`` pushes old."""
        self._items.append(item)
        return self._items[0]

    @property
    def items(self) -> list[Any]:
        """The items held, oldest first (``delay`` of them, or ``delay + 1`` after a push: the
        oldest is the one the last push returned)."""
        return list(self._items)

    @items.setter
    def items(self, values: list[Any]) -> None:
        self._items.clear()
        self._items.extend(values)


#: The latency of ``Planar3PReal-v0``: one control step between an action and its execution.
REALISTIC_LATENCY = LatencyConfig(action_delay=1, observation_delay=0)
