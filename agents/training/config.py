"""Training machinery for Stable-Baselines3 agents on Planar3P (used by ``planar3p train``).

Hyperparameters come from YAML files in the rl-zoo3 format, read by a small literal parser (no
``eval``); each run writes one self-contained directory.  The accepted keys, why rl-zoo3's
``ExperimentManager`` is not used, and the run directory's files: docs/training.md, "How the
training configuration works".

* :func:`load_hyperparams`, :func:`parse_overrides`, :func:`parse_env_kwargs`: the YAML entry
  and the command line's ``key=YAML`` overrides;
* :class:`TrainConfig`, :class:`EnvFactory`, :func:`policy_class`: a resolved run;
* :data:`ALGORITHMS`, :data:`OFF_POLICY`, :data:`REPLAY_BUFFERS`, :data:`PROJECT_POLICIES`;
  :func:`versions`, :func:`import_rl_zoo3`.
"""

from __future__ import annotations

import ast
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

__all__ = [
    "ALGORITHMS",
    "HYPERPARAMS_DIR",
    "OFF_POLICY",
    "PROJECT_POLICIES",
    "REPLAY_BUFFERS",
    "EnvFactory",
    "TrainConfig",
    "import_rl_zoo3",
    "load_hyperparams",
    "parse_env_kwargs",
    "parse_overrides",
    "policy_class",
    "versions",
]

ALGORITHMS = ("ppo", "sac", "td3", "tqc", "dqn")
#: Off-policy algorithms (replay buffer saved with checkpoints; HER possible).
OFF_POLICY = ("sac", "td3", "tqc", "dqn")
#: Replay buffers a YAML entry may name in ``replay_buffer_class``: class name -> its module.
REPLAY_BUFFERS = {
    "HerReplayBuffer": "stable_baselines3",
    "CompactHerReplayBuffer": "planar3p_agents.training.her",
}
#: Where the shipped, tuned hyperparameter files live (``<algo>.yml``).
HYPERPARAMS_DIR = Path(__file__).resolve().parent / "hyperparams"

_ZOO_KEYS = {
    "n_timesteps",
    "policy",
    "n_envs",
    "normalize",
    "noise_type",
    "noise_std",
    # This project's curriculum key (planar3p_agents.training.task_schedule), not an SB3 argument.
    "task_schedule",
    # Environment arguments a recipe needs (e.g. the observation a feature extractor reads);
    # the command line's --env-kwargs override them entry by entry.
    "env_kwargs",
}
#: Policy classes of this project a YAML entry's ``policy`` may name, besides SB3's aliases
#: (``MlpPolicy``, ...): name -> (module, class), imported only when named.
PROJECT_POLICIES: dict[str, tuple[str, str]] = {
    "ResidualTrackPolicy": ("planar3p_agents.controllers.residual", "ResidualTrackPolicy"),
    "ResidualReachPolicy": ("planar3p_agents.controllers.residual", "ResidualReachPolicy"),
    "ResidualLinePolicy": ("planar3p_agents.controllers.residual", "ResidualLinePolicy"),
    "ResidualAssemblyPolicy": ("planar3p_agents.controllers.residual", "ResidualAssemblyPolicy"),
    "ResidualPlannerPolicy": ("planar3p_agents.controllers.residual", "ResidualPlannerPolicy"),
    "ResidualOnOffPolicy": ("planar3p_agents.controllers.residual_on_off", "ResidualOnOffPolicy"),
    "PredictiveResidualOnOffPolicy": (
        "planar3p_agents.controllers.residual_on_off",
        "PredictiveResidualOnOffPolicy",
    ),
}


def policy_class(name: str) -> Any:
    """What SB3 is given as ``policy``: a project class of :data:`PROJECT_POLICIES`, else
    ``name`` itself (an SB3 alias such as ``MlpPolicy``, checked by SB3)."""
    if name in PROJECT_POLICIES:
        import importlib

        module, cls = PROJECT_POLICIES[name]
        return getattr(importlib.import_module(module), cls)
    return name


@dataclass
class TrainConfig:
    """Everything a run needs, resolved from the YAML entry and the command line."""

    algo: str
    env_id: str
    seed: int
    n_timesteps: int
    n_envs: int
    policy: str
    normalize: dict[str, Any] | None
    algo_kwargs: dict[str, Any]
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    noise_type: str | None = None
    noise_std: float = 0.1
    entry: dict[str, Any] = field(default_factory=dict)  # the YAML entry as written
    #: ``{steps: {TaskConfig field: value}}`` (:mod:`planar3p_agents.training.task_schedule`), or
    # None.
    task_schedule: dict[int, dict[str, Any]] | None = None

    def to_json(self) -> dict[str, Any]:
        """Plain data (JSON-serialisable) describing the run."""
        return {
            "algo": self.algo,
            "env_id": self.env_id,
            "seed": self.seed,
            "n_timesteps": self.n_timesteps,
            "n_envs": self.n_envs,
            "policy": self.policy,
            "normalize": self.normalize,
            "algo_kwargs": self.algo_kwargs,
            "env_kwargs": self.env_kwargs,
            "noise_type": self.noise_type,
            "noise_std": self.noise_std,
            "task_schedule": self.task_schedule,
        }


def _mapping(value: Any, what: str) -> dict[str, Any]:
    """An entry the zoo writes as a ``dict(...)`` string or as a YAML mapping (``policy_kwargs``,
    ``replay_buffer_kwargs``, ``env_kwargs``), as a dict; anything else is a ``ValueError``."""
    if isinstance(value, str):
        value = _literal(value, what)
    if not isinstance(value, Mapping):
        raise ValueError(f"{what} must be a mapping, got {value!r}")
    return dict(value)


def _literal(text: str, what: str) -> Any:
    """Evaluate the zoo's ``dict(...)`` strings safely (literals and ``dict``/``nn`` names)."""
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as exc:
        raise ValueError(f"{what}: cannot parse {text!r}: {exc}") from exc
    return _eval_node(tree.body, what)


_ACTIVATIONS = {"ReLU", "Tanh", "ELU", "LeakyReLU", "SiLU", "GELU"}
#: The project's feature extractors a YAML entry may name in ``policy_kwargs`` (name -> module).
_FEATURE_EXTRACTORS = {
    "GoalErrorExtractor": "planar3p_agents.policies.goal_features",
    "GoalTravelExtractor": "planar3p_agents.policies.goal_features",
}


def _eval_node(node: ast.AST, what: str) -> Any:
    if isinstance(node, ast.Constant):
        return node.value
    if isinstance(node, ast.List):
        return [_eval_node(n, what) for n in node.elts]
    if isinstance(node, ast.Tuple):
        return tuple(_eval_node(n, what) for n in node.elts)
    if isinstance(node, ast.Dict):
        return {
            _eval_node(k, what): _eval_node(v, what)
            for k, v in zip(node.keys, node.values, strict=True)
        }
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        return -_eval_node(node.operand, what)
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "dict":
        if node.args:
            raise ValueError(f"{what}: dict() takes keyword arguments only")
        return {kw.arg: _eval_node(kw.value, what) for kw in node.keywords}
    if (
        isinstance(node, ast.Attribute)
        and isinstance(node.value, ast.Name)
        and node.value.id == "nn"
        and node.attr in _ACTIVATIONS
    ):
        import torch.nn as nn

        return getattr(nn, node.attr)
    if isinstance(node, ast.Name) and node.id in _FEATURE_EXTRACTORS:
        import importlib

        return getattr(importlib.import_module(_FEATURE_EXTRACTORS[node.id]), node.id)
    raise ValueError(f"{what}: unsupported expression {ast.dump(node)[:80]}")


def load_hyperparams(path: str | Path, env_id: str, algo: str) -> dict[str, Any]:
    """The YAML entry for ``env_id`` (rl-zoo3 format), or ``ValueError``."""
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except FileNotFoundError as exc:
        raise ValueError(f"hyperparameter file {path} does not exist") from exc
    except (OSError, yaml.YAMLError) as exc:
        raise ValueError(f"cannot read hyperparameter file {path}: {exc}") from exc
    if not isinstance(data, Mapping):
        raise ValueError(f"hyperparameter file {path} must map environment ids to settings")
    if env_id not in data:
        raise ValueError(
            f"hyperparameter file {path} has no entry for {env_id!r} (has {sorted(data)})"
        )
    entry = data[env_id]
    if not isinstance(entry, Mapping):
        raise ValueError(f"entry {env_id!r} of {path} must be a mapping")
    return dict(entry)


def import_rl_zoo3() -> Any:
    """Import :mod:`rl_zoo3` and undo the one global change its import makes.

    ``import rl_zoo3`` replaces ``gymnasium.wrappers.TimeLimit`` (and the name ``gym.make``
    uses) by its ``PatchedTimeLimit``, which reports ``truncated=False`` when an episode
    terminates on its last allowed step.  Every environment made afterwards in the process
    would end its episodes differently from ``Planar3P-v0`` as registered (the v0 regression
    test hashes those flags), so the original wrapper is put back.
    """
    import gymnasium
    import gymnasium.envs.registration as registration
    import gymnasium.wrappers.common as common
    import rl_zoo3
    from rl_zoo3.gym_patches import PatchedTimeLimit

    original = PatchedTimeLimit.__mro__[1]
    for module in (gymnasium.wrappers, common, registration):
        if getattr(module, "TimeLimit", None) is PatchedTimeLimit:
            if module is registration:
                delattr(module, "TimeLimit")  # gymnasium itself defines no such name there
            else:
                module.TimeLimit = original
    return rl_zoo3


def _schedule(value: Any, what: str) -> Any:
    """``"lin_<x>"`` -> rl-zoo3's linear schedule from ``x`` to 0; numbers pass through."""
    if isinstance(value, str):
        if not value.startswith("lin_"):
            raise ValueError(f"{what} must be a number or 'lin_<number>', got {value!r}")
        try:
            start = float(value[4:])
        except ValueError as exc:
            raise ValueError(f"{what}: bad linear schedule {value!r}") from exc
        if not np.isfinite(start) or start < 0:
            raise ValueError(f"{what}: bad linear schedule {value!r}")
        import_rl_zoo3()
        from rl_zoo3.utils import linear_schedule

        return linear_schedule(start)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{what} must be a number or 'lin_<number>', got {value!r}")
    if not np.isfinite(value):
        raise ValueError(f"{what} must be finite, got {value!r}")
    return value


#: Largest training seed: SB3 seeds NumPy with ``seed + env index`` (below 2**32) and the
#: evaluation environment with ``seed + 10_000``.
MAX_SEED = 2**31 - 1
#: Largest number of environment steps a run accepts (far beyond any run on one machine).
MAX_TIMESTEPS = 10**12


def _count(value: Any, what: str, limit: int = MAX_TIMESTEPS) -> int:
    """A positive whole number (``1e6`` accepted as a float), at most ``limit``."""
    if isinstance(value, bool):
        raise ValueError(f"{what} must be a positive whole number, got {value!r}")
    try:
        number = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{what} must be a positive whole number, got {value!r}") from exc
    if not np.isfinite(number) or number != int(number) or not 1 <= number <= limit:
        raise ValueError(f"{what} must be a whole number from 1 to {limit:g}, got {value!r}")
    return int(number)


def resolve(
    algo: str,
    env_id: str,
    seed: int,
    entry: Mapping[str, Any],
    *,
    n_timesteps: int | None = None,
    n_envs: int | None = None,
    env_kwargs: Mapping[str, Any] | None = None,
) -> TrainConfig:
    """Turn a YAML entry plus command-line overrides into a :class:`TrainConfig`."""
    if algo not in ALGORITHMS:
        raise ValueError(f"unknown algorithm {algo!r}; choose one of {', '.join(ALGORITHMS)}")
    entry = dict(entry)
    steps = _count(
        n_timesteps if n_timesteps is not None else entry.get("n_timesteps", 100_000),
        "n_timesteps",
    )
    envs = _count(n_envs if n_envs is not None else entry.get("n_envs", 1), "n_envs", 1024)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise ValueError(f"seed must be an integer, got {seed!r}")
    if not 0 <= seed <= MAX_SEED:
        raise ValueError(f"seed must be between 0 and {MAX_SEED}, got {seed}")
    norm = entry.get("normalize", False)
    if isinstance(norm, str):
        norm = _literal(norm, "normalize")
    if norm is True:
        normalize: dict[str, Any] | None = {}
    elif norm in (False, None):
        normalize = None
    elif isinstance(norm, Mapping):
        normalize = dict(norm)
    else:
        raise ValueError(f"normalize must be a bool or a mapping, got {norm!r}")
    kwargs = {k: v for k, v in entry.items() if k not in _ZOO_KEYS}
    if "policy_kwargs" in kwargs:
        kwargs["policy_kwargs"] = _mapping(kwargs["policy_kwargs"], "policy_kwargs")
    for key in ("learning_rate", "clip_range"):
        if key in kwargs:
            kwargs[key] = _schedule(kwargs[key], key)
    _resolve_replay_buffer(algo, kwargs)
    recipe_env = _mapping(entry.get("env_kwargs") or {}, "env_kwargs")
    if not all(isinstance(k, str) for k in recipe_env):
        raise ValueError(f"env_kwargs must be a mapping of argument names, got {recipe_env!r}")
    noise_type = entry.get("noise_type")
    if noise_type not in (None, "normal"):
        raise ValueError(f"noise_type must be 'normal' or absent, got {noise_type!r}")
    return TrainConfig(
        algo=algo,
        env_id=env_id,
        seed=int(seed),
        n_timesteps=steps,
        n_envs=envs,
        policy=str(entry.get("policy", "MlpPolicy")),
        normalize=normalize,
        algo_kwargs=kwargs,
        env_kwargs={**recipe_env, **(env_kwargs or {})},
        noise_type=noise_type,
        noise_std=float(entry.get("noise_std", 0.1)),
        entry=entry,
        task_schedule=entry.get("task_schedule"),
    )


def _resolve_replay_buffer(algo: str, kwargs: dict[str, Any]) -> None:
    """Turn the zoo's ``replay_buffer_class`` name and ``replay_buffer_kwargs`` string into the
    class and a mapping, in place (only the buffers in :data:`REPLAY_BUFFERS`; no code)."""
    name = kwargs.get("replay_buffer_class")
    if name is not None:
        if algo not in OFF_POLICY:
            raise ValueError(f"replay_buffer_class needs an off-policy algorithm, not {algo!r}")
        if not isinstance(name, str) or name not in REPLAY_BUFFERS:
            raise ValueError(
                f"replay_buffer_class must be one of {', '.join(REPLAY_BUFFERS)}, got {name!r}"
            )
        import importlib

        kwargs["replay_buffer_class"] = getattr(importlib.import_module(REPLAY_BUFFERS[name]), name)
    if kwargs.get("replay_buffer_kwargs") is not None:
        kwargs["replay_buffer_kwargs"] = _mapping(
            kwargs["replay_buffer_kwargs"], "replay_buffer_kwargs"
        )


def parse_env_kwargs(items: list[str] | None) -> dict[str, Any]:
    """``["key=value", ...]`` with JSON (or plain string) values -> dict."""
    out: dict[str, Any] = {}
    for item in items or []:
        if "=" not in item:
            raise ValueError(f"environment keyword argument {item!r} is not of the form key=value")
        key, text = item.split("=", 1)
        try:
            out[key] = json.loads(text)
        except json.JSONDecodeError:
            out[key] = text
    return out


class EnvFactory:
    """Picklable ``() -> env`` for vectorised workers (also spawned or forkserver ones).

    It carries the registered :class:`gymnasium.envs.registration.EnvSpec` (whose entry point
    names the module to import), so a fresh worker process needs no prior registration.
    """

    def __init__(self, env_id: str, env_kwargs: Mapping[str, Any] | None = None) -> None:
        import gymnasium as gym

        import planar3p_gym  # noqa: F401  (registers the package's ids)

        self.spec = gym.spec(env_id)
        self.env_kwargs = dict(env_kwargs or {})

    def __call__(self, **overrides: Any) -> Any:
        import gymnasium as gym

        return gym.make(self.spec, **{**self.env_kwargs, **overrides})


def parse_overrides(items: list[str] | None) -> dict[str, Any]:
    """``["key=value", ...]`` with YAML values (e.g. ``learning_starts=1000``) -> dict."""
    out: dict[str, Any] = {}
    for item in items or []:
        if "=" not in item:
            raise ValueError(f"hyperparameter override {item!r} is not of the form key=value")
        key, text = item.split("=", 1)
        try:
            value = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise ValueError(f"hyperparameter override {item!r}: {exc}") from exc
        if isinstance(value, str):  # YAML 1.1 reads "2e-5" (no dot) as a string
            try:
                value = float(value)
            except ValueError:
                pass
        out[key] = value
    return out


def versions() -> dict[str, str]:
    """SB3's :func:`~stable_baselines3.common.utils.get_system_info` (OS, Python, SB3, PyTorch,
    NumPy, Gymnasium, ...) plus the versions of pymunk, rl-zoo3 and this package."""
    from importlib.metadata import PackageNotFoundError, version

    from stable_baselines3.common.utils import get_system_info

    out, _ = get_system_info(print_info=False)
    for dist in ("pymunk", "rl_zoo3", "planar3p-gym"):
        try:
            out[dist] = version(dist)
        except PackageNotFoundError:
            out[dist] = "not installed"
    return out


def to_jsonable(value: Any) -> Any:
    """Recursively convert a config value to JSON-friendly data."""
    if isinstance(value, Mapping):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_jsonable(v) for v in value]
    if isinstance(value, (np.integer, np.floating)):
        return value.item()
    if isinstance(value, (str, int, float, bool)) or value is None:
        return value
    if isinstance(value, type):
        return f"{value.__module__}.{value.__qualname__}"
    return repr(value)
