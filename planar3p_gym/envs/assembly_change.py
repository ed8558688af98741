"""``Planar3PAssemblyChange-v0``: reach a target pose in the other assembly mode."""

from __future__ import annotations

from typing import Any

from planar3p_gym.checks import config_from
from planar3p_gym.envs.core import Planar3PEnv
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks.assembly_change import AssemblyChangeTask, CrossingLimits

__all__ = [
    "ASSEMBLY_CHANGE_MAX_STEPS",
    "ASSEMBLY_CHANGE_MODE",
    "Planar3PAssemblyChangeEnv",
    "assembly_change_design",
]

#: Time limit of ``Planar3PAssemblyChange-v0`` in control steps (12 s at 50 Hz).
ASSEMBLY_CHANGE_MAX_STEPS = 600
#: Working mode of the registered id: the default design's mode with holdable poses in both
#: assembly modes.
ASSEMBLY_CHANGE_MODE = (1, 1, 1)


def assembly_change_design() -> Design:
    """The default design of ``Planar3PAssemblyChange-v0``: ``Design.fig8()`` mounted
    horizontally (``gravity = 0``: the weight acts along the joint axes and is carried by the
    bearings).  Under gravity in the plane the task is not feasible for the demonstration
    (see :mod:`planar3p_gym.tasks.assembly_change`)."""
    return Design.fig8(gravity=0.0)


class Planar3PAssemblyChangeEnv(Planar3PEnv):
    """Change assembly mode: bring the gripper to a target pose on the other side of a
    parallel singularity.

    ## Description
    The machine, physics, actions and breakdown test of ``Planar3P-v0``
    (:class:`planar3p_gym.envs.core.Planar3PEnv`), on the default design mounted horizontally:
    ``Design.fig8(gravity=0.0)`` (:func:`assembly_change_design`; with gravity in the plane the
    platform falls onto another branch near the singularity and no verified episode was found,
    see :mod:`planar3p_gym.tasks.assembly_change`).  Start and target lie in the same working mode
    (by default ``(+1, +1, +1)``) but in opposite assembly modes (``sign det A``): the only way
    from one to the other passes a parallel singularity, where the actuators cannot hold the
    platform in one direction, so the crossing has to use its inertia and gravity within the
    actuator force limits.  Crossing is the goal and does not end the episode.

    ## Action Space
    ``Box(-1, 1, (3,), float32)``: slider velocity commands as fractions of ``max_speed``
    (0.2 m/s), as in ``Planar3P-v0``.

    ## Observation Space
    ``Box((36,), float32)``: the 31 entries of ``Planar3P-v0``
    (:mod:`planar3p_gym.tasks.observation`; errors against the target pose), then the target's
    slider travels (m, 3 entries), the target's assembly mode (+-1) and the signed parallel margin
    (``sign det A`` times the parallel margin, in ``[-1, 1]``; it passes 0 at the crossing).

    ## Rewards
    The terms of ``Planar3P-v0`` without the parallel-margin barrier (the task is to pass the
    parallel singularity): ``-w_pose e - w_precision (1 - exp(-d / s)) - w_singularity
    barrier(serial margin) - w_action effort + w_success [success] - w_failure [breakdown]``;
    the weighted terms are in ``info["reward_terms"]``.

    ## Starting State
    Start and target are drawn from ``self.np_random`` like the reach task's poses (margins,
    stroke, holdable with 75 % of the actuator force) in opposite assembly modes, joined by a
    straight pose path that stays in the stroke with serial margin >= 0.1 and crosses
    ``det A = 0`` once, and (by default) verified in this simulation: the travel motion along
    that path at up to the full slider speed crosses and ends within 1 cm of the target
    (:mod:`planar3p_gym.tasks.assembly_change`).  ``reset(options={"start", "target",
    "working_mode"})`` fixes any of them (``ValueError`` if infeasible);
    ``info["episode_spec"]`` replays an episode.

    ## Episode End
    ``terminated`` on success (within ``position_tolerance`` and ``orientation_tolerance`` of
    the target, every slider slower than ``rest_speed``, in the target's assembly mode) or on
    physics breakdown (``info["termination_reason"]``); ``truncated`` by the time limit (600
    steps, 12 s at 50 Hz).  ``info`` also has ``target_assembly``, ``in_target_assembly`` and
    ``crossings`` (changes of ``sign det A`` so far).

    ## Arguments
    The arguments of :class:`~planar3p_gym.envs.core.Planar3PEnv` (``design``: default
    ``Design.fig8(gravity=0.0)``; ``working_mode``
    (default here ``(1, 1, 1)``), ``control_frequency``, ``substeps``,
    ``solver_iterations``, ``reward_weights``, ``task_config``, ``breakdown_threshold``,
    ``render_mode``, ``render_size``, ...), plus ``crossing_limits``
    (:class:`~planar3p_gym.tasks.assembly_change.CrossingLimits` or a dict of its fields,
    e.g. ``{"verify": False}`` to skip the simulated check at reset) and ``travel_shaping``
    (weight of an optional reward term ``-w sum_i |rho_i - rho_i^t| / L`` towards the target's
    slider travels, :mod:`planar3p_gym.tasks.travel_shaping`; default 0, no such term).

    ## Version History
    - v0 (1.0.0): frozen, with the changes every id took in 1.0.0
      (:class:`~planar3p_gym.envs.core.Planar3PEnv`, Version History).
    - v0 (0.1.0): initial release.
    """

    def __init__(
        self,
        design: Design | dict | str | None = None,
        *,
        working_mode: Any = ASSEMBLY_CHANGE_MODE,
        crossing_limits: CrossingLimits | dict | None = None,
        travel_shaping: float = 0.0,
        **kwargs: Any,
    ) -> None:
        if "task" in kwargs:
            raise ValueError("Planar3PAssemblyChangeEnv makes its own task; do not pass task=")
        crossing_limits = config_from(crossing_limits, CrossingLimits, "crossing_limits")
        super().__init__(
            assembly_change_design() if design is None else design,
            working_mode=working_mode,
            task=AssemblyChangeTask(limits=crossing_limits, travel_shaping=travel_shaping),
            **kwargs,
        )
