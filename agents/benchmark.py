"""The policy benchmark as a library: play policies on fixed suites and write the report.

:func:`run_benchmark` plays every policy on every suite (:mod:`agents.suites`) with the episode
runner (:mod:`agents.episodes`), summarises (:mod:`agents.statistics`) and writes into ``out``
``report.md``, ``episodes.csv``, ``summary.json``, ``suites.json`` and the figures
(:mod:`agents.report`, :mod:`agents.report_plots`).  Results are written after each
(policy, suite), so a failing policy or an interrupt keeps what is finished.
``scripts/benchmark.py`` is its command line.

Also here: :func:`check_output_dir` (refuse to overwrite an earlier run's files) and
:func:`training_seed` (the seed a model was trained with, from its run's JSON record).
Loading policies, and refusing statistics files the user did not name, is
:mod:`agents.policies`' job.
"""

from __future__ import annotations

import json
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from planar3p_gym.design import Design

from .episodes import EpisodeResult, evaluate
from .policies import PolicyError, load_policy, parse_policy_spec, policy_label
from .report import write_report, write_rows, write_summary
from .report_plots import plot_errors, plot_success, plot_trajectories
from .statistics import summarize
from .suites import SUITE_NAMES, EpisodeSpec, Suite, load_suites, make_suite, save_suites

__all__ = [
    "OUTPUT_FILES",
    "TRAJECTORIES_PER_SUITE",
    "BenchmarkRun",
    "build_suites",
    "check_output_dir",
    "load_policies",
    "run_benchmark",
    "training_seed",
]

#: Episodes per suite whose trajectories are recorded for the trajectory plot.
TRAJECTORIES_PER_SUITE = 3
#: Files a run writes into its output directory.
OUTPUT_FILES: tuple[str, ...] = (
    "report.md",
    "episodes.csv",
    "summary.json",
    "suites.json",
    "success_rate.png",
    "errors.png",
    "trajectories.png",
)


def check_output_dir(out: str | Path, force: bool = False) -> Path:
    """``out`` as a path, or ``ValueError`` if it is not a directory or (unless ``force``)
    already holds files of a run (:data:`OUTPUT_FILES`).  Creates nothing."""
    p = Path(out)
    if p.exists() and not p.is_dir():
        raise ValueError(f"output path {p} exists and is not a directory")
    if not force and p.is_dir():
        found = [name for name in OUTPUT_FILES if (p / name).exists()]
        if found:
            raise ValueError(
                f"{p} already holds benchmark results ({', '.join(found)}); "
                "choose another --out or pass --force to overwrite them"
            )
    return p


def _json(path: Path) -> Any:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def training_seed(model_path: str | Path | None) -> int | None:
    """The seed a model was trained with, where its JSON record says so, else ``None``.

    Reads (JSON only, never a pickle) ``config.json`` of a ``scripts/train.py`` run (beside the
    model or one level up, for checkpoints: ``{"config": {"seed": ...}}``) or the record of a
    shipped model, ``<name>.json`` beside ``<name>.zip`` (``{"run": {"config": {...}}}``).
    """
    if model_path is None:
        return None
    p = Path(model_path)
    records = [
        (p.with_suffix(".json"), ("run", "config")),
        *((d / "config.json", ("config",)) for d in (p.parent, p.parent.parent)),
    ]
    for path, keys in records:
        data = _json(path) if path.is_file() else None
        for key in keys:
            data = data.get(key) if isinstance(data, dict) else None
        seed = data.get("seed") if isinstance(data, dict) else None
        if isinstance(seed, int) and not isinstance(seed, bool):
            return seed
    return None


def load_policies(
    specs: Sequence[str], env: Any, *, seed: int = 0, device: str = "cpu"
) -> tuple[dict[str, Any], dict[str, tuple[str, int | None]]]:
    """Load each specification (:func:`agents.policies.load_policy`) under its label
    (:func:`agents.policies.policy_label`): returns labels -> policies and labels ->
    (specification, training seed or ``None``).  :class:`~agents.policies.PolicyError` for a
    bad specification or a label given twice."""
    policies: dict[str, Any] = {}
    meta: dict[str, tuple[str, int | None]] = {}
    for text in specs:
        ps = parse_policy_spec(text)
        label = policy_label(text)
        if label in policies:
            raise PolicyError(f"policy {text!r} given twice (as {label!r})")
        policies[label] = load_policy(ps, env=env, seed=seed, device=device)
        meta[label] = (text, training_seed(ps.path))
    return policies, meta


def build_suites(
    names: Sequence[str],
    n_episodes: int,
    seed: int,
    design: Design,
    *,
    suite_file: str | Path | None = None,
    **suite_kwargs: Any,
) -> dict[str, Suite]:
    """The suites ``names``: generated (:func:`agents.suites.make_suite` with
    ``suite_kwargs``) or, with ``suite_file``, read from a saved ``suites.json``, which must be
    for ``design`` and hold them all.  ``ValueError`` with a clear message otherwise."""
    if suite_file is None:
        unknown = [s for s in names if s not in SUITE_NAMES]
        if unknown:
            raise ValueError(
                f"unknown suite(s) {', '.join(map(repr, unknown))}; known: {', '.join(SUITE_NAMES)}"
            )
        try:
            return {n: make_suite(n, n_episodes, seed, design, **suite_kwargs) for n in names}
        except ValueError as exc:
            raise ValueError(f"cannot generate the suites: {exc}") from exc
    loaded, file_design = load_suites(suite_file)
    if file_design != design:
        raise ValueError(f"{suite_file} was made for another design: {file_design}")
    missing = [s for s in names if s not in loaded]
    if missing:
        raise ValueError(
            f"suite(s) {', '.join(missing)} not in {suite_file}; it has {', '.join(loaded)}"
        )
    return {s: loaded[s] for s in names}


@dataclass
class BenchmarkRun:
    """What :func:`run_benchmark` produced: exit status (0 done, 1 a policy failed, 130
    interrupted), the summaries, the per-episode results, the settings, the results table
    and the figures written."""

    status: int
    summaries: list[dict[str, Any]]
    results: dict[tuple[str, str], list[EpisodeResult]]
    settings: dict[str, Any]
    table: str
    plots: list[str] = field(default_factory=list)
    error: str | None = None


def run_benchmark(
    env: Any,
    policies: dict[str, Any],
    suites: dict[str, Suite],
    out: str | Path,
    *,
    settings: dict[str, Any],
    seed: int = 0,
    n_resamples: int = 2000,
    plots: bool = True,
    progress: bool = False,
    training_seeds: dict[str, int | None] | None = None,
    envs: dict[str, Any] | None = None,
) -> BenchmarkRun:
    """Play every policy (label -> object with SB3's ``predict``) on every suite in ``env``
    and write the outputs into ``out`` (created; existing files are overwritten: check with
    :func:`check_output_dir` first).

    ``settings`` (the command and options, recorded in ``summary.json`` and the report) must
    hold ``command``; ``seed``, ``bootstrap``, ``episodes`` (the longest suite), ``design``
    (``"fig8"`` or its parameters), ``env`` (the environment's configuration),
    ``training_seeds`` and ``policy_env_kwargs`` (what each model's run recorded) are filled
    in.  ``envs`` maps an environment id to the environment of the suites with that
    ``env_id`` (default ``env``).
    A policy raising while it runs, or ``KeyboardInterrupt``, stops the run after writing the
    results finished so far (``status`` 1 or 130, ``error`` says why).
    """
    t_start = time.perf_counter()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    design = env.unwrapped.design
    save_suites(out / "suites.json", suites, design)
    settings = {
        **settings,
        "seed": seed,
        "episodes": max(len(s) for s in suites.values()),
        "bootstrap": n_resamples,
        "design": "fig8" if design == Design.fig8() else design.to_dict(),
        "env": env.unwrapped.config(),
        "training_seeds": {k: v for k, v in (training_seeds or {}).items() if v is not None},
        "policy_env_kwargs": {
            k: p.env_kwargs for k, p in policies.items() if getattr(p, "env_kwargs", None)
        },
        "elapsed_s": 0.0,
    }
    results: dict[tuple[str, str], list[EpisodeResult]] = {}
    summaries: list[dict[str, Any]] = []
    total = sum(len(s) for s in suites.values()) * len(policies)
    bar = _progress(total, disable=not progress)
    status, error = 0, None

    def recorded(spec: EpisodeSpec) -> bool:
        return spec.index < TRAJECTORIES_PER_SUITE

    try:
        for label, policy in policies.items():
            for name, suite in suites.items():
                bar.set_description(f"{label} / {name}")
                suite_env = (envs or {}).get(getattr(suite, "env_id", ""), env)
                res = evaluate(
                    suite_env,
                    policy,
                    suite,
                    policy_name=label,
                    seed=seed,
                    record=recorded,
                    callback=lambda _r: bar.update(1),
                )
                results[(label, name)] = res
                summaries.append(summarize(res, n_resamples=n_resamples, seed=seed))
                write_rows(out, results, training_seeds)
                settings["elapsed_s"] = time.perf_counter() - t_start
                write_summary(out, settings, summaries)
    except KeyboardInterrupt:
        status, error = 130, "interrupted"
    except Exception as exc:  # a policy or model failing at run time
        status, error = 1, f"evaluation failed ({type(exc).__name__}: {exc})"
    finally:
        bar.close()
    settings["elapsed_s"] = time.perf_counter() - t_start
    write_summary(out, settings, summaries)
    written: list[str] = []
    if summaries and plots:
        done = [s for s in suites if any(k[1] == s for k in results)]
        written.append(plot_success(out, summaries, done))
        written.append(plot_errors(out, results, done))
        traj = plot_trajectories(out, design, {s: suites[s] for s in done}, results)
        if traj:
            written.append(traj)
    table = write_report(
        out,
        settings["command"],
        settings,
        suites,
        summaries,
        results,
        written,
        complete=status == 0,
    )
    return BenchmarkRun(status, summaries, results, settings, table, written, error)


class _NoBar:
    def update(self, n: int = 1) -> None: ...
    def set_description(self, text: str) -> None: ...
    def close(self) -> None: ...


def _progress(total: int, disable: bool) -> Any:
    if disable:
        return _NoBar()
    try:
        from tqdm.auto import tqdm
    except ImportError:  # tqdm comes with the [train] extra
        return _NoBar()
    return tqdm(total=total, unit="ep", dynamic_ncols=True)
