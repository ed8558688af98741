"""The layout of the shipped policies: where every file of ``pretrained:<name>`` lives.

Each shipped model is one rl-zoo3 log folder under ``agents/zoo/pretrained/<name>/`` with its
``provenance.json``, every file checked against ``SHA256SUMS`` before loading (the tree and the
provenance's keys: docs/pretrained.md, "How the zoo is laid out").  This module is the only
definition of these paths and imports nothing heavy.

* :data:`PRETRAINED_DIR`, :data:`PROVENANCE`, :data:`EXPERIMENT_ID`: the places;
* :class:`ShippedModel`, :func:`shipped_model`, :func:`shipped_model_of`,
  :func:`shipped_names`, :func:`read_provenance`, :func:`check_name`: a model's files;
* :func:`enjoy_command`: rl-zoo3's command that plays it.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = [
    "EXPERIMENT_ID",
    "PRETRAINED_DIR",
    "PROVENANCE",
    "ShippedModel",
    "check_name",
    "enjoy_command",
    "read_provenance",
    "shipped_model",
    "shipped_model_of",
    "shipped_names",
]

#: Where ``pretrained:<name>`` models live.
PRETRAINED_DIR = Path(__file__).resolve().parent / "pretrained"
#: The provenance record of a shipped model, at the top of its folder.
PROVENANCE = "provenance.json"
#: Every model folder holds one experiment, rl-zoo3's experiment id 1 (``--exp-id 1``).
EXPERIMENT_ID = 1

_TOKEN = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.\-]*")


def check_name(name: str) -> None:
    """``ValueError`` unless ``name`` is a usable model name (letters, digits, ``-`` and ``_``)."""
    if (
        not isinstance(name, str)
        or not name
        or not name.replace("_", "").replace("-", "").isalnum()
    ):
        raise ValueError(f"invalid name {name!r} (letters, digits, - and _)")


def _check_token(what: str, value: Any) -> str:
    """An algorithm key or environment id usable as a path component."""
    if not isinstance(value, str) or not _TOKEN.fullmatch(value) or ".." in value:
        raise ValueError(f"invalid {what} {value!r} in a provenance record")
    return value


@dataclass(frozen=True)
class ShippedModel:
    """The files of one shipped model (they need not exist yet: shipping writes them).

    Attributes:
        root: the pretrained directory (holds ``SHA256SUMS``).
        name: the model's name (``pretrained:<name>``).
        algo: the SB3 algorithm key (``ppo``, ...), rl-zoo3's ``--algo``.
        env_id: the id it was trained on, rl-zoo3's ``--env``.
    """

    root: Path
    name: str
    algo: str
    env_id: str

    def __post_init__(self) -> None:
        check_name(self.name)
        _check_token("algorithm", self.algo)
        _check_token("environment id", self.env_id)

    @property
    def folder(self) -> Path:
        """The model's folder: rl-zoo3's log folder (``-f``)."""
        return self.root / self.name

    @property
    def provenance(self) -> Path:
        return self.folder / PROVENANCE

    @property
    def experiment(self) -> Path:
        """rl-zoo3's experiment folder ``<algo>/<env id>_1``."""
        return self.folder / self.algo / f"{self.env_id}_{EXPERIMENT_ID}"

    @property
    def model(self) -> Path:
        return self.experiment / f"{self.env_id}.zip"

    @property
    def params(self) -> Path:
        """rl-zoo3's folder of saved settings and statistics, ``<env id>/``."""
        return self.experiment / self.env_id

    @property
    def stats(self) -> Path:
        return self.params / "vecnormalize.pkl"

    @property
    def zoo_config(self) -> Path:
        return self.params / "config.yml"

    @property
    def zoo_args(self) -> Path:
        return self.params / "args.yml"

    def files(self) -> list[Path]:
        """The model's files that exist, provenance first, then the model, its statistics and the
        rl-zoo3 settings."""
        every = (self.provenance, self.model, self.stats, self.zoo_config, self.zoo_args)
        return [p for p in every if p.is_file()]

    def relative(self, path: Path) -> str:
        """``path`` as the manifest names it (POSIX, relative to ``root``)."""
        return path.relative_to(self.root).as_posix()


def read_provenance(path: Path) -> dict[str, Any]:
    """The provenance record at ``path`` (JSON, never a pickle); ``ValueError`` if unreadable."""
    try:
        record = json.loads(path.read_text())
        record["run"]["config"]["algo"], record["run"]["config"]["env_id"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"no readable provenance record {path}: {exc}") from exc
    return record


def shipped_model(name: str, directory: Path | None = None) -> ShippedModel:
    """The files of the shipped ``pretrained:<name>`` in ``directory`` (default
    :data:`PRETRAINED_DIR`), from its provenance record; ``ValueError`` if it has none."""
    root = Path(directory) if directory is not None else PRETRAINED_DIR
    check_name(name)
    config = read_provenance(root / name / PROVENANCE)["run"]["config"]
    return ShippedModel(root, name, config["algo"], config["env_id"])


def shipped_names(directory: Path | None = None) -> list[str]:
    """Names of the models shipped in ``directory`` (folders with a provenance record), sorted."""
    root = Path(directory) if directory is not None else PRETRAINED_DIR
    if not root.is_dir():
        return []
    return sorted(
        p.name for p in root.iterdir() if not p.name.startswith(".") and (p / PROVENANCE).is_file()
    )


def shipped_model_of(path: str | Path) -> ShippedModel | None:
    """The shipped model whose model file is ``path`` (``<root>/<name>/<algo>/<env id>_1/<env
    id>.zip`` beside ``<root>/<name>/provenance.json``), else ``None``; reads nothing."""
    p = Path(path)
    if len(p.parents) < 4 or p.suffix != ".zip":
        return None
    experiment, algo_dir, folder = p.parents[0], p.parents[1], p.parents[2]
    if experiment.name != f"{p.stem}_{EXPERIMENT_ID}" or not (folder / PROVENANCE).is_file():
        return None
    try:
        return ShippedModel(p.parents[3], folder.name, algo_dir.name, p.stem)
    except ValueError:
        return None


def enjoy_command(model: ShippedModel, folder: str | None = None) -> str:
    """The command that plays ``model`` with rl-zoo3 (``folder``: how to name its folder,
    default ``agents/zoo/pretrained/<name>``).  rl-zoo3 does not check ``SHA256SUMS``."""
    f = folder if folder is not None else f"agents/zoo/pretrained/{model.name}"
    return (
        f"python -m rl_zoo3.enjoy --algo {model.algo} --env {model.env_id} -f {f} "
        f"--exp-id {EXPERIMENT_ID} --gym-packages planar3p_gym"
    )
