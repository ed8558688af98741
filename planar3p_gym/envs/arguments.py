"""Deprecated alias of :mod:`planar3p_gym.checks`, where every argument check of the package
now lives (kept so that ``from planar3p_gym.envs.arguments import design_from`` still works)."""

from __future__ import annotations

from planar3p_gym.checks import (
    RESET_OPTIONS,
    check_reset_options,
    config_from,
    design_from,
    is_int,
    is_number,
    mode_from,
    parse_action,
)

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
