"""The reach task of ``Planar3P-v0``: bring the gripper to a fixed target pose and stop there.

Start and target are drawn by :func:`planar3p_gym.tasks.sampling.sample_pair` (reachable in
the episode's working mode with margins, holdable, same assembly mode, straight path clear of
singularities by default).  Success: within the task's tolerances of the target with every slider
nearly at rest.

Episode spec: ``{"task": "reach", "working_mode": [s1, s2, s3], "start": [x, y, theta],
"target": [x, y, theta]}`` (m, m, rad), and ``"pair"``, the kind of pair drawn (one of
:data:`planar3p_gym.tasks.sampling.PAIR_KINDS`), whenever ``near_singular_fraction`` or
``detour_fraction`` is positive: a requested kind the search did not find within its budget
is reported as such, never silently replaced.  Reset options: ``start``, ``target``,
``working_mode`` (any subset; the rest is drawn), and ``pair`` with both poses given (the kind
recorded in a replayed spec, carried to the new spec).  No task metrics beyond the environment's
``position_error`` / ``orientation_error``.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from planar3p_gym.machine import kinematics
from planar3p_gym.tasks import sampling as task
from planar3p_gym.tasks.base import COMPILED_HOOKS, Pose, Task, pose_list
from planar3p_gym.tasks.kernel import KernelSettings, ReachKernel, Sensing, StepKernel

__all__ = ["COMPILED_HOOKS", "ReachTask"]  # (the hooks' tuple, defined in tasks.base)


class ReachTask(Task):
    """Reach a target pose (see the module docstring)."""

    name: ClassVar[str] = "reach"
    hooks_family: ClassVar[str | None] = "reach"
    option_keys: ClassVar[tuple[str, ...]] = ("start", "target", "working_mode", "pair")
    travel_goal: ClassVar[bool] = True

    def bind(self, env: Any) -> None:
        super().bind(env)
        self._target: Pose = (0.0, 0.0, 0.0)

    def check_options(self, options: dict[str, Any]) -> dict[str, Any]:
        kind = options.get("pair")
        if kind is not None:
            if kind not in task.PAIR_KINDS:
                raise ValueError(f"option pair must be one of {task.PAIR_KINDS}, got {kind!r}")
            if options.get("start") is None or options.get("target") is None:
                raise ValueError(
                    "option pair records the kind of a replayed pair: give start and target too"
                )
        requested = options.get("working_mode")
        if requested is not None and requested not in self.env.modes:
            # bounded and cached (fixed internal seed): a mode without pairs fails here, fast
            task.check_mode(self.env.design, requested, self.env.task_config)
        mode = self.known_mode(options)
        if mode is not None:  # checked before seeding: a rejected reset changes nothing
            for name in ("start", "target"):
                if options.get(name) is not None:
                    options[name] = task.check_pose(self.env.design, options[name], mode, name)
        return options

    def episode_spec(self, rng: np.random.Generator, options: dict[str, Any]) -> dict[str, Any]:
        design = self.env.design
        mode = self.known_mode(options)
        start = options.get("start")
        target = options.get("target")
        if mode is None:
            modes = self.env.modes
            mode = modes[int(rng.integers(len(modes)))]
            if start is not None:
                start = task.check_pose(design, start, mode, "start")
            if target is not None:
                target = task.check_pose(design, target, mode, "target")
        if start is not None and target is not None:
            assemblies = [
                int(kinematics.assembly_mode(design, p, kinematics.inverse(design, p, mode).rho))
                for p in (start, target)
            ]
            if assemblies[0] != assemblies[1]:
                raise ValueError(
                    "start and target are in different assembly modes (sign det A "
                    f"{assemblies[0]} vs {assemblies[1]}): no motion joins them without "
                    "crossing a parallel singularity"
                )
        cfg = self.env.task_config
        start, target, kind = task.draw_pair(
            design, mode, rng, cfg, start=start, target=target, sampler=self.pose_sampler(mode)
        )
        spec = {
            "task": self.name,
            "working_mode": [int(m) for m in mode],
            "start": pose_list(start),
            "target": pose_list(target),
        }
        if options.get("pair") is not None:
            spec["pair"] = options["pair"]
        elif cfg.near_singular_fraction > 0 or cfg.detour_fraction > 0:
            spec["pair"] = kind
        return spec

    def begin(self, spec: dict[str, Any]) -> tuple[np.ndarray, tuple[int, int, int]]:
        tx, ty, tth = spec["target"]
        self._target = (float(tx), float(ty), float(tth))
        mode = tuple(int(m) for m in spec["working_mode"])
        return np.asarray(spec["start"], dtype=np.float64), mode  # type: ignore[return-value]

    def reference(self, step: int) -> Pose:
        return self._target

    def kernel(self, settings: KernelSettings, machine: Sensing) -> StepKernel:
        """The compiled reach kernel on the projected physics of the nominal machine when the
        per-step hooks are the reach task's own (:attr:`~Task.compiled_family`), else the
        reference."""
        if self.compiled_family == "reach" and settings.projection and settings.nominal:
            return ReachKernel(self, settings, machine)
        return super().kernel(settings, machine)
