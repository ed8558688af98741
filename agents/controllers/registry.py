"""The built-in baselines: one table of their names, what each is, and the ids it plays on.

:func:`planar3p_agents.policies.factory.load_policy` is the one way to get any of them (and
any model) for an environment: it looks the name up in :data:`BASELINES`, refuses an id the
entry does not list (``ValueError`` naming both) and builds the policy for the id's
observation.  The table of baselines, the ``:gain=K`` suffix and the tuned gains:
docs/controllers.md, "How the controller modules work".

* :data:`BASELINES`, :class:`Baseline`, :class:`BaselineContext`, :func:`baselines_for`: the
  table, a row, what a builder is given, the names an id supports;
* :data:`ANALYTIC_POLICIES`, :data:`BUILTIN_POLICIES`, :data:`STRONGEST_REACH_BASELINES`:
  groups of names; :data:`CONTINUOUS_IDS`, :data:`ON_OFF_IDS`, :data:`REACH_IDS`: groups of ids.

Adding a baseline: a builder ``(BaselineContext) -> policy on the id's flat observation`` and
a row of :data:`BASELINES`; nothing else.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from planar3p_agents.controllers.layout import REGISTERED_IDS, ObservationLayout
from planar3p_gym.envs.registry import (
    ASSEMBLY_CHANGE_ENV_ID,
    ENV_ID,
    ENV_SPECS,
    GOAL_DENSE_ENV_ID,
    GOAL_ENV_ID,
    MODE_CHANGE_ENV_ID,
    REAL_ENV_ID,
    REAL_ON_OFF_ENV_ID,
    TRACK_ENV_ID,
    action_type_of,
)
from planar3p_gym.machine.design import Design

__all__ = [
    "ANALYTIC_POLICIES",
    "BASELINES",
    "BUILTIN_POLICIES",
    "CONTINUOUS_IDS",
    "ON_OFF_IDS",
    "REACH_IDS",
    "STRONGEST_REACH_BASELINES",
    "Baseline",
    "BaselineContext",
    "baselines_for",
]

#: The strongest reach baselines, in report order: what a reviewer would try
#: before believing that a learned reach policy is fast.  The benchmark plays them on the reach,
#: goal and built-machine reach suites, and the best of them scores 100 in the normalized scores.
STRONGEST_REACH_BASELINES: tuple[str, ...] = (
    "analytic-tuned",
    "slider-line",
    "certified",
    "certified-line",
)
#: The ids whose task is reaching a target pose in the start's working mode (slider rates).
REACH_IDS: tuple[str, ...] = (ENV_ID, GOAL_ENV_ID, GOAL_DENSE_ENV_ID, REAL_ENV_ID)
#: The ids whose actions are slider rates (a ``Box``): every id but the on-off ones.
CONTINUOUS_IDS: tuple[str, ...] = tuple(
    row.id for row in ENV_SPECS if action_type_of(row) == "continuous"
)
#: The ids with the prototype's on-off motors (``MultiDiscrete`` or ``Discrete`` actions).
ON_OFF_IDS: tuple[str, ...] = tuple(row.id for row in ENV_SPECS if row.id not in CONTINUOUS_IDS)
assert REAL_ON_OFF_ENV_ID in ON_OFF_IDS


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
        suite: the benchmark suite the policy is built for (a tuned baseline reads its gain
            for it), or ``None``.
    """

    env: Any
    design: Design
    layout: ObservationLayout
    action_space: Any = None
    seed: int | None = None
    gain: float | None = None
    suite: str | None = None

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
        per_suite: whether it depends on the suite it plays (built once per suite).
    """

    name: str
    description: str
    ids: tuple[str, ...]
    build: Callable[[BaselineContext], Any]
    takes_gain: bool = False
    per_suite: bool = False


def _analytic(mode: str) -> Callable[[BaselineContext], Any]:
    def build(ctx: BaselineContext) -> Any:
        from planar3p_agents.controllers.analytic import AnalyticController

        return AnalyticController(ctx.design, mode, observation_size=ctx.layout.size, **ctx.gains())

    return build


def _feedforward(ctx: BaselineContext) -> Any:
    from planar3p_agents.controllers.tracking import TrackingController

    return TrackingController(ctx.design, feedforward=1.0, **ctx.gains())


def _slider_line(ctx: BaselineContext) -> Any:
    from planar3p_agents.controllers.slider_line import DEFAULT_TRAVEL_GAIN, SliderLineController

    gain = ctx.gain if ctx.gain is not None else DEFAULT_TRAVEL_GAIN
    return SliderLineController(ctx.design, gain=gain, observation_size=ctx.layout.size)


def _analytic_tuned(ctx: BaselineContext) -> Any:
    from planar3p_agents.controllers.analytic import AnalyticController
    from planar3p_agents.evaluation.tuning import tuned_gain

    k = tuned_gain("analytic-tuned", ctx.suite)
    return AnalyticController(
        ctx.design, position_gain=k, orientation_gain=k, observation_size=ctx.layout.size
    )


def _feedforward_tuned(ctx: BaselineContext) -> Any:
    from planar3p_agents.controllers.tracking import TrackingController
    from planar3p_agents.evaluation.tuning import tuned_gain

    k = tuned_gain("analytic-feedforward-tuned", ctx.suite)
    return TrackingController(ctx.design, feedforward=1.0, position_gain=k, orientation_gain=k)


def _certified(ctx: BaselineContext) -> Any:
    from planar3p_agents.controllers.certified import CertifiedPlanner

    base = getattr(ctx.env, "unwrapped", None)
    return CertifiedPlanner(
        ctx.design,
        dt=float(getattr(base, "dt", 0.02)),
        task_config=getattr(base, "task_config", None),
        observation_size=ctx.layout.size,
    )


def _certified_line(ctx: BaselineContext) -> Any:
    from planar3p_agents.controllers.certified_line import CertifiedLineController

    base = getattr(ctx.env, "unwrapped", None)
    return CertifiedLineController(
        ctx.design, dt=float(getattr(base, "dt", 0.02)), observation_size=ctx.layout.size
    )


def _planner(ctx: BaselineContext) -> Any:
    from planar3p_agents.controllers.planner import JointPathPlanner

    return JointPathPlanner.from_env(ctx.env)


def _crossing(ctx: BaselineContext) -> Any:
    from planar3p_agents.controllers.crossing import CrossingController

    return CrossingController.from_env(ctx.env)


def _on_off(ctx: BaselineContext) -> Any:
    from gymnasium import spaces

    from planar3p_agents.controllers.analytic import AnalyticController
    from planar3p_agents.controllers.on_off import OnOffController

    inner = AnalyticController(ctx.design, observation_size=ctx.layout.size, **ctx.gains())
    return OnOffController(inner, discrete=isinstance(ctx.action_space, spaces.Discrete))


def _on_off_predictive(ctx: BaselineContext) -> Any:
    from planar3p_agents.controllers.predictive_on_off import PredictiveOnOffController

    if ctx.env is None:
        raise ValueError("analytic-on-off-predictive needs the environment (its delay and step)")
    return PredictiveOnOffController.from_env(ctx.env)


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
            CONTINUOUS_IDS,
            _analytic("simultaneous"),
            takes_gain=True,
        ),
        Baseline(
            "analytic-sequential",
            "simple motions one at a time: rotation, vertical, horizontal",
            CONTINUOUS_IDS,
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
            "slider-line",
            "straight line in slider space to the target's travels, synchronised, saturating",
            REACH_IDS,
            _slider_line,
            takes_gain=True,
        ),
        Baseline(
            "analytic-tuned",
            "simple motions superposed, gain tuned per suite on a separate draw",
            REACH_IDS,
            _analytic_tuned,
            per_suite=True,
        ),
        Baseline(
            "analytic-feedforward-tuned",
            "feed-forward tracking controller, gain tuned per suite on a separate draw",
            (TRACK_ENV_ID,),
            _feedforward_tuned,
            per_suite=True,
        ),
        Baseline(
            "certified",
            "slider line where certified, else simple motions on a clear path, else a detour",
            REACH_IDS,
            _certified,
        ),
        Baseline(
            "certified-line",
            "slider line, servo lag predicted, where certified from the current state, else "
            "simple motions",
            REACH_IDS,
            _certified_line,
        ),
        Baseline(
            "analytic-on-off",
            "simple motions superposed, as on-off motor commands with dead bands (bang-bang)",
            ON_OFF_IDS,
            _on_off,
            takes_gain=True,
        ),
        Baseline(
            "analytic-on-off-predictive",
            "on-off commands from the simple motions' travels, after the commands in flight and "
            "the servo's coasting, rounded to one step of the motors",
            ON_OFF_IDS,
            _on_off_predictive,
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
