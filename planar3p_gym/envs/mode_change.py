"""``Planar3PModeChange-v0``: reach a target pose in another working mode."""

from __future__ import annotations

from typing import Any

from planar3p_gym.checks import config_from
from planar3p_gym.envs.core import Planar3PEnv
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks.joint_paths import PathLimits
from planar3p_gym.tasks.mode_change import ModeChangeTask

__all__ = ["MODE_CHANGE_MAX_STEPS", "Planar3PModeChangeEnv"]

#: Time limit of ``Planar3PModeChange-v0`` in control steps (8 s at 50 Hz).
MODE_CHANGE_MAX_STEPS = 400


class Planar3PModeChangeEnv(Planar3PEnv):
    """Change working mode: bring the gripper to a target pose that lies in another working
    mode, which makes a leg swing through the perpendicular to its rail.

    ## Description
    The machine, physics, actions and failure tests of ``Planar3P-v0``
    (:class:`planar3p_gym.envs.core.Planar3PEnv`).  The start pose is in working mode
    ``sigma_s`` (by default ``(+1, +1, -1)``) and the target pose in a working mode ``sigma_t``
    that differs in one leg (``sign cos alpha_i``; on the default design ``(+1, +1, +1)``, leg
    3 flips): that leg must pass the serial singularity
    where it stands perpendicular to its rail.  A controller that keeps clear of serial
    singularities (the paper's simple motions with their brake) cannot get there; the slider
    under the upright leg has to move past it.  Changing working mode is not a failure here;
    crossing a parallel singularity (``sign det A`` changes) still is.

    ## Action Space
    ``Box(-1, 1, (3,), float32)``: slider velocity commands as fractions of ``max_speed``
    (0.2 m/s), as in ``Planar3P-v0``.

    ## Observation Space
    ``Box((37,), float32)``: the 31 entries of ``Planar3P-v0``
    (:mod:`planar3p_gym.tasks.observation`; errors against the target pose), then the target's
    slider travels (m, 3 entries) and its working mode ``sigma_t`` (3 entries of +-1).  The current
    working mode is the sign of the observed ``cos alpha_i``.

    ## Rewards
    The terms of ``Planar3P-v0`` without the serial-margin barrier (the task is to pass a
    serial singularity): ``-w_pose e - w_precision (1 - exp(-d / s)) - w_singularity
    barrier(parallel margin) - w_action effort + w_success [success] - w_failure [failure]``;
    the weighted terms are in ``info["reward_terms"]``.

    ## Starting State
    Start (in ``sigma_s``) and target (in ``sigma_t``, same assembly mode) are drawn from
    ``self.np_random`` like the reach task's poses (margins, stroke, holdable with 75 % of the
    actuator force) and kept only with a feasibility certificate: a path of the slider travels
    along which the platform's pose (exact direct kinematics, followed by continuity) stays
    holdable within 90 % of the actuator force with parallel margin >= 0.02, in the stroke,
    and arrives at the target in ``sigma_t`` (:mod:`planar3p_gym.tasks.mode_change`).
    ``reset(options={"start", "target", "working_mode", "target_working_mode"})`` fixes any of
    them (``ValueError`` if the request is infeasible); ``info["episode_spec"]`` replays an
    episode.

    ## Episode End
    ``terminated`` on success (within ``position_tolerance`` and ``orientation_tolerance`` of
    the target, every slider slower than ``rest_speed``, every leg in ``sigma_t``), on a
    parallel-singularity crossing or on physics breakdown (``info["termination_reason"]``);
    ``truncated`` by the time limit (400 steps, 8 s at 50 Hz).  ``info`` also has
    ``target_working_mode``, ``in_target_mode`` and ``legs_to_flip``.

    ## Arguments
    The arguments of :class:`~planar3p_gym.envs.core.Planar3PEnv` (``design``, ``working_mode``
    (start modes), ``control_frequency``, ``substeps``, ``solver_iterations``,
    ``reward_weights``, ``task_config``, ``breakdown_threshold``, ``render_mode``,
    ``render_size``, ...), plus ``flips`` (legs to flip, 1 to 3; default 1) and
    ``path_limits`` (:class:`~planar3p_gym.tasks.joint_paths.PathLimits` or a dict of its
    fields: the certificate's margins) and ``travel_shaping`` (weight of an optional reward
    term ``-w sum_i |rho_i - rho_i^t| / L`` towards the target's slider travels; default 0, no
    such term; for training, it does not change the success test).

    ## Version History
    - v0 (1.0.0): frozen, with the changes every id took in 1.0.0
      (:class:`~planar3p_gym.envs.core.Planar3PEnv`, Version History).
    - v0 (0.1.0): initial release.
    """

    def __init__(
        self,
        design: Design | dict | str | None = None,
        *,
        flips: int = 1,
        path_limits: PathLimits | dict | None = None,
        travel_shaping: float = 0.0,
        **kwargs: Any,
    ) -> None:
        if "task" in kwargs:
            raise ValueError("Planar3PModeChangeEnv makes its own task; do not pass task=")
        path_limits = config_from(path_limits, PathLimits, "path_limits")
        super().__init__(
            design,
            task=ModeChangeTask(flips=flips, limits=path_limits, travel_shaping=travel_shaping),
            **kwargs,
        )
