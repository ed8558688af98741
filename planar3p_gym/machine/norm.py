"""The length of a plane vector, compiled, with Python's own rounding.

* :func:`hypot` -- ``sqrt(x^2 + y^2)`` by the algorithm of CPython's ``math.hypot`` (exact
  squares and sums in double length, a square root and one differential correction): the
  same float, bit for bit, as ``math.hypot`` gives for every length of at least the smallest
  normal double (below it, within an ulp), where the platform's C ``hypot`` (what numba and
  numpy call) differs from it in the last bit for some inputs.  Compiled code that must
  reproduce a Python step's errors calls this one.
"""

from __future__ import annotations

import math
import sys

from numba import njit

__all__ = ["hypot"]

#: Dekker's splitting constant ``2^27 + 1``: a double times it splits into two 26-bit halves.
_SPLIT = 134217729.0
#: The smallest normal double (below it the scaling by a power of two would overflow).
_DBL_MIN = sys.float_info.min


@njit(cache=True)
def _square(x: float) -> tuple[float, float]:
    """``x * x`` as ``(hi, lo)`` with ``hi + lo`` exact (Dekker's product)."""
    hi = x * x
    c = _SPLIT * x
    xh = c - (c - x)
    xl = x - xh
    lo = ((xh * xh - hi) + xh * xl + xl * xh) + xl * xl
    return hi, lo


@njit(cache=True)
def _norm(x: float, y: float, top: float) -> float:
    """The length of ``(x, y)`` (both >= 0, finite, the larger ``top`` > 0, normal)."""
    _, e = math.frexp(top)
    scale = math.ldexp(1.0, -e)
    csum, frac1, frac2 = 1.0, 0.0, 0.0
    for v in (x, y):
        hi, lo = _square(v * scale)  # (lossless scaling and squaring)
        total = csum + hi
        frac2 += (csum - total) + hi
        csum = total
        frac1 += lo
    h = math.sqrt(csum - 1.0 + (frac1 + frac2))
    hi, lo = _square(h)
    total = csum - hi
    frac2 += (csum - total) - hi
    csum = total
    frac1 -= lo
    h += (csum - 1.0 + (frac1 + frac2)) / (2.0 * h)  # the differential correction
    return h / scale


@njit(cache=True)
def hypot(x: float, y: float) -> float:
    """``sqrt(x^2 + y^2)`` rounded as Python's ``math.hypot`` rounds it (module docstring)."""
    x, y = abs(x), abs(y)
    if math.isinf(x) or math.isinf(y):
        return math.inf
    if math.isnan(x) or math.isnan(y):
        return math.nan
    top = max(x, y)
    if top == 0.0:
        return top
    if top < _DBL_MIN:  # subnormals: scaled up to normals first
        return _DBL_MIN * _norm(x / _DBL_MIN, y / _DBL_MIN, top / _DBL_MIN)
    return _norm(x, y, top)
