"""The projection over a batch of simulations.

:class:`BatchState` holds the projected states of ``N`` simulations as arrays (what the reach
step's batch outputs, :class:`planar3p_gym.tasks.reach_step.BatchReach`, read); the native
vector env gets them from its compiled control step
(:func:`planar3p_gym.sim.chipmunk.advance_batch`).  :class:`BatchProjector` projects readouts
given as an array with the compiled :func:`planar3p_gym.sim.projection.project_batch`.  Both
loop over the one definition of the projection
(:func:`~planar3p_gym.sim.projection.project_row`, that is
:func:`~planar3p_gym.sim.projection.project_readout`, which a single environment calls): the
same numbers as the single environments, bit for bit.

``tests/envs/test_vector_env.py`` checks the native vector env against single environments, bit for
bit."""

from __future__ import annotations

import numpy as np

from planar3p_gym.sim.physics import FOLLOWING_ERROR_LIMIT
from planar3p_gym.sim.projection import LoopProjector, project_batch

__all__ = ["BatchProjector", "BatchState"]


class BatchState:
    """The projected states of a batch (arrays over the ``N`` simulations, SI units).

    Attributes:
        rho, rho_dot: ``(3, N)`` slider travels (m) and rates (m/s).
        pose: ``(3, N)``: ``x, y`` of ``G`` (m) and ``theta`` wrapped into ``(-pi, pi]``.
        twist: ``(3, N)`` velocity of ``G`` (m/s) and ``theta_dot`` (rad/s).
        leg_angles: ``(3, N)`` ``alpha_i`` (rad).
        closure: ``(N,)`` largest leg-length error (m).
        ux, uy: ``(3, N)`` leg vectors ``u_i = C_i - B_i`` (m); ``c, s``: ``(N,)``
            ``cos, sin theta``.
        finite: ``(N,)`` whether every number of the state is finite.
        states: ``(23, N)`` all of them as rows (the layout of
            :func:`~planar3p_gym.sim.projection.project_batch`; the arrays above are views
            of it), what the compiled reach outputs read.
    """

    __slots__ = (
        "c",
        "closure",
        "finite",
        "leg_angles",
        "pose",
        "rho",
        "rho_dot",
        "s",
        "states",
        "twist",
        "ux",
        "uy",
    )

    def __init__(self, **values: np.ndarray) -> None:
        for key, value in values.items():
            setattr(self, key, value)

    @classmethod
    def of(cls, states: np.ndarray, closure: np.ndarray) -> BatchState:
        """The batch state of projected ``states`` ``(23, N)`` (theta wrapped) and closure
        errors ``(N,)`` (m), as :func:`~planar3p_gym.sim.projection.project_batch` and
        :func:`~planar3p_gym.sim.chipmunk.advance_batch` return them."""
        total = states[:15].sum(axis=0) + closure
        return cls(
            rho=states[0:3],
            rho_dot=states[3:6],
            pose=states[6:9],
            twist=states[9:12],
            leg_angles=states[12:15],
            closure=closure,
            ux=states[15:21:2],
            uy=states[16:21:2],
            c=states[21],
            s=states[22],
            finite=np.isfinite(total),
            states=states,
        )


class BatchProjector:
    """:meth:`LoopProjector.project` of ``projector`` over a batch (module docstring)."""

    def __init__(self, projector: LoopProjector) -> None:
        self.scalar = projector
        self.constants = projector.constants

    def project(self, buf: np.ndarray, saturated: np.ndarray) -> BatchState:
        """Project the readouts in ``buf`` (shape ``(N, >= 60)``: ``x, y, angle, vx, vy, w``
        of the bodies in readout order, one simulation a row) onto the manifold, write the
        bodies to write back into ``buf[:, :60]`` (drive setpoints pulled to within
        :data:`~planar3p_gym.sim.physics.FOLLOWING_ERROR_LIMIT` of their sliders, as
        :meth:`Planar3PSim._project` does), and return the states.  ``saturated``: ``(3, N)``
        booleans."""
        contiguous = buf.flags.c_contiguous and buf.dtype == np.float64
        work = buf if contiguous else np.ascontiguousarray(buf, dtype=np.float64)
        states, closure = project_batch(
            work, np.ascontiguousarray(saturated, dtype=np.bool_), self.constants,
            FOLLOWING_ERROR_LIMIT,
        )  # fmt: skip
        if not contiguous:
            buf[:, :60] = work[:, :60]
        return BatchState.of(states, closure)
