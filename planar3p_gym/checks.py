"""Argument checks of the whole package, in one place, with one set of rules.

Every constructor argument, ``reset`` option, action and goal of the environments, and every
field of their configuration dataclasses, is checked here:

* a **number** is a Python or NumPy integer or float (or a 0-d array of one) alike;
  ``bool``/``numpy.bool_``, complex numbers, strings and ``None`` are not numbers;
* a number must be finite unless said otherwise (an integer too large for a float is not);
* an **integer** is a Python or NumPy integer (not a float, not a bool);
* a **flag** is ``True``/``False`` (Python or NumPy);
* an **array of numbers** (a pose, an action, a goal) is a sequence or array of such numbers
  (any real NumPy dtype; lists may mix Python and NumPy numbers; tensors that NumPy can read
  are accepted), with the stated shape;
* every rejection is a ``ValueError`` whose message names the argument (never a
  ``TypeError``, ``OverflowError`` or another exception type).

Plain functions: the ``as_*``/``is_*`` ones answer without raising, the others return the
parsed value or raise.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import fields, is_dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from planar3p_gym.machine.design import Design

__all__ = [
    "DESIGN_LIMITS",
    "as_finite_float",
    "as_int",
    "check_env_design",
    "check_reset_options",
    "choice",
    "config_from",
    "count",
    "design_from",
    "flag",
    "integer",
    "is_int",
    "is_number",
    "is_real",
    "mode_from",
    "number",
    "numbers",
    "parse_action",
    "parse_actions",
    "real_array",
    "seed",
    "short",
]

_REAL = (int, float, np.integer, np.floating)
_BOOL = (bool, np.bool_)


# ------------------------------------------------------------------ scalars, without raising
def is_real(value: Any) -> bool:
    """A real number: a Python or NumPy int or float, or a 0-d array of one (not a bool,
    not complex; may be infinite or NaN)."""
    if isinstance(value, _BOOL):
        return False
    if isinstance(value, _REAL):
        return True
    return isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf"


def as_finite_float(value: Any) -> float | None:
    """``value`` as a Python float if it is a finite real number (:func:`is_real`), else
    ``None`` (also for an integer beyond the float range)."""
    if not is_real(value):
        return None
    try:
        out = float(value)
    except OverflowError:  # an int beyond the float range
        return None
    return out if math.isfinite(out) else None


def as_int(value: Any) -> int | None:
    """``value`` as a Python int if it is an integer (Python or NumPy, or a 0-d integer array;
    ``bool`` excluded), else ``None``."""
    if isinstance(value, _BOOL):
        return None
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iu":
        return int(value)
    return None


def is_number(value: Any) -> bool:
    """A finite real number (:func:`as_finite_float` is not ``None``)."""
    return as_finite_float(value) is not None


def is_int(value: Any) -> bool:
    """An integer (:func:`as_int` is not ``None``)."""
    return as_int(value) is not None


def short(value: Any, limit: int = 80) -> str:
    """``repr(value)`` cut to ``limit`` characters (for error messages)."""
    try:
        text = repr(value)
    except Exception:  # (a broken __repr__ must not hide the real error)
        text = f"<{type(value).__name__}>"
    return text if len(text) <= limit else text[: limit - 3] + "..."


# ------------------------------------------------------------------ scalars, raising
def _interval(low: float | None, high: float | None, low_open: bool, high_open: bool) -> str:
    if low is None and high is None:
        return ""
    if high is None:
        return f" {'>' if low_open else '>='} {low:g}"
    if low is None:
        return f" {'<' if high_open else '<='} {high:g}"
    return f" in {'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"


def number(
    value: Any,
    name: str,
    *,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    high_open: bool = False,
    unit: str = "",
) -> float:
    """``value`` as a finite Python float within the bounds, else ``ValueError`` naming
    ``name`` (``unit``, e.g. ``"m"``, is quoted in the message)."""
    x = as_finite_float(value)
    ok = x is not None
    if ok and low is not None:
        ok = x > low if low_open else x >= low  # type: ignore[operator]
    if ok and high is not None:
        ok = x < high if high_open else x <= high  # type: ignore[operator]
    if not ok:
        where = _interval(low, high, low_open, high_open)
        raise ValueError(
            f"{name} must be a finite number{where}{f' ({unit})' if unit else ''}, "
            f"got {short(value)}"
        )
    return x  # type: ignore[return-value]


def integer(value: Any, name: str, *, low: int | None = None, high: int | None = None) -> int:
    """``value`` as a Python int within ``[low, high]``, else ``ValueError`` naming ``name``."""
    n = as_int(value)
    if n is None or (low is not None and n < low) or (high is not None and n > high):
        raise ValueError(
            f"{name} must be an integer{_interval(low, high, False, False)}, got {short(value)}"
        )
    return n


def seed(value: Any, name: str = "seed") -> int | None:
    """A reset's seed: ``None``, or an integer ``>= 0`` (Python or NumPy; ``bool`` excluded) as
    a Python int; ``ValueError`` naming ``name`` otherwise (floats and bools included)."""
    return None if value is None else integer(value, name, low=0)


def count(value: Any, name: str) -> int:
    """An integer ``>= 1`` (:func:`integer`)."""
    return integer(value, name, low=1)


def flag(value: Any, name: str) -> bool:
    """``True`` or ``False`` (Python or NumPy), else ``ValueError`` naming ``name``."""
    if not isinstance(value, _BOOL):
        raise ValueError(f"{name} must be True or False, got {short(value)}")
    return bool(value)


def choice(value: Any, name: str, choices: tuple[str, ...]) -> str:
    """One of the strings ``choices``, else ``ValueError`` naming ``name``."""
    if not (isinstance(value, str) and value in choices):
        raise ValueError(
            f"{name} must be one of {', '.join(map(repr, choices))}, got {short(value)}"
        )
    return value


def mode_from(value: Any, name: str = "working_mode") -> tuple[int, int, int]:
    """A working mode: three entries of +1 or -1 (Python or NumPy integers, or the floats
    +-1.0; no bools), as a tuple of ints, else ``ValueError`` naming ``name``."""
    entries: list[Any] | None = None
    if not isinstance(value, (str, bytes, Mapping)):
        try:
            entries = list(value)
        except Exception:  # (not iterable, or a failing iterator)
            entries = None
    out: list[int] = []
    if entries is not None and len(entries) == 3:
        for v in entries:
            x = as_finite_float(v)
            if x not in (1.0, -1.0):
                break
            out.append(int(x))  # type: ignore[arg-type]
    if len(out) != 3:
        raise ValueError(f"{name} must be three entries of +1 or -1, got {short(value)}")
    return out[0], out[1], out[2]


# ------------------------------------------------------------------ arrays
def real_array(value: Any) -> np.ndarray | None:
    """``value`` as a float64 array if it is an array of real numbers (any shape; see the
    module docstring), else ``None``.  Values may be infinite or NaN (an integer beyond the
    float range becomes ``inf``): callers test finiteness and shape."""
    if isinstance(value, (str, bytes, Mapping)) or value is None or isinstance(value, _BOOL):
        return None
    if isinstance(value, (list, tuple)):
        if any(isinstance(v, (_BOOL, str, bytes, complex, np.complexfloating)) for v in value):
            return None  # NumPy would turn [True, 0] into numbers and keep "1" as a string
        if any(isinstance(v, (list, tuple)) for v in value):
            rows = [real_array(v) for v in value]
            if any(r is None for r in rows):
                return None
            try:
                return np.array(rows, dtype=np.float64)
            except ValueError:  # ragged
                return None
    try:
        arr = np.asarray(value)
    except Exception:  # (e.g. a torch tensor that requires grad, ragged lists)
        return None
    if arr.dtype.kind == "O":  # e.g. Python ints beyond int64, NumPy scalars of mixed types
        flat = arr.ravel().tolist()
        if not all(is_real(v) for v in flat):
            return None
        out = np.empty(len(flat))
        for i, v in enumerate(flat):
            try:
                out[i] = float(v)
            except OverflowError:
                out[i] = math.inf if v > 0 else -math.inf
        return out.reshape(arr.shape)
    if arr.dtype.kind not in "iuf":  # bool, complex, strings, datetimes, ...
        return None
    return arr.astype(np.float64, copy=False)


def numbers(value: Any, size: int, name: str, meaning: str = "") -> np.ndarray:
    """``value`` as a float64 array of ``size`` finite numbers, or ``ValueError`` naming
    ``name`` (``meaning``, e.g. ``" (x, y, theta)"``, follows "numbers" in the message)."""
    arr = real_array(value)
    if arr is None:
        raise ValueError(f"{name} must be {size} real numbers{meaning}, got {short(value)}")
    if arr.shape != (size,) or not np.isfinite(arr).all():
        raise ValueError(f"{name} must be {size} finite numbers{meaning}, got {short(value)}")
    return arr.copy() if arr is value else arr


def parse_action(action: Any) -> tuple[float, float, float]:
    """An action as three finite floats clipped to ``[-1, 1]``, or ``ValueError``.

    Accepts a sequence or array of 3 real numbers (:func:`real_array`); rejects strings,
    booleans, complex numbers, wrong shapes, NaN/inf and values too large for a float.
    """
    if type(action) is np.ndarray and action.shape == (3,) and action.dtype.char in "fd":
        a0, a1, a2 = action.tolist()  # the common case, without the general checks' overhead
        if a0 * 0.0 == 0.0 and a1 * 0.0 == 0.0 and a2 * 0.0 == 0.0:  # finite (inf, NaN: NaN)
            return (
                -1.0 if a0 < -1.0 else (1.0 if a0 > 1.0 else a0),
                -1.0 if a1 < -1.0 else (1.0 if a1 > 1.0 else a1),
                -1.0 if a2 < -1.0 else (1.0 if a2 > 1.0 else a2),
            )
    arr = real_array(action)
    if arr is None:
        raise ValueError(f"action must be 3 real numbers in [-1, 1], got {short(action)}")
    if arr.shape != (3,):
        raise ValueError(f"action must have shape (3,), got shape {arr.shape}")
    a0, a1, a2 = arr.tolist()
    if not (math.isfinite(a0) and math.isfinite(a1) and math.isfinite(a2)):
        raise ValueError(f"action must be finite, got {short(action)}")
    a0 = -1.0 if a0 < -1.0 else (1.0 if a0 > 1.0 else a0)
    a1 = -1.0 if a1 < -1.0 else (1.0 if a1 > 1.0 else a1)
    a2 = -1.0 if a2 < -1.0 else (1.0 if a2 > 1.0 else a2)
    return a0, a1, a2


def parse_actions(actions: Any, n: int) -> np.ndarray:
    """A batch of ``n`` actions as a float64 array ``(n, 3)`` (not clipped), checked as
    :func:`parse_action` checks one, or ``ValueError``."""
    if (
        type(actions) is np.ndarray
        and actions.shape == (n, 3)
        and actions.dtype.char in "fd"
        and np.isfinite(actions).all()
    ):
        return actions.astype(np.float64, copy=False)
    arr = real_array(actions)
    if arr is None:
        raise ValueError(
            f"actions must be {n} rows of 3 real numbers in [-1, 1], got {short(actions)}"
        )
    if arr.shape != (n, 3):
        raise ValueError(f"actions must have shape ({n}, 3), got shape {arr.shape}")
    if not np.isfinite(arr).all():
        raise ValueError("actions must be finite")
    return arr


# ------------------------------------------------------------------ structured arguments
def config_from(arg: Any, cls: type, name: str) -> Any:
    """A config dataclass from ``None`` (defaults), an instance, or a mapping of its fields
    (an unknown field, or a bad value, raises ``ValueError`` naming ``name``)."""
    if arg is None:
        return cls()
    if isinstance(arg, cls):
        return arg
    if isinstance(arg, Mapping) and is_dataclass(cls):
        known = {f.name for f in fields(cls)}
        unknown = [k for k in arg if k not in known]
        if unknown:
            raise ValueError(
                f"unknown {name} field(s) {sorted(map(str, unknown))}; known: {sorted(known)}"
            )
        try:
            return cls(**arg)
        except ValueError as exc:
            raise ValueError(f"{name}: {exc}") from None
    raise ValueError(f"{name} must be a {cls.__name__} or a dict of its fields, got {short(arg)}")


#: Ranges of a design's quantities that the environments accept (SI units): beyond them the
#: simulation and the observation bounds lose their meaning (a design with 1e150 m legs would
#: have infinite float32 bounds).  ``Design`` itself accepts any finite positive value (the
#: kinematics and the workspace study work at any scale).
DESIGN_LIMITS: dict[str, tuple[float, float]] = {
    "leg_lengths": (1e-3, 1e3),
    "spacings": (0.0, 1e3),
    "stroke": (1e-3, 1e3),
    "rail_origins": (-1e3, 1e3),
    "slider_mass": (1e-4, 1e4),
    "leg_mass": (1e-4, 1e4),
    "platform_mass": (1e-4, 1e4),
    "max_force": (1e-3, 1e7),
    "max_speed": (1e-4, 1e3),
    "gravity": (0.0, 1e3),
    "reference_length": (1e-3, 1e3),
}


def check_env_design(design: Design, name: str = "design") -> Design:
    """``design`` if every quantity is within :data:`DESIGN_LIMITS`, else ``ValueError``
    naming the field."""
    for field_name, (lo, hi) in DESIGN_LIMITS.items():
        value = getattr(design, field_name)
        if value is None:
            continue
        for v in value if isinstance(value, tuple) else (value,):
            if not lo <= v <= hi:
                raise ValueError(
                    f"{name}.{field_name} must be in [{lo:g}, {hi:g}] for an environment, "
                    f"got {short(value)}"
                )
    return design


def design_from(arg: Any, name: str = "design") -> Design:
    """A :class:`Design` for an environment from ``None`` (``Design.fig8()``), a design, a
    mapping of its fields or a preset name (``"fig8"``, ``"fig7"``), checked by
    :func:`check_env_design`; else ``ValueError``."""
    from planar3p_gym.machine.design import Design

    if arg is None:
        design = Design.fig8()
    elif isinstance(arg, Design):
        design = arg
    elif isinstance(arg, Mapping):
        try:
            design = Design.from_dict(dict(arg))
        except ValueError as exc:
            raise ValueError(f"{name}: {exc}") from None
        except TypeError as exc:  # e.g. non-string keys
            raise ValueError(f"{name}: {exc}") from None
    elif isinstance(arg, str):
        presets = {"fig8": Design.fig8, "fig7": Design.fig7}
        if arg not in presets:
            raise ValueError(f"unknown {name} preset {arg!r}; known: {sorted(presets)}")
        design = presets[arg]()
    else:
        raise ValueError(
            f"{name} must be a Design, a dict of its fields or a preset name, got {short(arg)}"
        )
    return check_env_design(design, name)


def check_reset_options(options: Any, keys: tuple[str, ...]) -> dict[str, Any]:
    """``reset``'s ``options`` as a plain dict with only ``keys`` (a task's
    :attr:`~planar3p_gym.tasks.base.Task.option_keys` and ``"task"``), or ``ValueError``.

    Checks the container and keys and parses ``working_mode``; the poses are checked later
    against the episode's working mode.  Called before the environment is seeded, so a
    rejected reset leaves the random stream untouched.
    """
    if options is None:
        return {}
    if not isinstance(options, Mapping):
        raise ValueError(
            f"reset options must be a dict (keys: {', '.join(keys)}), got {short(options)}"
        )
    out = dict(options)
    unknown = [k for k in out if k not in keys]
    if unknown:
        raise ValueError(
            f"unknown reset options {sorted(map(str, unknown))}; known: {', '.join(keys)}"
        )
    if out.get("working_mode") is not None:
        out["working_mode"] = mode_from(out["working_mode"], "working_mode")
    return out
