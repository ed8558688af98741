"""Checks and parsing of ``Planar3PEnv``'s arguments: constructor settings, actions and
``reset`` options (plain functions; ``ValueError`` with a clear message on bad input)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import fields
from typing import Any

import numpy as np

from planar3p_gym.machine.design import Design

__all__ = [
    "RESET_OPTIONS",
    "check_reset_options",
    "config_from",
    "design_from",
    "is_int",
    "is_number",
    "mode_from",
    "parse_action",
]


def design_from(arg: Design | dict | str | None) -> Design:
    """A :class:`Design` from ``None`` (``Design.fig8()``), a design, a dict of its fields or a
    preset name (``"fig8"``, ``"fig7"``), or ``ValueError``."""
    if arg is None:
        return Design.fig8()
    if isinstance(arg, Design):
        return arg
    if isinstance(arg, dict):
        return Design.from_dict(arg)
    if isinstance(arg, str):
        presets = {"fig8": Design.fig8, "fig7": Design.fig7}
        if arg not in presets:
            raise ValueError(f"unknown design preset {arg!r}; known: {sorted(presets)}")
        return presets[arg]()
    raise ValueError(f"design must be a Design, a dict of its fields or a preset name, got {arg!r}")


def is_number(value: Any) -> bool:
    """A finite real number (``bool`` excluded)."""
    return (
        isinstance(value, (int, float, np.integer, np.floating))
        and not isinstance(value, (bool, np.bool_))
        and math.isfinite(value)
    )


def is_int(value: Any) -> bool:
    """An integer (``bool`` excluded)."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def config_from(arg: Any, cls: type, name: str) -> Any:
    """A config dataclass from ``None`` (defaults), an instance, or a dict of its fields."""
    if arg is None:
        return cls()
    if isinstance(arg, cls):
        return arg
    if isinstance(arg, dict):
        known = {f.name for f in fields(cls)}
        unknown = set(arg) - known
        if unknown:
            raise ValueError(f"unknown {name} fields {sorted(unknown)}; known: {sorted(known)}")
        return cls(**arg)
    raise ValueError(f"{name} must be a {cls.__name__} or a dict of its fields, got {arg!r}")


def parse_action(action: Any) -> tuple[float, float, float]:
    """An action as three finite floats clipped to ``[-1, 1]``, or ``ValueError``.

    Accepts a sequence or array of 3 real numbers (Python or NumPy ints and floats); rejects
    strings, booleans, complex numbers, wrong shapes, NaN/inf and values too large for a float.
    """
    if type(action) is np.ndarray and action.shape == (3,) and action.dtype.char in "fd":
        a0, a1, a2 = action.tolist()  # the common case, without the general checks' overhead
        if a0 * 0.0 == 0.0 and a1 * 0.0 == 0.0 and a2 * 0.0 == 0.0:  # finite (inf, NaN: NaN)
            return (
                -1.0 if a0 < -1.0 else (1.0 if a0 > 1.0 else a0),
                -1.0 if a1 < -1.0 else (1.0 if a1 > 1.0 else a1),
                -1.0 if a2 < -1.0 else (1.0 if a2 > 1.0 else a2),
            )
    if isinstance(action, (list, tuple)) and any(
        isinstance(v, (bool, np.bool_, str, bytes)) for v in action
    ):  # NumPy would turn [True, 0, 0] into integers and keep "1" as a string
        raise ValueError(f"action must be 3 real numbers in [-1, 1], got {_short(action)}")
    try:
        arr = np.asarray(action)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ValueError(f"action must be 3 real numbers in [-1, 1], got {_short(action)}") from exc
    if arr.dtype.kind == "O" and arr.shape == (3,):  # e.g. Python ints beyond int64
        arr = np.array([_real_to_float(v) for v in arr.tolist()])
    if arr.dtype.kind not in "fiu":
        raise ValueError(f"action must be 3 real numbers in [-1, 1], got {_short(action)}")
    if arr.shape != (3,):
        raise ValueError(f"action must have shape (3,), got shape {arr.shape}")
    a0, a1, a2 = arr.astype(np.float64).tolist()
    if not (math.isfinite(a0) and math.isfinite(a1) and math.isfinite(a2)):
        raise ValueError(f"action must be finite, got {_short(action)}")
    a0 = -1.0 if a0 < -1.0 else (1.0 if a0 > 1.0 else a0)
    a1 = -1.0 if a1 < -1.0 else (1.0 if a1 > 1.0 else a1)
    a2 = -1.0 if a2 < -1.0 else (1.0 if a2 > 1.0 else a2)
    return a0, a1, a2


def _real_to_float(value: Any) -> Any:
    """A real number as a float (``inf`` if too large); anything else unchanged (rejected)."""
    if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_)
    ):
        try:
            return float(value)
        except OverflowError:
            return math.inf if value > 0 else -math.inf
    return value


def _short(value: Any, limit: int = 80) -> str:
    """``repr(value)`` cut to ``limit`` characters (for error messages)."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


#: Keys ``reset(options=...)`` understands.
RESET_OPTIONS = ("start", "target", "working_mode")


def check_reset_options(options: Any, keys: tuple[str, ...] = RESET_OPTIONS) -> dict[str, Any]:
    """``reset``'s ``options`` as a plain dict with only ``keys``, or ``ValueError``.

    Checks the container and keys and parses ``working_mode``; the poses are checked later
    against the episode's working mode.  Called before the environment is seeded, so a
    rejected reset leaves the random stream untouched.
    """
    if options is None:
        return {}
    if not isinstance(options, Mapping):
        raise ValueError(f"reset options must be a dict (keys: {', '.join(keys)}), got {options!r}")
    out = dict(options)
    unknown = [k for k in out if k not in keys]
    if unknown:
        raise ValueError(
            f"unknown reset options {sorted(map(str, unknown))}; known: {', '.join(keys)}"
        )
    if out.get("working_mode") is not None:
        out["working_mode"] = mode_from(out["working_mode"])
    return out


def mode_from(arg: Any) -> tuple[int, int, int]:
    """A working mode (three entries of +1 or -1) as a tuple of ints, or ``ValueError``."""
    try:
        m = tuple(int(v) for v in arg)
        ok = len(m) == 3 and all(v in (1, -1) for v in m) and all(float(v) == int(v) for v in arg)
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ValueError(f"working_mode must be three entries of +1 or -1, got {arg!r}")
    return m  # type: ignore[return-value]
