"""Recording what the projection does inside a simulation's compiled control step, and the
projection of a batch of readouts row by row.

:func:`planar3p_gym.sim.chipmunk.step_projected` reads, steps, projects and writes the bodies in
one compiled call, so a test cannot wrap the projector's Python methods to see the readouts.
:func:`recorded_projections` swaps it for the same sequence of its compiled parts, called from
Python with a hook between them (``tests/sim/test_chipmunk.py`` checks that the two give the
same simulation, bit for bit).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

import numpy as np

from planar3p_gym.sim import chipmunk
from planar3p_gym.sim.batch_step import BatchState
from planar3p_gym.sim.physics import FOLLOWING_ERROR_LIMIT
from planar3p_gym.sim.projection import project_in_place, project_row

#: ``record(before, saturated, after)``: the 60 readout numbers before and after the projection
#: and the servos' saturation flags.
Recorder = Callable[[list[float], tuple[bool, bool, bool], list[float]], None]


def step_in_parts(record: Recorder | None = None) -> Callable[..., tuple[np.ndarray, float]]:
    """:func:`~planar3p_gym.sim.chipmunk.step_projected` made of its compiled parts, calling
    ``record`` between the physics and the write-back."""

    def step(
        fns, handles, v0, v1, v2, h, substeps, force_limit, readout, consts, limit, forces
    ) -> tuple[np.ndarray, float]:
        chipmunk.read_bodies(fns, handles)
        start = readout[:60].copy()
        chipmunk.advance(fns, handles, v0, v1, v2, h, substeps, readout, forces)
        saturated = tuple(bool(m >= force_limit) for m in forces[3:6].tolist())
        before = readout[:60].tolist()
        state, closure = project_in_place(readout, *saturated, consts, limit)
        if record is not None:
            record(before, saturated, readout[:60].tolist())
        chipmunk.write_bodies(fns, handles)
        # (a step the constrained dynamics takes again: chipmunk.step_projected's last part)
        return chipmunk._recover_and_write(
            fns,
            handles,
            start,
            v0,
            v1,
            v2,
            h,
            force_limit,
            readout,
            consts,
            limit,
            forces,
            state,
            closure,
        )

    return step


@contextmanager
def recorded_projections(record: Recorder) -> Iterator[None]:
    """Within the block, every projected control step of a simulation stepping through
    Chipmunk's C API calls ``record`` (:data:`Recorder`)."""
    original = chipmunk.step_projected
    chipmunk.step_projected = step_in_parts(record)
    try:
        yield
    finally:
        chipmunk.step_projected = original


def project_rows(buf: np.ndarray, saturated: np.ndarray, consts: np.ndarray) -> BatchState:
    """:func:`~planar3p_gym.sim.projection.project_row` of every row of ``buf`` (``(N, >= 60)``
    readouts, written back in place, drive setpoints limited as a simulation limits them),
    with ``saturated`` ``(3, N)``: what the native vector env's compiled step
    (:func:`~planar3p_gym.sim.chipmunk.advance_batch`) does between its physics and write-back."""
    n = buf.shape[0]
    states, closure = np.empty((23, n)), np.empty(n)
    for j in range(n):
        s0, s1, s2 = (bool(x) for x in saturated[:, j])
        project_row(buf[j], s0, s1, s2, consts, FOLLOWING_ERROR_LIMIT, states, closure, j)
    return BatchState.of(states, closure)
