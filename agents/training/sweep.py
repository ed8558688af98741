"""Training sweeps as Ray Tune trials: seeds x configurations, or an Optuna search space.

Every trial is one training run through the same two functions as ``scripts/train.py``
(:func:`planar3p_agents.training.run.plan_run`, :func:`planar3p_agents.training.run.execute`), with
one torch thread and one CPU.  Ray does the scheduling (a local Ray by default, or a running cluster
given its address) and Ray Tune the bookkeeping; Optuna's sampler (Ray Tune's ``OptunaSearch``)
proposes configurations in search mode.

A sweep writes one directory::

    <out>/sweep.json     what was asked (configurations, seeds, search space, command)
    <out>/runs/<trial>/  each trial's run directory (model.zip, vecnormalize.pkl, metrics, ...)
    <out>/ray/           Ray Tune's own records of the trials
    <out>/results.csv    one row per trial (columns: :data:`COLUMNS`)
    <out>/results.md     the same table, and success rates per configuration across seeds

The ``training_seed`` column is the seed the policy was trained with, and ``policy`` names the
trained model with its statistics in :func:`planar3p_agents.policies.factory.load_policy`'s syntax,
so that the benchmark can evaluate every row and aggregate across training seeds.

Configurations (``grid``) map a name to ``{"params": {...}, "env_kwargs": {...},
"n_envs": int}`` (all optional); a search space maps hyperparameters to
``{"loguniform": [low, high]}``, ``{"uniform": [low, high]}``, ``{"int": [low, high]}`` (both
ends included) or ``{"choice": [values...]}``.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from planar3p_agents.training.run import RunOptions, execute, plan_run
from planar3p_gym.atomic_files import write_atomic

__all__ = [
    "COLUMNS",
    "SweepSpec",
    "load_spec_file",
    "results_markdown",
    "run_sweep",
    "search_space",
    "validate",
]

#: Columns of ``results.csv`` (one row per trial).
COLUMNS = (
    "trial",
    "config",
    "algo",
    "env_id",
    "training_seed",
    "timesteps",
    "final_success_rate",
    "final_mean_return",
    "median_position_error_mm",
    "median_orientation_error_deg",
    "wall_time_s",
    "steps_per_s",
    "params",
    "run_dir",
    "policy",
    "status",
)

_DISTRIBUTIONS = ("loguniform", "uniform", "int", "choice")


@dataclass
class SweepSpec:
    """What to run: algorithm, environment, seeds, configurations or a search space.

    ``timesteps`` is the total environment steps of each trial; ``options`` the run options
    shared by every trial (evaluation, checkpoints; ``threads`` must be 1).  In search
    mode (``search`` given) ``num_samples`` configurations are drawn (on top of the
    ``default`` configuration of ``grid``), each trained with the single seed in ``seeds``,
    and ``metric`` (``final_success_rate`` or ``final_mean_return``) is maximised.
    """

    algo: str
    seeds: list[int]
    env_id: str = "Planar3P-v0"
    timesteps: int | None = None
    grid: dict[str, dict[str, Any]] = field(default_factory=lambda: {"default": {}})
    search: dict[str, dict[str, Any]] | None = None
    num_samples: int = 8
    metric: str = "final_success_rate"
    search_seed: int = 0
    hyperparams: str | None = None
    options: RunOptions = field(default_factory=RunOptions)


def load_spec_file(path: str | Path) -> dict[str, Any]:
    """A YAML (or JSON) mapping from a file: a grid of configurations or a search space."""
    import yaml

    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise ValueError(f"cannot read {path}: {exc}") from exc
    if not isinstance(data, Mapping) or not data:
        raise ValueError(f"{path} must hold a non-empty mapping")
    return dict(data)


def _trial_name(config: str, seed: int) -> str:
    return f"{config}-s{seed}"


def validate(spec: SweepSpec, out: Path) -> None:
    """Check the whole sweep before anything starts (``ValueError``): every configuration
    and seed is planned like a ``scripts/train.py`` run; the output directory must be new."""
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise ValueError(f"output directory {out} exists and is not empty")
    if not spec.seeds or len(set(spec.seeds)) != len(spec.seeds):
        raise ValueError(f"seeds must be distinct and at least one, got {spec.seeds}")
    if spec.options.threads != 1:
        raise ValueError("sweep trials use one torch thread each")
    if spec.metric not in ("final_success_rate", "final_mean_return"):
        raise ValueError(f"metric must be final_success_rate or final_mean_return: {spec.metric}")
    if spec.search is not None:
        if len(spec.seeds) != 1:
            raise ValueError("a search trains each sampled configuration with one seed")
        if isinstance(spec.num_samples, bool) or not 1 <= int(spec.num_samples) <= 10_000:
            raise ValueError(f"num_samples must be from 1 to 10000, got {spec.num_samples}")
        search_space(spec.search)
        plans = [("default", spec.seeds[0], _sample_midpoints(spec.search))]
    else:
        if not spec.grid:
            raise ValueError("no configuration to run")
        plans = []
        for name, conf in spec.grid.items():
            if not str(name).replace("_", "").replace("-", "").replace(".", "").isalnum():
                raise ValueError(f"configuration name {name!r}: letters, digits, - _ . only")
            if not isinstance(conf, Mapping) or set(conf) - {"params", "env_kwargs", "n_envs"}:
                raise ValueError(
                    f"configuration {name!r} may hold params, env_kwargs and n_envs only"
                )
            plans.append((name, spec.seeds[0], {}))  # the seed does not change the plan
    from planar3p_agents.training.config import MAX_SEED

    for seed in spec.seeds:
        if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= MAX_SEED:
            raise ValueError(f"seed must be an integer from 0 to {MAX_SEED}, got {seed!r}")
    for name, seed, sampled in plans:
        conf = spec.grid.get(name, {})
        try:
            _plan(spec, conf, seed, out / "runs" / _trial_name(name, seed), sampled)
        except ValueError as exc:
            raise ValueError(f"configuration {name!r}, seed {seed}: {exc}") from exc


def _sample_midpoints(space: Mapping[str, Any]) -> dict[str, Any]:
    """One representative value per searched hyperparameter (to validate the search)."""
    out = {}
    for key, dist in space.items():
        kind, arg = next(iter(dist.items()))
        if kind == "choice":
            out[key] = arg[0]
        elif kind == "loguniform":
            out[key] = math.sqrt(arg[0] * arg[1])
        elif kind == "int":
            out[key] = int(arg[0])
        else:
            out[key] = 0.5 * (arg[0] + arg[1])
    return out


def search_space(space: Mapping[str, Any]) -> dict[str, Any]:
    """The search space as Ray Tune domains (``ValueError`` on a malformed entry)."""
    from ray import tune

    out = {}
    for key, dist in space.items():
        if not isinstance(dist, Mapping) or len(dist) != 1:
            raise ValueError(f"search {key!r}: give one of {', '.join(_DISTRIBUTIONS)}")
        kind, arg = next(iter(dist.items()))
        if kind not in _DISTRIBUTIONS or not isinstance(arg, list) or not arg:
            raise ValueError(f"search {key!r}: give one of {', '.join(_DISTRIBUTIONS)} + a list")
        if kind == "choice":
            out[key] = tune.choice(arg)
            continue
        if len(arg) != 2 or not all(isinstance(v, (int, float)) for v in arg):
            raise ValueError(f"search {key!r}: {kind} needs [low, high]")
        low, high = arg
        if not (np.isfinite(low) and np.isfinite(high) and low < high):
            raise ValueError(f"search {key!r}: need finite low < high, got {arg}")
        if kind == "loguniform":
            if low <= 0:
                raise ValueError(f"search {key!r}: loguniform needs low > 0")
            out[key] = tune.loguniform(low, high)
        elif kind == "uniform":
            out[key] = tune.uniform(low, high)
        else:
            out[key] = tune.randint(int(low), int(high) + 1)
    return out


def _plan(
    spec: SweepSpec, conf: Mapping[str, Any], seed: int, run_dir: Path, sampled: dict[str, Any]
) -> Any:
    params = {**dict(conf.get("params") or {}), **sampled}
    return plan_run(
        spec.algo,
        spec.env_id,
        seed,
        run_dir=run_dir,
        timesteps=spec.timesteps,
        n_envs=conf.get("n_envs"),
        env_kwargs=dict(conf.get("env_kwargs") or {}),
        hyperparams=spec.hyperparams,
        params=params,
        options=spec.options,
        command=f"sweep trial {run_dir.name}",
    )


def _trainable(config: dict[str, Any]) -> None:
    """One Ray Tune trial: plan and execute one run, report its final evaluation."""
    import torch
    from ray import tune

    torch.set_num_threads(1)
    spec = SweepSpec(**{**config["spec"], "options": RunOptions(**config["spec"]["options"])})
    sampled = dict(config.get("hp") or {})
    name = config["config"]
    if sampled:
        name = f"search{tune.get_context().get_trial_id().split('_')[-1]}"
    seed = int(config["seed"])
    run_dir = Path(config["out"]) / "runs" / _trial_name(name, seed)
    conf = spec.grid.get(config["config"], {})
    plan = _plan(spec, conf, seed, run_dir, sampled)
    plan.extra = {"sweep": {"config": name, "sampled": sampled}}
    metrics = execute(plan)
    final = metrics["final_evaluation"]
    vecnorm = run_dir / "vecnormalize.pkl"
    stats = f":stats={vecnorm}" if vecnorm.is_file() else ":stats=none"
    tune.report(
        {
            "trial": run_dir.name,
            "configuration": name,  # Ray Tune keeps "config" for the trial's settings
            "algo": plan.cfg.algo,
            "env_id": plan.cfg.env_id,
            "training_seed": seed,
            "timesteps": metrics["timesteps"],
            "final_success_rate": final["success_rate"],
            "final_mean_return": final["mean_return"],
            "median_position_error_mm": final["median_position_error_mm"],
            "median_orientation_error_deg": final["median_orientation_error_deg"],
            "wall_time_s": metrics["wall_time_s"],
            "steps_per_s": metrics["steps_per_s"],
            "params": json.dumps({**dict(conf.get("params") or {}), **sampled}, sort_keys=True),
            "run_dir": str(run_dir),
            "policy": f"{plan.cfg.algo}:{run_dir / 'model.zip'}{stats}",
            "status": "ok",
        }
    )


def run_sweep(
    spec: SweepSpec,
    out: str | Path,
    *,
    address: str | None = None,
    num_cpus: int | None = None,
    command: str = "",
) -> list[dict[str, Any]]:
    """Run the sweep on Ray (local unless ``address``), write ``results.csv`` /
    ``results.md`` in ``out`` and return the rows (sorted by configuration and seed)."""
    import ray
    from ray import tune

    out = Path(out).resolve()
    validate(spec, out)
    spec_dict = {**asdict(spec), "options": asdict(spec.options)}
    base = {"spec": spec_dict, "out": str(out)}
    if spec.search is None:
        param_space = {
            **base,
            "config": tune.grid_search(list(spec.grid)),
            "seed": tune.grid_search(list(spec.seeds)),
        }
        tune_config = tune.TuneConfig()
    else:
        from ray.tune.search.optuna import OptunaSearch

        space = search_space(spec.search)
        param_space = {**base, "config": "default", "seed": spec.seeds[0], "hp": space}
        tune_config = tune.TuneConfig(
            search_alg=OptunaSearch(metric=spec.metric, mode="max", seed=spec.search_seed),
            num_samples=int(spec.num_samples),
        )
    started = False
    if not ray.is_initialized():
        root = str(Path(__file__).resolve().parents[2])
        env = {"PYTHONPATH": os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH")) if p)}
        kwargs: dict[str, Any] = {"runtime_env": {"env_vars": env}, "log_to_driver": False}
        if address is None:
            kwargs.update(num_cpus=num_cpus, include_dashboard=False)
        try:
            ray.init(address=address, **kwargs)
        except (ConnectionError, RuntimeError) as exc:
            raise ValueError(f"cannot start or join Ray (address {address!r}): {exc}") from exc
        started = True
    try:
        out.mkdir(parents=True, exist_ok=True)
        record = {**asdict(spec), "command": command}
        (out / "sweep.json").write_text(json.dumps(record, indent=2, default=str))
        tuner = tune.Tuner(
            tune.with_resources(_trainable, {"cpu": 1}),
            param_space=param_space,
            tune_config=tune_config,
            run_config=tune.RunConfig(storage_path=str(out / "ray"), name="sweep", verbose=0),
        )
        grid = tuner.fit()
    finally:
        if started:
            ray.shutdown()
    rows = []
    for result in grid:
        metrics = dict(result.metrics or {})
        metrics["config"] = metrics.get("configuration", "")
        row = {c: metrics.get(c, "") for c in COLUMNS}
        if result.error is not None:
            cfg = result.config or {}
            row.update(
                config=cfg.get("config", ""),
                training_seed=cfg.get("seed", ""),
                algo=spec.algo,
                env_id=spec.env_id,
                status=f"error: {str(result.error).splitlines()[0][:200]}",
            )
        rows.append(row)
    rows.sort(key=lambda r: (str(r["config"]), str(r["training_seed"])))
    write_atomic(out / "results.csv", _csv(rows))
    write_atomic(out / "results.md", results_markdown(rows, spec))
    return rows


def _csv(rows: Sequence[Mapping[str, Any]]) -> str:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(COLUMNS), lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return buf.getvalue()


def _fmt(value: Any, digits: int = 2) -> str:
    return f"{value:.{digits}f}" if isinstance(value, float) else str(value)


def results_markdown(rows: Sequence[Mapping[str, Any]], spec: SweepSpec) -> str:
    """The trials as a markdown table, then success rate per configuration across seeds."""
    lines = [
        f"# Sweep: {spec.algo.upper()} on {spec.env_id}",
        "",
        "| trial | config | training seed | env steps | final success | final return "
        "| wall time (s) | params | status |",
        "|---|---|---:|---:|---:|---:|---:|---|---|",
    ]
    for r in rows:
        params = f"`{r['params']}`" if r["params"] else ""  # an empty `` shows as two backticks
        lines.append(
            f"| {r['trial']} | {r['config']} | {r['training_seed']} | {r['timesteps']} "
            f"| {_fmt(r['final_success_rate'])} | {_fmt(r['final_mean_return'], 1)} "
            f"| {_fmt(r['wall_time_s'], 0)} | {params} | {r['status']} |"
        )
    lines += [
        "",
        "Final success rate per configuration (each run's own deterministic evaluation, "
        f"{spec.options.final_eval_episodes} episodes):",
        "",
        "| config | seeds | mean | min | max |",
        "|---|---:|---:|---:|---:|",
    ]
    for name in sorted({str(r["config"]) for r in rows}):
        rates = [
            float(r["final_success_rate"])
            for r in rows
            if str(r["config"]) == name and r["status"] == "ok"
        ]
        if rates:
            lines.append(
                f"| {name} | {len(rates)} | {np.mean(rates):.2f} | {min(rates):.2f} "
                f"| {max(rates):.2f} |"
            )
    return "\n".join(lines) + "\n"
