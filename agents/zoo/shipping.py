"""Ship a trained model from a run directory into ``agents/zoo/pretrained/`` as
``pretrained:<name>``.

The model is stored once, in the layout of :mod:`planar3p_agents.zoo.layout`: one rl-zoo3 log
folder per shipped model, ``<name>/<algo>/<env id>_1/`` (the model ``<env id>.zip``, and in
``<env id>/`` its statistics ``vecnormalize.pkl``, the hyperparameters ``config.yml`` and the
arguments ``args.yml``), with the provenance record ``<name>/provenance.json`` (the run's config
and command, its metrics, the versions).  ``pretrained:<name>`` loads it after checking the
manifest; ``python -m rl_zoo3.enjoy --algo ALGO --env ID -f agents/zoo/pretrained/<name>
--exp-id 1 --gym-packages planar3p_gym`` plays the same files (after ``scripts/ship_policy.py
--verify <name>``: rl-zoo3 checks nothing).

Shipped files carry no absolute path and no host name (:mod:`planar3p_agents.zoo.portable`):
the run directory is written ``runs/<run>`` in the record and in the model's ``data``
(``tensorboard_log``; the weights are copied byte for byte), and shipping refuses a run whose
files would still carry one.  A re-shipped name replaces its folder as a whole.  Afterwards the
checksum manifest (:func:`planar3p_agents.zoo.manifest.write_manifest`) is rewritten.

rl-zoo3's own packaging (``rl_zoo3.push_to_hub``) uploads to the Hugging Face hub and needs its
training layout, so it does not do this job; the layout written here is what its ``enjoy`` /
``record_video`` read.
"""

from __future__ import annotations

import json
import shutil
import tempfile
from pathlib import Path
from typing import Any

from planar3p_agents.policies.spec import PRETRAINED_DIR
from planar3p_agents.training.checkpoints import checkpoint_path
from planar3p_agents.zoo.layout import ShippedModel, check_name, read_provenance, shipped_model
from planar3p_agents.zoo.manifest import write_manifest
from planar3p_agents.zoo.portable import machine_traces, portable_model, portable_record
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
#: The repository (paths inside it are recorded relative to it).
_REPO = Path(__file__).resolve().parents[2]


def _write(dst: Path, text: str) -> None:
    dst.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(dst, text)


def _zoo_files(model: ShippedModel, record: dict[str, Any]) -> None:
    """Write rl-zoo3's ``config.yml`` and ``args.yml`` of ``model`` from its provenance."""
    import yaml

    run = record["run"]
    config = run["config"]
    entry: dict[str, Any] = dict(run.get("entry") or {})
    entry["normalize"] = model.stats.is_file()  # the zoo loads <env id>/vecnormalize.pkl if true
    entry.update(n_envs=config.get("n_envs"), n_timesteps=config.get("n_timesteps"))
    entry.pop("env_kwargs", None)
    _write(model.zoo_config, yaml.safe_dump(entry, sort_keys=True))
    args = {
        "algo": model.algo,
        "env": model.env_id,
        "env_kwargs": config.get("env_kwargs") or None,
        "seed": config.get("seed"),
        "n_timesteps": config.get("n_timesteps"),
        "shipped_name": model.name,
        "command": run.get("command", ""),
    }
    if run.get("resumes"):  # (training continued from checkpoints: each resume's command)
        args["resumes"] = [r.get("command", "") for r in run["resumes"]]
    _write(model.zoo_args, yaml.safe_dump(args, sort_keys=True))


def zoo_layout(name: str, directory: Path | None = None) -> Path:
    """Rewrite rl-zoo3's ``config.yml`` and ``args.yml`` of the shipped ``pretrained:<name>`` in
    ``directory`` from its provenance record (e.g. after the record was edited); returns the
    experiment folder.  ``ValueError`` if the model or its record is missing.  The manifest is
    not rewritten here."""
    model = shipped_model(name, directory or PRETRAINED_DIR)
    if not model.model.is_file():
        raise ValueError(f"{model.model} does not exist")
    _zoo_files(model, read_provenance(model.provenance))
    return model.experiment


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


def _read_run(run: Path, model: str) -> tuple[Path, Path, dict[str, Any], str]:
    """The model file, its statistics (maybe absent), the run record and the model's relative
    path; ``ValueError`` if the run is not usable."""
    model_rel, stats_rel = model_files(model)
    if model == "best_model" and not (run / model_rel).is_file():
        model_rel, stats_rel = _LEGACY_BEST
    src, config = run / model_rel, run / "config.json"
    for path in (src, config):
        if not path.is_file():
            raise ValueError(f"{path} does not exist")
    try:
        run_record = json.loads(config.read_text())
        ShippedModel(
            PRETRAINED_DIR, "x", run_record["config"]["algo"], run_record["config"]["env_id"]
        )
    except (ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"{config} is not a run's config.json: {exc}") from exc
    return src, run / stats_rel, run_record, model_rel


def ship(
    run: Path,
    name: str,
    model: str = "best_model",
    out: Path | None = None,
    note: str = "",
) -> list[Path]:
    """Copy ``model`` of the run directory ``run`` into ``out`` (default
    ``agents/zoo/pretrained``) as ``pretrained:<name>`` (layout:
    :mod:`planar3p_agents.zoo.layout`) and rewrite the manifest; returns the files written
    (the manifest last).  ``ValueError`` (nothing written) if the name or the run is not usable,
    or if a file to ship would carry an absolute path or the host name."""
    check_name(name)
    run = Path(run)
    out = Path(out) if out is not None else PRETRAINED_DIR
    src, stats, run_record, model_rel = _read_run(run, model)
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
    record = portable_record(record, run, _REPO)
    config = record["run"]["config"]
    out.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".ship-{name}-", dir=out))
    try:
        staged = ShippedModel(staging, name, config["algo"], config["env_id"])
        portable_model(src, staged.model, run, _REPO)
        if stats.is_file():
            staged.stats.parent.mkdir(parents=True, exist_ok=True)
            copy_atomic(stats, staged.stats)
        _write(staged.provenance, json.dumps(record, indent=2) + "\n")
        _zoo_files(staged, record)
        traces = machine_traces(staged.files())
        if traces:
            raise ValueError(
                "a shipped file would carry a trace of this machine (absolute path or host "
                "name); fix the run's files and ship again:\n  " + "\n  ".join(traces)
            )
        final = ShippedModel(out, name, staged.algo, staged.env_id)
        if final.folder.exists():  # a re-shipped name: its folder is replaced as a whole
            final.folder.rename(staging / ".replaced")
        staged.folder.rename(final.folder)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return [*final.files(), write_manifest(out)]
