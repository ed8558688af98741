"""The built-in baselines: one table of their names, what each is, and the ids it plays on.

:func:`planar3p_agents.policies.factory.load_policy` is the one way to get any of them (and
any model) for an environment; it looks the name up in :data:`BASELINES`, refuses an id the
entry does not list (``ValueError`` naming both), builds the policy for the id's observation
(:func:`planar3p_agents.controllers.layout.observation_layout`) and puts it behind
:class:`~planar3p_agents.controllers.goal_adapter.GoalAdapter` on the goal ids' ``Dict``
observation.

======================  ======================================================  ================
name                    policy                                                  ids
======================  ======================================================  ================
analytic-simultaneous   the simple motions superposed (resolved-rate control)   all
analytic-sequential     the simple motions one at a time                        all
analytic-feedforward    simultaneous simple motions + reference velocity        tracking
planner                 certified travel-space path, then simple motions        mode change
crossing                dynamic crossing demonstration, then simple motions     assembly change
random                  uniformly random actions (seeded)                       all
zero                    zero slider velocity                                    all
======================  ======================================================  ================

The analytic controllers read the 31 entries every observation starts with (and the tracking
controller the reference velocity the tracking task appends), so they play every id; the
planner and the crossing demonstration need the target's travels and modes only their tasks
observe.  A name followed by ``:gain=K`` (:data:`ANALYTIC_POLICIES`) sets the position and
orientation gains to ``K`` (1/s).

Adding a baseline: a builder ``(BaselineContext) -> policy on the id's flat observation`` and
a row of :data:`BASELINES`; nothing else (the name is then known to the policy
specifications, the benchmark and the command lines).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from planar3p_agents.controllers.layout import REGISTERED_IDS, ObservationLayout
from planar3p_gym.envs.registry import ASSEMBLY_CHANGE_ENV_ID, MODE_CHANGE_ENV_ID, TRACK_ENV_ID
from planar3p_gym.machine.design import Design

__all__ = [
    "ANALYTIC_POLICIES",
    "BASELINES",
    "BUILTIN_POLICIES",
    "Baseline",
    "BaselineContext",
    "baselines_for",
]


@dataclass(frozen=True)
class BaselineContext:
    """What a builder gets.

    Attributes:
        env: the environment (possibly wrapped), or ``None`` (``Planar3P-v0`` assumed).
        design: the machine.
        layout: the observation as the policy will see it (after the goal adapter).
        action_space: the environment's action space (``None`` without an environment).
        seed: seed of a random policy.
        gain: the ``:gain=K`` of the specification (1/s), or ``None``.
    """

    env: Any
    design: Design
    layout: ObservationLayout
    action_space: Any = None
    seed: int | None = None
    gain: float | None = None

    def gains(self) -> dict[str, float]:
        """The analytic controllers' gain arguments (none for the default gains)."""
        if self.gain is None:
            return {}
        return {"position_gain": self.gain, "orientation_gain": self.gain}


@dataclass(frozen=True)
class Baseline:
    """One built-in baseline.

    Attributes:
        name: its name in a policy specification.
        description: one line.
        ids: the registered ids it plays on.
        build: ``(BaselineContext) -> policy`` (SB3-style ``predict`` on the flat
            observation of ``context.layout``).
        takes_gain: whether ``:gain=K`` applies.
    """

    name: str
    description: str
    ids: tuple[str, ...]
    build: Callable[[BaselineContext], Any]
    takes_gain: bool = False


def _analytic(mode: str) -> Callable[[BaselineContext], Any]:
    def build(ctx: BaselineContext) -> Any:
        from planar3p_agents.controllers.analytic import AnalyticController

        return AnalyticController(ctx.design, mode, observation_size=ctx.layout.size, **ctx.gains())

    return build


def _feedforward(ctx: BaselineContext) -> Any:
    from planar3p_agents.controllers.tracking import TrackingController

    return TrackingController(ctx.design, feedforward=1.0, **ctx.gains())


def _planner(ctx: BaselineContext) -> Any:
    from planar3p_agents.controllers.planner import JointPathPlanner

    return JointPathPlanner.from_env(ctx.env)


def _crossing(ctx: BaselineContext) -> Any:
    from planar3p_agents.controllers.crossing import CrossingController

    return CrossingController.from_env(ctx.env)


def _random(ctx: BaselineContext) -> Any:
    from planar3p_agents.controllers.floor import RandomPolicy

    return RandomPolicy(ctx.action_space, seed=ctx.seed)


def _zero(ctx: BaselineContext) -> Any:
    from planar3p_agents.controllers.floor import ZeroPolicy

    shape = getattr(ctx.action_space, "shape", None)
    return ZeroPolicy(int(shape[0]) if shape else 3)


#: Every built-in baseline, by name (the order of help texts and error messages).
BASELINES: dict[str, Baseline] = {
    b.name: b
    for b in (
        Baseline(
            "analytic-simultaneous",
            "simple motions superposed (resolved-rate control)",
            REGISTERED_IDS,
            _analytic("simultaneous"),
            takes_gain=True,
        ),
        Baseline(
            "analytic-sequential",
            "simple motions one at a time: rotation, vertical, horizontal",
            REGISTERED_IDS,
            _analytic("sequential"),
            takes_gain=True,
        ),
        Baseline("random", "uniformly random actions (seeded)", REGISTERED_IDS, _random),
        Baseline("zero", "zero slider velocity", REGISTERED_IDS, _zero),
        Baseline(
            "analytic-feedforward",
            "simultaneous simple motions with the reference velocity fed forward",
            (TRACK_ENV_ID,),
            _feedforward,
            takes_gain=True,
        ),
        Baseline(
            "planner",
            "certified travel-space path through the legs' upright positions, then simple motions",
            (MODE_CHANGE_ENV_ID,),
            _planner,
        ),
        Baseline(
            "crossing",
            "travel-space motion through the parallel singularity, then simple motions",
            (ASSEMBLY_CHANGE_ENV_ID,),
            _crossing,
        ),
    )
}

#: Built-in policy name -> its description (the names a specification may use).
BUILTIN_POLICIES: dict[str, str] = {name: b.description for name, b in BASELINES.items()}
#: The baselines that take ``:gain=K`` (their feedback gains, 1/s).
ANALYTIC_POLICIES: tuple[str, ...] = tuple(n for n, b in BASELINES.items() if b.takes_gain)


def baselines_for(env_id: str) -> tuple[str, ...]:
    """Names of the baselines that play on ``env_id``."""
    return tuple(n for n, b in BASELINES.items() if env_id in b.ids)
