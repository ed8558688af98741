"""The projected states of a batch of simulations.

:class:`BatchState` holds the projected states of ``N`` simulations as arrays; the native
vector env gets them from its compiled control step
(:func:`planar3p_gym.sim.chipmunk.advance_batch`), which loops over the one definition of the
projection (:func:`~planar3p_gym.sim.projection.project_row`, that is
:func:`~planar3p_gym.sim.projection.project_readout`, which a single environment calls): the
same numbers as the single environments, bit for bit.

``tests/envs/test_vector_env.py`` checks the native vector env against single environments, bit for
bit."""

from __future__ import annotations

import numpy as np

__all__ = ["BatchState"]


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
            :func:`~planar3p_gym.sim.chipmunk.advance_batch`; the arrays above are views
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
        errors ``(N,)`` (m), as :func:`~planar3p_gym.sim.chipmunk.advance_batch` returns them."""
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
