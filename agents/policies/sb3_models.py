"""Stable-Baselines3 model files: which algorithm saved one, where its ``VecNormalize``
statistics may lie, what its training recorded (:func:`training_record`: the id, the
environment arguments, the seed), and loading both into an :class:`SB3Policy`
(:func:`load_sb3_model`), which refuses a model trained on another id than the environment's.

Model and statistics files are code (:data:`planar3p_agents.policies.spec.TRUSTED_FILES_NOTE`):
nothing is unpickled that the caller did not name, and a model with statistics beside it and none
named is refused rather than evaluated without them.
"""

from __future__ import annotations

import json
import pickle
import re
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from planar3p_agents.controllers.base import PolicyAdapter
from planar3p_agents.policies.play_envs import observation_kwargs
from planar3p_agents.policies.spec import NO_STATS, SB3_ALGORITHMS, STATS_MARK, PolicyError
from planar3p_agents.zoo.layout import shipped_model_of

__all__ = [
    "RENAMED_IDS",
    "SB3Policy",
    "TrainingRecord",
    "check_trained_id",
    "load_sb3_model",
    "load_yaml_data",
    "renamed",
    "run_env_kwargs",
    "same_task",
    "training_record",
    "vecnormalize_candidates",
]


def _detect_algorithm(path: Path) -> str:
    """The SB3 algorithm a model zip was saved by, from its ``data`` JSON."""
    try:
        with zipfile.ZipFile(path) as zf:
            names = set(zf.namelist())
            if "data" not in names or "policy.pth" not in names:
                raise PolicyError(
                    f"{path} is not a Stable-Baselines3 model (missing 'data' or 'policy.pth')"
                )
            data = json.loads(zf.read("data"))
    except zipfile.BadZipFile as exc:
        raise PolicyError(f"corrupt model file {path}: not a zip archive ({exc})") from exc
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise PolicyError(f"corrupt model file {path}: unreadable 'data' ({exc})") from exc
    except OSError as exc:
        raise PolicyError(f"cannot read model file {path}: {exc}") from exc
    if not isinstance(data, dict):
        raise PolicyError(f"corrupt model file {path}: 'data' is not a mapping")
    module = str(data.get("policy_class", {}).get("__module__", ""))
    if "clip_range" in data:
        return "ppo"
    if "policy_delay" in data or "target_policy_noise" in data:
        return "td3"
    if ("ent_coef" in data and "target_entropy" in data) or ".sac." in module:
        return "sac"
    if "vf_coef" in data:
        return "a2c"
    raise PolicyError(
        f"cannot tell which SB3 algorithm saved {path}; prefix the path with one of "
        f"{', '.join(k + ':' for k in SB3_ALGORITHMS)}"
    )


def vecnormalize_candidates(path: Path) -> list[Path]:
    """Where the ``VecNormalize`` statistics of the model ``path`` may be, in order.

    Matches ``scripts/train.py``'s run directory (``model.zip`` + ``vecnormalize.pkl``,
    ``best_model.zip`` + ``best_vecnormalize.pkl``, ``checkpoints/rl_model_<n>_steps.zip`` +
    ``rl_model_vecnormalize_<n>_steps.pkl``), ``<stem>.zip`` + ``<stem>_vecnormalize.pkl``, and
    rl-zoo3's (``<run>/<env id>.zip`` or ``best_model.zip`` + ``<run>/<env id>/vecnormalize.pkl``,
    which is also the layout of the shipped models).  Nothing is loaded from these places unless
    named: :func:`load_sb3_model` refuses a model that has statistics there and none named.
    """
    stem = path.stem
    out = [path.with_name(f"{stem}_vecnormalize.pkl")]
    if stem.endswith("_model"):
        out.append(path.with_name(f"{stem[: -len('_model')]}_vecnormalize.pkl"))
    m = re.fullmatch(r"(.*)_(\d+)_steps", stem)
    if m:
        out.append(path.with_name(f"{m.group(1)}_vecnormalize_{m.group(2)}_steps.pkl"))
    out.append(path.parent / "vecnormalize.pkl")
    out.append(path.with_suffix("") / "vecnormalize.pkl")  # rl-zoo3: <run>/<env id>.zip
    if path.parent.is_dir():  # rl-zoo3: best_model.zip, checkpoints beside <run>/<env id>/
        out.extend(sorted(c for c in path.parent.glob("*/vecnormalize.pkl") if c not in out))
    return out


def _vecnormalize_file(path: Path) -> Path | None:
    for cand in vecnormalize_candidates(path):
        if cand.is_file():
            return cand
    return None


def _unnamed_stats_error(path: Path, found: Path) -> PolicyError:
    return PolicyError(
        f"model {path} has observation statistics beside it ({found}) but none were named; "
        f"statistics files are code and are loaded only when named: use "
        f"'{path}{STATS_MARK}{found}' if you trust that file, or '{path}{STATS_MARK}{NO_STATS}' "
        "to evaluate without them"
    )


@dataclass(frozen=True)
class TrainingRecord:
    """What a model's training recorded about it, read from JSON or YAML (never a pickle).

    Attributes:
        source: the file read: a run's ``config.json`` (``scripts/train.py``), a shipped
            model's provenance record (:mod:`planar3p_agents.zoo.layout`) or rl-zoo3's
            ``args.yml``.
        env_id: the id it was trained on (``None`` if not recorded or unreadable).
        env_kwargs: its environment keyword arguments (``None`` if not recorded).
        seed: its training seed (``None`` if not recorded).
    """

    source: Path
    env_id: str | None = None
    env_kwargs: dict[str, Any] | None = None
    seed: int | None = None


def _zoo_args_candidates(path: Path) -> list[Path]:
    """rl-zoo3's ``args.yml`` of a model: ``<run>/<env id>/args.yml`` beside ``<run>/<env
    id>.zip`` (or beside ``best_model.zip`` / checkpoints in ``<run>/``)."""
    out = [path.with_suffix("") / "args.yml"]
    if path.parent.is_dir():
        out.extend(sorted(c for c in path.parent.glob("*/args.yml") if c not in out))
    return out


def load_yaml_data(text: str) -> Any:
    """YAML as plain data: Python tags (rl-zoo3 writes ``args.yml`` with them) become lists,
    mappings and strings, never objects (a :class:`yaml.SafeLoader` that builds none)."""
    import yaml

    class _DataLoader(yaml.SafeLoader):
        pass

    def _plain(loader: yaml.SafeLoader, suffix: str, node: yaml.Node) -> Any:
        if isinstance(node, yaml.MappingNode):
            return loader.construct_mapping(node, deep=True)
        if isinstance(node, yaml.SequenceNode):
            return loader.construct_sequence(node, deep=True)
        return loader.construct_scalar(node)  # type: ignore[arg-type]

    _DataLoader.add_multi_constructor("", _plain)
    return yaml.load(text, Loader=_DataLoader)


def _read_yaml_data(text: str) -> Any:
    """:func:`load_yaml_data` of an rl-zoo3 ``args.yml``, an ``OrderedDict`` made a dict."""
    data = load_yaml_data(text)
    if isinstance(data, list) and len(data) == 1 and isinstance(data[0], list):
        data = data[0]  # the argument list of ``!!python/object/apply:collections.OrderedDict``
    if isinstance(data, list) and all(isinstance(i, list) and len(i) == 2 for i in data):
        data = {k: v for k, v in data if isinstance(k, str)}  # an OrderedDict as its pairs
    return data


def _env_name(value: Any) -> str | None:
    """An env id as recorded: a string, or rl-zoo3's ``EnvironmentName`` as plain data."""
    if isinstance(value, dict):
        value = (value.get("args") or [None])[0]
    return value if isinstance(value, str) and value else None


def _read_record(path: Path, kind: str) -> TrainingRecord:
    """The record at ``path`` (``kind``: ``run``, ``shipped`` or ``zoo``); an unreadable one
    records nothing."""
    try:
        if kind == "zoo":
            data = _read_yaml_data(path.read_text())
            env_id, kwargs, seed = (
                _env_name(data.get("env")),
                data.get("env_kwargs"),
                data.get("seed"),
            )
        else:
            data = json.loads(path.read_text())
            config = data["run"]["config"] if kind == "shipped" else data.get("config", data)
            env_id, kwargs, seed = (
                config.get("env_id"),
                config.get("env_kwargs"),
                config.get("seed"),
            )
    except Exception:  # unreadable JSON or YAML of any kind records nothing
        return TrainingRecord(path)
    return TrainingRecord(
        path,
        env_id if isinstance(env_id, str) and env_id else None,
        dict(kwargs) if isinstance(kwargs, dict) else None,
        seed if isinstance(seed, int) and not isinstance(seed, bool) else None,
    )


def training_record(path: str | Path) -> TrainingRecord | None:
    """What the training of the model ``path`` recorded, from the first record found: a shipped
    model's provenance, its run's ``config.json`` (beside the model, or one level up for a
    checkpoint), rl-zoo3's ``args.yml``; ``None`` if there is none."""
    p = Path(path)
    shipped = shipped_model_of(p)
    candidates = [(shipped.provenance, "shipped")] if shipped is not None else []
    candidates += [(p.parent / "config.json", "run"), (p.parent.parent / "config.json", "run")]
    candidates += [(c, "zoo") for c in _zoo_args_candidates(p)]
    for cand, kind in candidates:
        if cand.is_file():
            return _read_record(cand, kind)
    return None


def run_env_kwargs(path: Path) -> dict[str, Any] | None:
    """The environment keyword arguments a model was trained with, if its training record
    (:func:`training_record`) has them; else ``None``."""
    record = training_record(path)
    return record.env_kwargs if record is not None else None


#: Ids of development versions that were never released and the id whose machine and task they
#: ran (their models play there); an id registered now is never renamed.
RENAMED_IDS: dict[str, str] = {"Planar3P-v1": "Planar3P-v0"}


def _environment(env_id: str) -> tuple[Any, Any] | None:
    """The entry point of a registered id and the task its registration names (``None`` where
    the class has its own), or ``None`` for an unknown id."""
    from gymnasium.envs.registration import registry

    spec = registry.get(env_id)
    return None if spec is None else (spec.entry_point, spec.kwargs.get("task"))


def renamed(trained_id: str) -> str:
    """``trained_id``, or the id :data:`RENAMED_IDS` gives where ``trained_id`` is not
    registered."""
    return trained_id if _environment(trained_id) else RENAMED_IDS.get(trained_id, trained_id)


def same_task(trained_id: str, env_id: str) -> bool:
    """Whether a model trained on ``trained_id`` may play ``env_id``: the same id (after
    :func:`renamed`), or two registrations of the same environment class and task that differ
    only in their defaults (``Planar3PGoal-v0`` and ``Planar3PGoalDense-v0``: the reward)."""
    trained = renamed(trained_id)
    if trained == env_id:
        return True
    environment = _environment(trained)
    return environment is not None and environment == _environment(env_id)


def check_trained_id(path: Path, env: Any) -> None:
    """:class:`PolicyError` naming both ids if the model ``path`` was trained on another id
    than ``env``'s (:func:`same_task`); nothing if either id is unknown."""
    spec = getattr(env, "spec", None) or getattr(getattr(env, "unwrapped", None), "spec", None)
    env_id = getattr(spec, "id", None)
    record = training_record(path)
    if not env_id or record is None or record.env_id is None or same_task(record.env_id, env_id):
        return
    now = renamed(record.env_id)
    hint = f" (now {now})" if now != record.env_id else ""
    raise PolicyError(
        f"model {path} was trained on {record.env_id}{hint} (recorded in {record.source}), "
        f"the environment is {env_id}: play it on {now}"
    )


def _load_vecnormalize(path: Path) -> Any:
    from stable_baselines3.common.vec_env import VecNormalize

    try:
        with path.open("rb") as f:
            vn = pickle.load(f)
    except Exception as exc:  # unpickling can raise nearly anything on a corrupt file
        raise PolicyError(f"corrupt VecNormalize statistics {path}: {exc}") from exc
    if not isinstance(vn, VecNormalize):
        raise PolicyError(f"{path} does not hold VecNormalize statistics")
    vn.training = False
    vn.norm_reward = False
    return vn


class SB3Policy(PolicyAdapter):
    """A loaded Stable-Baselines3 model, with its frozen ``VecNormalize`` statistics if any.

    :meth:`predict` normalises the observation (if statistics were found) and calls the
    model's ``predict``; deterministic by default.
    """

    def __init__(
        self,
        model: Any,
        vecnormalize: Any = None,
        name: str = "model",
        env_kwargs: dict[str, Any] | None = None,
        vecnormalize_path: Path | None = None,
    ) -> None:
        super().__init__(model)
        self.vecnormalize = vecnormalize
        self.name = name
        #: Environment keyword arguments recorded by the training run (``None`` if unknown).
        self.env_kwargs = env_kwargs
        self.vecnormalize_path = vecnormalize_path

    @property
    def model(self) -> Any:
        """The SB3 model (the wrapped policy)."""
        return self.policy

    @property
    def observation_space(self) -> Any:
        return self.model.observation_space

    @property
    def action_space(self) -> Any:
        return self.model.action_space

    def reset(self, seed: Any = None) -> None:
        """Nothing to reset (kept for the benchmark's uniform calling convention)."""

    def adapt(self, observation: ArrayLike) -> Any:
        """The observation as float32 (each entry of a ``Dict`` one), normalised with the
        statistics if any."""
        if isinstance(observation, dict):
            obs: Any = {k: np.asarray(v, dtype=np.float32) for k, v in observation.items()}
            if self.vecnormalize is not None:
                obs = self.vecnormalize.normalize_obs(obs)
                obs = {k: np.asarray(v, dtype=np.float32) for k, v in obs.items()}
            return obs
        obs = np.asarray(observation, dtype=np.float32)
        if self.vecnormalize is not None:
            obs = self.vecnormalize.normalize_obs(obs).astype(np.float32)
        return obs


def _shapes(space: Any) -> Any:
    """A space's shape, or ``{key: shape}`` for a ``Dict`` space."""
    sub = getattr(space, "spaces", None)
    if isinstance(sub, dict):
        return {k: v.shape for k, v in sub.items()}
    return space.shape


def _stats_shapes(obs_rms: Any) -> Any:
    """The observation shape(s) ``VecNormalize`` statistics are for (``Dict``: per key)."""
    if isinstance(obs_rms, dict):
        return {k: v.mean.shape for k, v in obs_rms.items()}
    return obs_rms.mean.shape


def _stats_fit(stats: Any, shapes: Any) -> bool:
    """Statistics fit a space: same shape, or for a ``Dict`` space each normalised key (a
    subset: ``norm_obs_keys``) with its shape."""
    if isinstance(stats, dict):
        return isinstance(shapes, dict) and all(shapes.get(k) == v for k, v in stats.items())
    return stats == shapes


def load_sb3_model(
    path: str | Path,
    algo: str | None = None,
    device: str = "cpu",
    name: str | None = None,
    check_env: Any = None,
    vecnormalize: str | Path | None = None,
) -> SB3Policy:
    """Load an SB3 model file and, if named, its ``VecNormalize`` statistics.

    Both are code (:data:`TRUSTED_FILES_NOTE`).  ``vecnormalize``: the statistics file, or
    :data:`NO_STATS` to go without; ``None`` refuses a model that has statistics beside it
    (:func:`vecnormalize_candidates`) rather than load them unasked or silently ignore them.
    ``check_env``: an environment the model must fit: trained on its id (:func:`check_trained_id`,
    checked before anything is loaded) and with its observation and action spaces.
    Raises :class:`PolicyError` for a missing, corrupt or mismatched model.
    """
    p = Path(path)
    if not p.is_file():
        raise PolicyError(f"model file not found: {p}")
    vn_path: Path | None = None
    if vecnormalize is None:
        found = _vecnormalize_file(p)
        if found is not None:
            raise _unnamed_stats_error(p, found)
    elif str(vecnormalize).lower() != NO_STATS:
        vn_path = Path(vecnormalize).expanduser()
        if not vn_path.is_file():
            raise PolicyError(f"statistics file not found: {vn_path}")
    if check_env is not None:
        check_trained_id(p, check_env)
    key = algo or _detect_algorithm(p)
    if key not in SB3_ALGORITHMS:
        raise PolicyError(f"unknown SB3 algorithm {key!r}; known: {', '.join(SB3_ALGORITHMS)}")
    if key == "tqc":
        import sb3_contrib as algorithms
    else:
        import stable_baselines3 as algorithms

    from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm

    cls = getattr(algorithms, SB3_ALGORITHMS[key])
    # Playing needs no replay buffer: an off-policy model gets a one-entry plain buffer instead
    # of the saved one (a HER buffer cannot even be built without the training env).
    no_buffer = (
        {"replay_buffer_class": None, "replay_buffer_kwargs": {}, "buffer_size": 1}
        if issubclass(cls, OffPolicyAlgorithm)
        else {}
    )
    try:
        model = cls.load(p, device=device, **no_buffer)
    except Exception as exc:  # SB3/torch raise many types on corrupt or foreign files
        raise PolicyError(
            f"cannot load {p} as a {SB3_ALGORITHMS[key]} model: {type(exc).__name__}: {exc}"
        ) from exc
    vn = _load_vecnormalize(vn_path) if vn_path is not None else None
    if check_env is not None:
        obs_space = check_env.observation_space
        act_space = check_env.action_space
        # A policy that builds part of its observation itself (the command in flight) is
        # played on the rest: :mod:`planar3p_agents.policies.command_memory`.
        played = getattr(model.policy, "played_observation_space", model.observation_space)
        if _shapes(played) != _shapes(obs_space):
            seen = observation_kwargs(run_env_kwargs(p))
            hint = f"; it was trained with {seen}: make the environment with them" if seen else ""
            raise PolicyError(
                f"model {p} expects observations of shape {_shapes(played)}, "
                f"the environment gives {_shapes(obs_space)}{hint}"
            )
        if model.action_space.shape != act_space.shape:
            raise PolicyError(
                f"model {p} outputs actions of shape {model.action_space.shape}, "
                f"the environment takes {act_space.shape}"
            )
        # Statistics of a run that normalised rewards only (norm_obs=False) have no obs_rms.
        fit = (
            vn is None
            or not vn.norm_obs
            or _stats_fit(_stats_shapes(vn.obs_rms), _shapes(obs_space))
        )
        if not fit:
            raise PolicyError(
                f"VecNormalize statistics {vn_path} are for observations of shape "
                f"{_stats_shapes(vn.obs_rms)}, the environment gives {_shapes(obs_space)}"
            )
    return SB3Policy(model, vn, name or p.stem, run_env_kwargs(p), vn_path)
