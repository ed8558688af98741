"""Policy registry and loader: a policy name or a model path -> an object with SB3's ``predict``.

Accepted specifications (:func:`load_policy`):

* built-in names: ``analytic-simultaneous``, ``analytic-sequential`` (:mod:`agents.analytic`),
  ``random``, ``zero`` (:mod:`agents.baselines`);
* ``pretrained:<name>``: the model ``agents/pretrained/<name>.zip`` shipped with the package,
  with its statistics ``<name>_vecnormalize.pkl``; both are checked against the SHA-256 sums in
  ``agents/pretrained/SHA256SUMS`` before anything is loaded (:func:`verify_pretrained`);
* a path to a Stable-Baselines3 model (``.zip``) saved by PPO, SAC, TD3, A2C or DDPG; the
  algorithm is read from the file, or forced with a prefix ``ppo:``, ``sac:``, ``td3:``,
  ``a2c:``, ``ddpg:`` (e.g. ``sac:runs/x/model.zip``).

Model and statistics files are code (:data:`TRUSTED_FILES_NOTE`): loading one can run arbitrary
commands, so load only files you trust, and nothing is unpickled that the caller did not name.
Observation statistics (``VecNormalize``) are loaded only when named, with the suffix
``:stats=PATH.pkl`` (``runs/x/model.zip:stats=runs/x/vecnormalize.pkl``) or the ``vecnormalize``
argument of :func:`load_policy`; ``:stats=none`` evaluates the model without them.  A model
with statistics beside it in a known layout (:func:`vecnormalize_candidates`: this project's
runs, the pretrained layout, rl-zoo3's ``<run>/<env id>/vecnormalize.pkl``) and no ``stats``
named is refused, because evaluating it without them would silently measure something else.

Every failure to resolve or load a specification raises :class:`PolicyError` (a
``ValueError``) with a message that says what was wrong.
"""

from __future__ import annotations

import hashlib
import json
import pickle
import re
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from planar3p_gym.design import Design

from .analytic import AnalyticController
from .baselines import RandomPolicy, ZeroPolicy

__all__ = [
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

#: Say this wherever a file can be loaded (README, ``--help`` of scripts that load models).
TRUSTED_FILES_NOTE = (
    "Model (.zip) and statistics (.pkl) files are code: loading one can run arbitrary "
    "commands, so load only files you trust. Shipped pretrained:<name> files are checked "
    "against agents/pretrained/SHA256SUMS first; statistics are loaded only when named "
    "(MODEL.zip:stats=STATS.pkl, or :stats=none to go without)."
)

#: Built-in policies and what they are.
BUILTIN_POLICIES: dict[str, str] = {
    "analytic-simultaneous": "simple motions superposed (resolved-rate control)",
    "analytic-sequential": "simple motions one at a time: rotation, vertical, horizontal",
    "random": "uniformly random actions (seeded)",
    "zero": "zero slider velocity",
}
#: Where ``pretrained:<name>`` models live.
PRETRAINED_DIR = Path(__file__).resolve().parent / "pretrained"
#: Stable-Baselines3 algorithms a model file may come from (prefix -> class name).
SB3_ALGORITHMS: dict[str, str] = {
    "ppo": "PPO",
    "sac": "SAC",
    "td3": "TD3",
    "a2c": "A2C",
    "ddpg": "DDPG",
    "tqc": "TQC",  # sb3-contrib
}
PRETRAINED_PREFIX = "pretrained:"
#: SHA-256 sums of the shipped files, in ``sha256sum`` format (``sha256sum -c SHA256SUMS``).
MANIFEST = "SHA256SUMS"
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
        name: the built-in name, or the model's label (``pretrained:<name>`` or file stem).
        path: the model file (``kind == "model"``).
        algo: the forced SB3 algorithm key (``ppo``, ...), or ``None`` to detect it.
        stats: the named ``VecNormalize`` statistics file, :data:`NO_STATS`, or ``None``
            (none named).
    """

    text: str
    kind: str
    name: str
    path: Path | None = None
    algo: str | None = None
    stats: Path | str | None = None


def file_sha256(path: Path) -> str:
    """Hex SHA-256 of a file's bytes."""
    h = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _read_manifest(directory: Path) -> dict[str, str]:
    path = directory / MANIFEST
    try:
        lines = path.read_text().splitlines()
    except OSError as exc:
        raise PolicyError(f"cannot read the checksum manifest {path}: {exc}") from exc
    sums = {}
    for line in lines:
        if not line.strip():
            continue
        m = re.fullmatch(r"([0-9a-fA-F]{64}) [ *](.+)", line.rstrip("\r\n"))
        if m is None:
            raise PolicyError(f"malformed line in {path} (want sha256sum format): {line!r}")
        sums[m.group(2)] = m.group(1).lower()
    return sums


#: Shipped files the manifest covers (all are read by a loader; ``.yml`` by rl-zoo3's YAML).
MANIFEST_SUFFIXES = (".zip", ".pkl", ".json", ".yml", ".yaml")


def write_manifest(directory: Path | None = None) -> Path:
    """(Re)write ``SHA256SUMS`` for every model, statistics, record and config file under the
    pretrained directory, subfolders included (rl-zoo3 layout), named by their relative POSIX
    paths as ``sha256sum -c`` expects (``scripts/ship_policy.py`` calls this after copying)."""
    d = directory or PRETRAINED_DIR
    files = sorted(p for p in d.rglob("*") if p.is_file() and p.suffix in MANIFEST_SUFFIXES)
    out = d / MANIFEST
    lines = (f"{file_sha256(p)}  {p.relative_to(d).as_posix()}\n" for p in files)
    out.write_text("".join(lines))
    return out


def verify_pretrained(name: str, directory: Path | None = None) -> list[Path]:
    """Check the shipped files of ``pretrained:<name>`` against ``SHA256SUMS``; return the
    verified files (model first, then its statistics if shipped).  Raises :class:`PolicyError`
    naming the file if one is missing from the manifest or its bytes differ."""
    d = directory or PRETRAINED_DIR
    sums = _read_manifest(d)
    files = [d / f"{name}.zip"]
    stats = d / f"{name}_vecnormalize.pkl"
    if stats.is_file() or stats.name in sums:
        files.append(stats)
    for path in files:
        want = sums.get(path.name)
        if want is None:
            raise PolicyError(
                f"{path} is not listed in {d / MANIFEST}; refusing to load an unverified file "
                "(model and statistics files are code)"
            )
        if not path.is_file():
            raise PolicyError(f"shipped file {path} is missing")
        got = file_sha256(path)
        if got != want:
            raise PolicyError(
                f"checksum mismatch for shipped file {path}: SHA-256 {got}, expected {want} "
                f"({MANIFEST}); the file was altered or corrupted, refusing to load it "
                "(model and statistics files are code)"
            )
    return files


def list_pretrained(directory: Path | None = None) -> list[str]:
    """Names of the shipped pretrained models (``pretrained:<name>``)."""
    d = directory or PRETRAINED_DIR
    if not d.is_dir():
        return []
    return sorted(p.stem for p in d.glob("*.zip"))


def _known() -> str:
    names = list(BUILTIN_POLICIES) + [PRETRAINED_PREFIX + n for n in list_pretrained()]
    return ", ".join(names) + ", or a path to an SB3 model .zip[:stats=STATS.pkl]"


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
        path = PRETRAINED_DIR / f"{name}.zip"
        if not path.is_file():
            have = list_pretrained()
            raise PolicyError(
                f"unknown pretrained model {name!r}: {path} does not exist; "
                f"available: {', '.join(have) if have else 'none shipped yet'}"
            )
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
    ``model``/``best_model`` and for rl-zoo3's ``<run>/<env id>.zip``)."""
    spec = str(text).strip()
    if spec in BUILTIN_POLICIES or spec.startswith(PRETRAINED_PREFIX):
        return spec
    if STATS_MARK in spec:
        spec = spec.rpartition(STATS_MARK)[0]
    head, sep, rest = spec.partition(":")
    if sep and head.lower() in SB3_ALGORITHMS and rest:
        spec = rest
    p = Path(spec)
    parent = p.parent.name
    generic = p.stem in ("model", "best_model") or p.stem.endswith("_model")
    zoo = (p.parent / p.stem).is_dir()  # rl-zoo3: <run>/<env id>.zip beside <run>/<env id>/
    return f"{parent}/{p.stem}" if parent and (generic or zoo) else p.stem


# ------------------------------------------------------------------ SB3 models
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
    ``rl_model_vecnormalize_<n>_steps.pkl``), the pretrained layout (``<name>.zip`` +
    ``<name>_vecnormalize.pkl``) and rl-zoo3's (``<run>/<env id>.zip`` or ``best_model.zip``
    + ``<run>/<env id>/vecnormalize.pkl``).  Nothing is loaded from these places unless named:
    :func:`load_sb3_model` refuses a model that has statistics there and none named.
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


def run_env_kwargs(path: Path) -> dict[str, Any] | None:
    """The environment keyword arguments a model was trained with, if its run directory
    (``scripts/train.py``) has a ``config.json`` that records them; else ``None``."""
    for cand in (path.parent / "config.json", path.parent.parent / "config.json"):
        if cand.is_file():
            try:
                data = json.loads(cand.read_text())
                kwargs = data.get("config", data).get("env_kwargs")
            except (OSError, ValueError, AttributeError):
                return None
            return dict(kwargs) if isinstance(kwargs, dict) else None
    return None


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


class SB3Policy:
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
        self.model = model
        self.vecnormalize = vecnormalize
        self.name = name
        #: Environment keyword arguments recorded by the training run (``None`` if unknown).
        self.env_kwargs = env_kwargs
        self.vecnormalize_path = vecnormalize_path

    @property
    def observation_space(self) -> Any:
        return self.model.observation_space

    @property
    def action_space(self) -> Any:
        return self.model.action_space

    def reset(self, seed: Any = None) -> None:
        """Nothing to reset (kept for the benchmark's uniform calling convention)."""

    def predict(
        self,
        observation: ArrayLike,
        state: Any = None,
        episode_start: ArrayLike | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        obs = np.asarray(observation, dtype=np.float32)
        if self.vecnormalize is not None:
            obs = self.vecnormalize.normalize_obs(obs).astype(np.float32)
        return self.model.predict(
            obs, state=state, episode_start=episode_start, deterministic=deterministic
        )


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
    ``check_env``: an environment whose observation and action spaces the model must match.
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
    key = algo or _detect_algorithm(p)
    if key not in SB3_ALGORITHMS:
        raise PolicyError(f"unknown SB3 algorithm {key!r}; known: {', '.join(SB3_ALGORITHMS)}")
    if key == "tqc":
        import sb3_contrib as algorithms
    else:
        import stable_baselines3 as algorithms

    cls = getattr(algorithms, SB3_ALGORITHMS[key])
    try:
        model = cls.load(p, device=device)
    except Exception as exc:  # SB3/torch raise many types on corrupt or foreign files
        raise PolicyError(
            f"cannot load {p} as a {SB3_ALGORITHMS[key]} model: {type(exc).__name__}: {exc}"
        ) from exc
    vn = _load_vecnormalize(vn_path) if vn_path is not None else None
    if check_env is not None:
        obs_space = check_env.observation_space
        act_space = check_env.action_space
        if model.observation_space.shape != obs_space.shape:
            raise PolicyError(
                f"model {p} expects observations of shape {model.observation_space.shape}, "
                f"the environment gives {obs_space.shape}"
            )
        if model.action_space.shape != act_space.shape:
            raise PolicyError(
                f"model {p} outputs actions of shape {model.action_space.shape}, "
                f"the environment takes {act_space.shape}"
            )
        if vn is not None and vn.obs_rms.mean.shape != obs_space.shape:
            raise PolicyError(
                f"VecNormalize statistics {vn_path} are for observations of shape "
                f"{vn.obs_rms.mean.shape}, the environment gives {obs_space.shape}"
            )
    return SB3Policy(model, vn, name or p.stem, run_env_kwargs(p), vn_path)


def load_policy(
    spec: str | PolicySpec,
    *,
    env: Any = None,
    design: Design | None = None,
    seed: int | None = None,
    device: str = "cpu",
    vecnormalize: str | Path | None = None,
) -> Any:
    """The policy named by ``spec`` (see the module docstring), ready to ``predict``.

    ``env`` (optional) supplies the design of the analytic controllers and the spaces a
    model must match; ``design`` can be given instead.  ``seed`` seeds the random policy.
    ``vecnormalize``: statistics file of a model path (or :data:`NO_STATS`), like the spec's
    ``:stats=`` suffix (giving both is an error).  Model and statistics files are code: see
    :data:`TRUSTED_FILES_NOTE`.
    """
    ps = spec if isinstance(spec, PolicySpec) else parse_policy_spec(spec)
    stats = ps.stats
    if vecnormalize is not None:
        if ps.kind != "model" or ps.text.startswith(PRETRAINED_PREFIX):
            raise PolicyError(f"statistics apply to model paths only, not {ps.text!r}")
        if stats is not None:
            raise PolicyError(f"statistics named twice for {ps.text!r} (spec and argument)")
        stats = _stats_value(str(vecnormalize))
    if design is None and env is not None:
        design = env.unwrapped.design
    if ps.kind == "builtin":
        if ps.name == "analytic-simultaneous":
            return AnalyticController(design, "simultaneous")
        if ps.name == "analytic-sequential":
            return AnalyticController(design, "sequential")
        if ps.name == "random":
            return RandomPolicy(env.action_space if env is not None else None, seed=seed)
        return ZeroPolicy()
    assert ps.path is not None
    if ps.text.startswith(PRETRAINED_PREFIX):
        files = verify_pretrained(ps.name[len(PRETRAINED_PREFIX) :], ps.path.parent)
        stats = files[1] if len(files) > 1 else NO_STATS
    return load_sb3_model(
        ps.path, ps.algo, device=device, name=ps.name, check_env=env, vecnormalize=stats
    )
