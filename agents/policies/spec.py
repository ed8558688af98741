"""Policy specifications: what a name such as ``analytic-simultaneous``, ``pretrained:<name>``
or ``sac:runs/x/model.zip:stats=runs/x/vecnormalize.pkl`` means, resolved without loading
anything (:func:`parse_policy_spec`), and its short label (:func:`policy_label`).

The syntax is described in :mod:`planar3p_agents.policies.factory`, which loads what a
specification names.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

# The built-in names and which take :gain=K: the baseline registry's.
from planar3p_agents.controllers.registry import ANALYTIC_POLICIES, BUILTIN_POLICIES
from planar3p_agents.zoo.layout import PRETRAINED_DIR, shipped_model, shipped_names

__all__ = [
    "ANALYTIC_POLICIES",
    "BUILTIN_POLICIES",
    "GAIN_MARK",
    "NO_STATS",
    "PRETRAINED_DIR",
    "PRETRAINED_PREFIX",
    "SB3_ALGORITHMS",
    "STATS_MARK",
    "TRUSTED_FILES_NOTE",
    "PolicyError",
    "PolicySpec",
    "list_pretrained",
    "parse_policy_spec",
    "policy_label",
]

#: Say this wherever a file can be loaded (README, ``--help`` of scripts that load models).
TRUSTED_FILES_NOTE = (
    "Model (.zip) and statistics (.pkl) files are code: loading one can run arbitrary "
    "commands, so load only files you trust. Shipped pretrained:<name> files are checked "
    "against agents/zoo/pretrained/SHA256SUMS first (rl-zoo3's enjoy does not check them: run "
    "scripts/ship_policy.py --verify NAME before it); statistics are loaded only when named "
    "(MODEL.zip:stats=STATS.pkl, or :stats=none to go without)."
)

#: ``analytic-simultaneous:gain=12``: the controller with position and orientation gains 12 1/s
#: (default 6 1/s), e.g. to compare a learned policy with a retuned controller.
GAIN_MARK = ":gain="
#: Stable-Baselines3 algorithms a model file may come from (prefix -> class name).
SB3_ALGORITHMS: dict[str, str] = {
    "ppo": "PPO",
    "sac": "SAC",
    "td3": "TD3",
    "a2c": "A2C",
    "ddpg": "DDPG",
    "dqn": "DQN",
    "tqc": "TQC",  # sb3-contrib
}
PRETRAINED_PREFIX = "pretrained:"
#: ``stats`` value meaning "evaluate without observation statistics".
NO_STATS = "none"
STATS_MARK = ":stats="


class PolicyError(ValueError):
    """A policy specification that cannot be resolved or loaded."""


@dataclass(frozen=True)
class PolicySpec:
    """A parsed policy specification.

    Attributes:
        text: the specification as given.
        kind: ``"builtin"`` or ``"model"``.
        name: the built-in name (without a :data:`GAIN_MARK` suffix), or the model's label
            (``pretrained:<name>`` or file stem).
        path: the model file (``kind == "model"``).
        algo: the forced SB3 algorithm key (``ppo``, ...), or ``None`` to detect it.
        stats: the named ``VecNormalize`` statistics file, :data:`NO_STATS`, or ``None``
            (none named).
        gain: an analytic controller's feedback gain (1/s) named with :data:`GAIN_MARK`, or
            ``None`` for its default.
    """

    text: str
    kind: str
    name: str
    path: Path | None = None
    algo: str | None = None
    stats: Path | str | None = None
    gain: float | None = None


def list_pretrained(directory: Path | None = None) -> list[str]:
    """Names of the shipped pretrained models (``pretrained:<name>``; the layout is
    :mod:`planar3p_agents.zoo.layout`)."""
    return shipped_names(directory or PRETRAINED_DIR)


def _known() -> str:
    names = list(BUILTIN_POLICIES) + [PRETRAINED_PREFIX + n for n in list_pretrained()]
    return (
        ", ".join(names)
        + f", an analytic controller with {GAIN_MARK}K (1/s), or a path to an SB3 model "
        ".zip[:stats=STATS.pkl]"
    )


def _gain_spec(spec: str) -> PolicySpec | None:
    """``analytic-...:gain=K`` parsed (``K`` finite and > 0, 1/s), or ``None`` if ``spec`` is
    not of that form."""
    head, sep, value = spec.partition(GAIN_MARK)
    if not sep or head not in ANALYTIC_POLICIES:
        return None
    try:
        gain = float(value)
    except ValueError:
        gain = float("nan")
    if not (math.isfinite(gain) and gain > 0):
        raise PolicyError(f"the gain of {spec!r} must be a finite number > 0 (1/s)")
    return PolicySpec(spec, "builtin", head, gain=gain)


def _stats_value(text: str) -> Path | str:
    """A named statistics file (must exist) or :data:`NO_STATS`."""
    value = text.strip()
    if not value:
        raise PolicyError(f"empty statistics path after {STATS_MARK!r}")
    if value.lower() == NO_STATS:
        return NO_STATS
    path = Path(value).expanduser()
    if not path.is_file():
        raise PolicyError(f"statistics file not found: {path}")
    return path


def parse_policy_spec(text: str) -> PolicySpec:
    """Resolve a specification without loading anything (files must exist).

    A model path may end with ``:stats=PATH.pkl`` (its ``VecNormalize`` statistics) or
    ``:stats=none``.
    """
    spec = str(text).strip()
    if not spec:
        raise PolicyError(f"empty policy name; known: {_known()}")
    if spec in BUILTIN_POLICIES:
        return PolicySpec(spec, "builtin", spec)
    gained = _gain_spec(spec)
    if gained is not None:
        return gained
    stats: Path | str | None = None
    if STATS_MARK in spec:
        spec, _, stats_text = spec.rpartition(STATS_MARK)
        if spec in BUILTIN_POLICIES or spec.startswith(PRETRAINED_PREFIX):
            raise PolicyError(
                f"{STATS_MARK!r} applies to model paths only (built-in policies need none; "
                f"pretrained models bring their own): {text!r}"
            )
        stats = _stats_value(stats_text)
    if spec.startswith(PRETRAINED_PREFIX):
        name = spec[len(PRETRAINED_PREFIX) :]
        if not name or "/" in name or "\\" in name or name.startswith("."):
            raise PolicyError(f"invalid pretrained model name {name!r}")
        try:
            path = shipped_model(name, PRETRAINED_DIR).model
        except ValueError as exc:
            have = list_pretrained()
            folder = PRETRAINED_DIR / name
            if folder.is_dir():  # an altered provenance record is a checksum mismatch
                from planar3p_agents.zoo.manifest import verify_zoo_folder

                verify_zoo_folder(name, PRETRAINED_DIR)
            why = f"{folder} does not exist" if not folder.exists() else str(exc)
            raise PolicyError(
                f"unknown pretrained model {name!r}: {why}; "
                f"available: {', '.join(have) if have else 'none shipped yet'}"
            ) from exc
        if not path.is_file():
            raise PolicyError(f"shipped model {name!r} has no model file {path}")
        return PolicySpec(spec, "model", spec, path, None)
    algo = None
    head, sep, rest = spec.partition(":")
    if sep and head.lower() in SB3_ALGORITHMS and rest:
        algo, spec_path = head.lower(), rest
    else:
        spec_path = spec
    path = Path(spec_path).expanduser()
    looks_like_path = path.suffix == ".zip" or "/" in spec_path or path.exists()
    if not looks_like_path and algo is None:
        raise PolicyError(f"unknown policy {spec!r}; known: {_known()}")
    if not path.exists() and path.suffix != ".zip" and path.with_suffix(".zip").exists():
        path = path.with_suffix(".zip")
    if not path.exists():
        raise PolicyError(f"model file not found: {path}")
    if not path.is_file():
        raise PolicyError(f"model path is not a file: {path}")
    return PolicySpec(text, "model", path.stem, path, algo, stats)


def policy_label(text: str) -> str:
    """Short name of a specification for tables and plots (built-in name, ``pretrained:x``,
    or the model file's stem, prefixed by its directory for generic stems such as
    ``model``/``best_model`` and for rl-zoo3's ``<run>/<env id>.zip``, and by the run for a
    checkpoint ``<run>/checkpoints/rl_model_<steps>_steps.zip``)."""
    spec = str(text).strip()
    if spec in BUILTIN_POLICIES or spec.startswith(PRETRAINED_PREFIX):
        return spec
    if spec.partition(GAIN_MARK)[0] in ANALYTIC_POLICIES:
        return spec
    if STATS_MARK in spec:
        spec = spec.rpartition(STATS_MARK)[0]
    head, sep, rest = spec.partition(":")
    if sep and head.lower() in SB3_ALGORITHMS and rest:
        spec = rest
    p = Path(spec)
    parent = p.parent.name
    if parent == "checkpoints" and p.parent.parent.name:  # runs/<run>/checkpoints/rl_model_N_steps
        return f"{p.parent.parent.name}/{p.stem}"
    generic = p.stem in ("model", "best_model") or p.stem.endswith("_model")
    zoo = (p.parent / p.stem).is_dir()  # rl-zoo3: <run>/<env id>.zip beside <run>/<env id>/
    return f"{parent}/{p.stem}" if parent and (generic or zoo) else p.stem
