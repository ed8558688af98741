"""Type checks shared by the configuration dataclasses (plain numbers, NumPy scalars, no bools)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["as_finite_float", "as_int"]


def as_finite_float(value: Any) -> float | None:
    """``value`` as a Python float if it is a finite real number (Python or NumPy int or float,
    ``bool`` excluded), else ``None``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(
        value, (int, float, np.integer, np.floating)
    ):
        return None
    try:
        out = float(value)
    except OverflowError:  # an int beyond the float range
        return None
    return out if math.isfinite(out) else None


def as_int(value: Any) -> int | None:
    """``value`` as a Python int if it is an integer (Python or NumPy, ``bool`` excluded), else
    ``None``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        return None
    return int(value)
