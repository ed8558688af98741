"""The one policy factory: a policy name or a model path, and the environment it is to play,
-> an object with SB3's ``predict`` for that environment's observations (:func:`load_policy`).

Every failure to resolve or load a specification raises :class:`PolicyError` (a
``ValueError``) saying what was wrong.  Model and statistics files are code
(:data:`TRUSTED_FILES_NOTE`): nothing is unpickled that the caller did not name.  The accepted
specifications and the rules for observation statistics: docs/controllers.md, "How the
controller modules work".

* a built-in baseline (:data:`planar3p_agents.controllers.registry.BASELINES`, optionally
  ``:gain=K``), refused on an id it does not support;
* ``pretrained:<name>``: a shipped model, checked against ``SHA256SUMS`` first
  (:func:`verify_pretrained`);
* a Stable-Baselines3 ``.zip`` (optionally ``ppo:``/``sac:``/... and ``:stats=PATH.pkl`` or
  ``:stats=none``).

The parts live in :mod:`planar3p_agents.controllers.registry`,
:mod:`planar3p_agents.policies.spec`, :mod:`planar3p_agents.zoo.manifest` and
:mod:`planar3p_agents.policies.sb3_models`; their names are re-exported here.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from planar3p_agents.controllers.goal_adapter import GoalAdapter
from planar3p_agents.controllers.layout import observation_layout
from planar3p_agents.controllers.registry import BASELINES, BaselineContext
from planar3p_agents.policies.sb3_models import (
    SB3Policy,
    load_sb3_model,
    run_env_kwargs,
    vecnormalize_candidates,
)
from planar3p_agents.policies.spec import (
    BUILTIN_POLICIES,
    NO_STATS,
    PRETRAINED_DIR,
    PRETRAINED_PREFIX,
    SB3_ALGORITHMS,
    TRUSTED_FILES_NOTE,
    PolicyError,
    PolicySpec,
    _stats_value,
    list_pretrained,
    parse_policy_spec,
    policy_label,
)
from planar3p_agents.zoo.layout import shipped_model_of
from planar3p_agents.zoo.manifest import MANIFEST, file_sha256, verify_pretrained, write_manifest
from planar3p_gym.machine.design import Design

__all__ = [
    "BASELINES",
    "BUILTIN_POLICIES",
    "MANIFEST",
    "NO_STATS",
    "PRETRAINED_DIR",
    "SB3_ALGORITHMS",
    "TRUSTED_FILES_NOTE",
    "PolicyError",
    "PolicySpec",
    "SB3Policy",
    "file_sha256",
    "list_pretrained",
    "load_policy",
    "load_sb3_model",
    "parse_policy_spec",
    "policy_label",
    "run_env_kwargs",
    "vecnormalize_candidates",
    "verify_pretrained",
    "write_manifest",
]


def load_policy(
    spec: str | PolicySpec,
    env: Any = None,
    *,
    design: Design | None = None,
    seed: int | None = None,
    device: str = "cpu",
    vecnormalize: str | Path | None = None,
    suite: str | None = None,
) -> Any:
    """The policy named by ``spec`` (see the module docstring), ready to ``predict`` on the
    observations of ``env``.

    ``env``: the environment the policy is to play (any registered id, possibly wrapped).  A
    baseline is built for its id and observation and refused (:class:`PolicyError`) on an id
    it does not support; a model must match its spaces.  Without ``env`` a baseline is built
    for ``Planar3P-v0`` with ``design`` (default ``Design.fig8()``).  ``design`` replaces the
    environment's design for the analytic controllers.  ``seed`` seeds the random policy.
    ``vecnormalize``: statistics file of a model path (or :data:`NO_STATS`), like the spec's
    ``:stats=`` suffix (giving both is an error).  Model and statistics files are code: see
    :data:`TRUSTED_FILES_NOTE`.  ``suite``: the benchmark suite a baseline is built for (a
    tuned baseline reads its gain for it).
    """
    ps = spec if isinstance(spec, PolicySpec) else parse_policy_spec(spec)
    stats = ps.stats
    if vecnormalize is not None:
        if ps.kind != "model" or ps.text.startswith(PRETRAINED_PREFIX):
            raise PolicyError(f"statistics apply to model paths only, not {ps.text!r}")
        if stats is not None:
            raise PolicyError(f"statistics named twice for {ps.text!r} (spec and argument)")
        stats = _stats_value(str(vecnormalize))
    if ps.kind == "builtin":
        return _baseline(ps, env, design, seed, suite)
    assert ps.path is not None
    if ps.text.startswith(PRETRAINED_PREFIX):
        shipped = shipped_model_of(ps.path)  # <root>/<name>/<algo>/<env id>_1/<env id>.zip
        root = shipped.root if shipped is not None else ps.path.parent  # (else: refused there)
        files = verify_pretrained(ps.name[len(PRETRAINED_PREFIX) :], root)
        stats = files[1] if len(files) > 1 else NO_STATS
    return load_sb3_model(
        ps.path, ps.algo, device=device, name=ps.name, check_env=env, vecnormalize=stats
    )


def _baseline(
    ps: PolicySpec, env: Any, design: Design | None, seed: int | None, suite: str | None = None
) -> Any:
    """The built-in baseline ``ps`` for ``env`` (:data:`BASELINES`)."""
    entry = BASELINES[ps.name]
    try:
        layout = observation_layout(env)
    except ValueError as exc:
        raise PolicyError(f"cannot play {ps.text!r} on this environment: {exc}") from exc
    if layout.env_id not in entry.ids:
        assumed = " (no env given: Planar3P-v0 assumed)" if env is None else ""
        raise PolicyError(
            f"baseline {ps.name!r} does not apply to {layout.env_id}{assumed}; it plays on "
            f"{', '.join(entry.ids)}"
        )
    if design is None:
        design = env.unwrapped.design if env is not None else Design.fig8()
    context = BaselineContext(
        env=env,
        design=design,
        layout=layout,
        action_space=env.action_space if env is not None else None,
        seed=seed,
        gain=ps.gain,
        suite=suite,
    )
    policy = entry.build(context)
    return GoalAdapter(policy, design.characteristic_length) if layout.goal else policy
