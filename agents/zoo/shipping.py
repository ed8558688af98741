"""Ship a trained model from a run directory into ``agents/zoo/pretrained/`` in two layouts.

1. This project's: ``<name>.zip`` (the model), ``<name>_vecnormalize.pkl`` (its observation
   statistics, if the run normalised) and ``<name>.json`` (provenance: the run's config and
   command, its metrics, the versions), which ``pretrained:<name>`` loads.
2. rl-zoo3's, so that ``python -m rl_zoo3.enjoy --algo ALGO --env ID -f agents/zoo/pretrained
   --gym-packages planar3p_gym`` plays it::

       <algo>/<env id>_<n>/<env id>.zip                  the model
       <algo>/<env id>_<n>/<env id>/vecnormalize.pkl     its statistics
       <algo>/<env id>_<n>/<env id>/config.yml           the hyperparameters (zoo format)
       <algo>/<env id>_<n>/<env id>/args.yml             algo, env id, env kwargs, seed, name

   ``<n>`` is the experiment id (``--exp-id``; enjoy's default is the highest): a re-shipped
   name keeps its id, a new name gets the next one.

Afterwards the checksum manifest (:func:`planar3p_agents.zoo.manifest.write_manifest`) is rewritten.
rl-zoo3's own packaging (``rl_zoo3.push_to_hub``) uploads to the Hugging Face hub and needs
its training layout, so it does not do this job; the zoo layout written here is what its
``enjoy`` / ``record_video`` read.  Files are written atomically.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import yaml

from planar3p_agents.policies.spec import PRETRAINED_DIR
from planar3p_agents.training.checkpoints import checkpoint_path
from planar3p_agents.zoo.manifest import write_manifest
from planar3p_gym.atomic_files import copy_atomic, write_atomic

__all__ = ["CHECKPOINT_PREFIX", "MODELS", "model_files", "ship", "zoo_layout"]

#: Models of a run directory (``scripts/train.py``) and their statistics; older runs kept the
#: best model at the top level as ``best_model.zip`` + ``best_vecnormalize.pkl``.
MODELS = {
    "model": ("model.zip", "vecnormalize.pkl"),
    "best_model": ("best/best_model.zip", "best/vecnormalize.pkl"),
    "kickstart_model": ("kickstart_model.zip", "kickstart_vecnormalize.pkl"),
}
_LEGACY_BEST = ("best_model.zip", "best_vecnormalize.pkl")


def _copy(src: Path, dst: Path) -> None:
    dst.parent.mkdir(parents=True, exist_ok=True)
    copy_atomic(src, dst)


def _write(dst: Path, text: str) -> None:
    dst.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(dst, text)


def _check_name(name: str) -> None:
    if not name or not name.replace("_", "").replace("-", "").isalnum():
        raise ValueError(f"invalid name {name!r} (letters, digits, - and _)")


def _experiment_id(base: Path, env_id: str, name: str) -> int:
    """The zoo experiment id of ``name`` under ``base`` (existing, else the next free one)."""
    ids = {}
    for args in base.glob(f"{env_id}_*/{env_id}/args.yml"):
        exp = args.parent.parent.name[len(env_id) + 1 :]
        if exp.isdigit():
            shipped = (yaml.safe_load(args.read_text()) or {}).get("shipped_name")
            ids[int(exp)] = shipped
    for exp, shipped in ids.items():
        if shipped == name:
            return exp
    return max(ids, default=0) + 1


def zoo_layout(name: str, directory: Path | None = None) -> Path:
    """Write (or rewrite) the rl-zoo3 layout of the shipped ``pretrained:<name>`` from its
    files and provenance in ``directory``; returns the experiment folder."""
    d = directory or PRETRAINED_DIR
    _check_name(name)
    try:
        record = json.loads((d / f"{name}.json").read_text())
        config = record["run"]["config"]
        algo, env_id = config["algo"], config["env_id"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"no readable provenance {d / (name + '.json')}: {exc}") from exc
    model = d / f"{name}.zip"
    if not model.is_file():
        raise ValueError(f"{model} does not exist")
    base = d / algo
    exp = base / f"{env_id}_{_experiment_id(base, env_id, name)}"
    _copy(model, exp / f"{env_id}.zip")
    stats = d / f"{name}_vecnormalize.pkl"
    entry: dict[str, Any] = dict(record["run"].get("entry") or {})
    entry["normalize"] = stats.is_file()  # the zoo loads <env id>/vecnormalize.pkl if true
    entry.update(n_envs=config.get("n_envs"), n_timesteps=config.get("n_timesteps"))
    if stats.is_file():
        _copy(stats, exp / env_id / "vecnormalize.pkl")
    else:
        (exp / env_id / "vecnormalize.pkl").unlink(missing_ok=True)
    entry.pop("env_kwargs", None)
    _write(exp / env_id / "config.yml", yaml.safe_dump(entry, sort_keys=True))
    args = {
        "algo": algo,
        "env": env_id,
        "env_kwargs": config.get("env_kwargs") or None,
        "seed": config.get("seed"),
        "n_timesteps": config.get("n_timesteps"),
        "shipped_name": name,
        "command": record["run"].get("command", ""),
    }
    _write(exp / env_id / "args.yml", yaml.safe_dump(args, sort_keys=True))
    return exp


#: ``checkpoint:<steps>``: the run's checkpoint after ``<steps>`` environment steps.
CHECKPOINT_PREFIX = "checkpoint:"


def model_files(model: str) -> tuple[str, str]:
    """Paths, relative to a run directory, of the model ``model`` (a key of :data:`MODELS`
    or ``checkpoint:<steps>``) and of its statistics.  ``ValueError`` for another name."""
    if model in MODELS:
        return MODELS[model]
    steps = model.removeprefix(CHECKPOINT_PREFIX)
    if model.startswith(CHECKPOINT_PREFIX) and steps.isdigit() and int(steps) > 0:
        n = int(steps)
        return checkpoint_path(n), checkpoint_path(n, "vecnormalize")
    raise ValueError(
        f"model must be one of {', '.join(MODELS)} or {CHECKPOINT_PREFIX}<steps>, got {model!r}"
    )


def ship(
    run: Path,
    name: str,
    model: str = "best_model",
    out: Path | None = None,
    note: str = "",
) -> list[Path]:
    """Copy ``model`` of the run directory ``run`` into ``out`` (default
    ``agents/zoo/pretrained``) as ``pretrained:<name>`` in both layouts; returns the files
    written.  ``ValueError`` (nothing written) if the name or the run is not usable."""
    _check_name(name)
    model_rel, stats_rel = model_files(model)
    out = Path(out) if out is not None else PRETRAINED_DIR
    run = Path(run)
    if model == "best_model" and not (run / model_rel).is_file():
        model_rel, stats_rel = _LEGACY_BEST
    src, config = run / model_rel, run / "config.json"
    for path in (src, config):
        if not path.is_file():
            raise ValueError(f"{path} does not exist")
    try:
        run_record = json.loads(config.read_text())
        run_record["config"]["algo"], run_record["config"]["env_id"]
    except (ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"{config} is not a run's config.json: {exc}") from exc
    if out.exists() and not out.is_dir():
        raise ValueError(f"{out} is not a directory")
    record: dict[str, Any] = {
        "name": name,
        "source_run": run.name,
        "source_model": model_rel,
        "note": note,
        "run": run_record,
    }
    for extra in ("metrics.json", "versions.json"):
        path = run / extra
        if path.is_file():
            record[extra.removesuffix(".json")] = json.loads(path.read_text())
    written = [out / f"{name}.zip"]
    _copy(src, written[0])
    stats = run / stats_rel
    if stats.is_file():
        written.append(out / f"{name}_vecnormalize.pkl")
        _copy(stats, written[-1])
    else:
        (out / f"{name}_vecnormalize.pkl").unlink(missing_ok=True)
    written.append(out / f"{name}.json")
    _write(written[-1], json.dumps(record, indent=2))
    exp = zoo_layout(name, out)
    written += sorted(p for p in exp.rglob("*") if p.is_file())
    written.append(write_manifest(out))
    return written
