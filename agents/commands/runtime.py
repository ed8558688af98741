"""The process's share of the machine for the timing commands (workspace, bench-kinematics)."""

from __future__ import annotations

import os

__all__ = ["pin_one_core"]


def pin_one_core() -> str:
    """Pin this process to one CPU (Linux); a description of what was done.  Thread pools
    started earlier (BLAS) then share that one core."""
    if hasattr(os, "sched_setaffinity"):
        cpus = sorted(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {cpus[-1]})
        return f"pinned to CPU {cpus[-1]} (of {len(cpus)})"
    return "not pinned (no sched_setaffinity)"
