"""The one angle wrap of the package.

* :func:`wrap_angle` -- an angle (rad), a float or an array of any shape, wrapped into
  ``(-pi, pi]``, the range of ``atan2``.  It is compiled, so the fast paths call it as they are;
  plain Python calls it as well.  A torch twin in the agents' goal feature extractor is tested
  against it.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["wrap_angle"]


@njit(cache=True)
def wrap_angle(angle: float | np.ndarray) -> float | np.ndarray:
    """``angle`` (rad; a float or an array) wrapped into ``(-pi, pi]``."""
    return math.pi - (math.pi - angle) % (2.0 * math.pi)
