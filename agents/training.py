"""Training machinery for Stable-Baselines3 agents on Planar3P (used by ``scripts/train.py``).

Hyperparameters come from YAML files in the rl-zoo3 format: a mapping keyed by environment id,
each entry holding the algorithm's keyword arguments plus the zoo's own keys ``n_timesteps``,
``policy``, ``n_envs``, ``normalize`` (bool, or a dict / string of VecNormalize kwargs),
``noise_type``/``noise_std`` (action noise of off-policy algorithms) and ``policy_kwargs``
(a mapping, or a string such as ``"dict(net_arch=[256, 256])"`` as the zoo writes them).
A ``lin_`` prefix on ``learning_rate`` or ``clip_range`` means a linear schedule to 0.

Each run writes one self-contained directory:

=========================  ==================================================================
``model.zip``              the final model
``best_model.zip``         the model with the best evaluation return (EvalCallback)
``vecnormalize.pkl``       normalisation statistics beside each model (when normalising)
``config.json``            resolved hyperparameters, env id and kwargs, seed, command line
``versions.json``          versions of Python and the libraries
``metrics.json``           final evaluation (success rate, returns, errors) and wall time
``evaluations.npz``        the learning curve (EvalCallback: timesteps, returns, successes)
``checkpoints/``           periodic checkpoints (model, statistics, replay buffer) for resume
``tb/``                    TensorBoard logs
=========================  ==================================================================
"""

from __future__ import annotations

import ast
import json
import platform
import sys
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

__all__ = [
    "ALGORITHMS",
    "HYPERPARAMS_DIR",
    "EnvFactory",
    "TrainConfig",
    "load_hyperparams",
    "parse_env_kwargs",
    "parse_overrides",
    "versions",
]

ALGORITHMS = ("ppo", "sac", "td3")
#: Where the shipped, tuned hyperparameter files live (``<algo>.yml``).
HYPERPARAMS_DIR = Path(__file__).resolve().parent / "hyperparams"

_ZOO_KEYS = {"n_timesteps", "policy", "n_envs", "normalize", "noise_type", "noise_std"}


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
        }


def _literal(text: str, what: str) -> Any:
    """Evaluate the zoo's ``dict(...)`` strings safely (literals and ``dict``/``nn`` names)."""
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as exc:
        raise ValueError(f"{what}: cannot parse {text!r}: {exc}") from exc
    return _eval_node(tree.body, what)


_ACTIVATIONS = {"ReLU", "Tanh", "ELU", "LeakyReLU", "SiLU", "GELU"}


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


def _schedule(value: Any, what: str) -> Any:
    if isinstance(value, str) and value.startswith("lin_"):
        try:
            start = float(value[4:])
        except ValueError as exc:
            raise ValueError(f"{what}: bad linear schedule {value!r}") from exc
        return _Linear(start)
    return value


class _Linear:
    """Linear schedule from ``start`` to 0 over training (picklable)."""

    def __init__(self, start: float) -> None:
        self.start = start

    def __call__(self, progress_remaining: float) -> float:
        return progress_remaining * self.start

    def __repr__(self) -> str:
        return f"lin_{self.start}"


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
    steps = int(
        float(n_timesteps if n_timesteps is not None else entry.get("n_timesteps", 100_000))
    )
    envs = int(n_envs if n_envs is not None else entry.get("n_envs", 1))
    if steps <= 0 or envs <= 0:
        raise ValueError(f"n_timesteps and n_envs must be positive (got {steps}, {envs})")
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
    if isinstance(kwargs.get("policy_kwargs"), str):
        kwargs["policy_kwargs"] = _literal(kwargs["policy_kwargs"], "policy_kwargs")
    for key in ("learning_rate", "clip_range"):
        if key in kwargs:
            kwargs[key] = _schedule(kwargs[key], key)
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
        env_kwargs=dict(env_kwargs or {}),
        noise_type=noise_type,
        noise_std=float(entry.get("noise_std", 0.1)),
        entry=entry,
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
    """Versions of Python and the libraries a run depends on."""
    out = {"python": sys.version.split()[0], "platform": platform.platform()}
    for name in ("numpy", "gymnasium", "pymunk", "stable_baselines3", "torch", "planar3p_gym"):
        try:
            module = __import__(name)
            out[name] = str(getattr(module, "__version__", "unknown"))
        except ImportError:  # pragma: no cover - all are dependencies of the train extra
            out[name] = "not installed"
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
