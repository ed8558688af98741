"""The policy benchmark as a library: play policies on fixed suites and write the report.

:func:`run_benchmark` plays every policy on every suite
(:mod:`planar3p_agents.evaluation.reach_suites`) with the episode runner
(:mod:`planar3p_agents.evaluation.episodes`), summarises
(:mod:`planar3p_agents.evaluation.intervals`) and writes into ``out`` ``report.md``,
``episodes.csv``, ``summary.json``, ``suites.json`` and the figures
(:mod:`planar3p_agents.evaluation.report`, :mod:`planar3p_agents.evaluation.report_plots`).  Results
are written after each (policy, suite), so a failing policy or an interrupt keeps what is finished.
``scripts/benchmark.py`` is its command line.

Also here: :func:`check_output_dir` (refuse to overwrite an earlier run's files) and
:func:`training_seed` (the seed a model was trained with, from its run's JSON record).
Loading policies, and refusing statistics files the user did not name, is
:mod:`planar3p_agents.policies.factory`' job.
"""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from planar3p_agents.controllers.layout import env_id_of
from planar3p_agents.controllers.registry import BASELINES, STRONGEST_REACH_BASELINES
from planar3p_agents.evaluation.episodes import EpisodeResult, evaluate
from planar3p_agents.evaluation.intervals import summarize
from planar3p_agents.evaluation.normalized_scores import write_scores
from planar3p_agents.evaluation.reach_suites import (
    SUITE_NAMES,
    EpisodeSpec,
    Suite,
    load_suites,
    make_suite,
    save_suites,
)
from planar3p_agents.evaluation.report import write_report, write_rows, write_summary
from planar3p_agents.evaluation.report_plots import plot_errors, plot_success, plot_trajectories
from planar3p_agents.evaluation.task_suites import TASK_SUITES, make_task_suite
from planar3p_agents.policies.factory import (
    PolicyError,
    load_policy,
    parse_policy_spec,
    policy_label,
    run_env_kwargs,
)
from planar3p_agents.policies.play_envs import PlayEnvs, play_kwargs
from planar3p_agents.zoo.layout import shipped_model_of
from planar3p_gym import atomic_files
from planar3p_gym.machine.design import Design

#: What ``baselines`` stands for on the reach suites.
REACH_BASELINES: tuple[str, ...] = (
    "analytic-simultaneous",
    "analytic-sequential",
    *STRONGEST_REACH_BASELINES,
    "random",
    "zero",
)
#: Every task baseline name.
TASK_BASELINE_NAMES = frozenset(b for d in TASK_SUITES.values() for b in d.baselines)

__all__ = [
    "OUTPUT_FILES",
    "REACH_BASELINES",
    "TRAJECTORIES_PER_SUITE",
    "BenchmarkRun",
    "build_suites",
    "check_output_dir",
    "load_suite_policies",
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
    "scores.csv",
)


def check_output_dir(out: str | Path, force: bool = False) -> Path:
    """``out`` as a path, or ``ValueError`` if no directory can be written there
    (:func:`planar3p_gym.atomic_files.check_output_dir`: a file, under a file, not writable)
    or (unless ``force``) it already holds files of a run (:data:`OUTPUT_FILES`).  Creates
    nothing."""
    p = atomic_files.check_output_dir(out)
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
    shipped model, ``<name>/provenance.json`` (``{"run": {"config": {...}}}``;
    :mod:`planar3p_agents.zoo.layout`), or ``<stem>.json`` beside ``<stem>.zip``.
    """
    if model_path is None:
        return None
    p = Path(model_path)
    shipped = shipped_model_of(p)
    records = [
        (shipped.provenance if shipped else p.with_suffix(".json"), ("run", "config")),
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


def _warn(text: str) -> None:
    print(f"warning: {text}", file=sys.stderr)


def load_suite_policies(
    specs: Sequence[str],
    suites: Sequence[str],
    envs: dict[str, Any],
    *,
    seed: int = 0,
    device: str = "cpu",
    warn: Callable[[str], None] = _warn,
    play_envs: PlayEnvs | None = None,
) -> tuple[dict[str, dict[str, Any]], dict[str, tuple[str, int | None]]]:
    """The policies each suite (a name of
    :data:`~planar3p_agents.evaluation.reach_suites.SUITE_NAMES` or of
    :data:`~planar3p_agents.evaluation.task_suites.TASK_SUITES`) is played with: suite ->
    (label -> policy), and label -> (specification, training seed or ``None``).

    ``baselines`` stands for the suite's baselines (:data:`REACH_BASELINES` on the reach
    suites, the task's own in :data:`planar3p_agents.evaluation.task_suites.TASK_SUITES`).  Every
    specification is loaded with :func:`planar3p_agents.policies.factory.load_policy` for the
    suite's environment ``envs[suite]`` (once for all the reach suites): a built-in baseline
    for the suite's id, skipped (``warn`` says so) on a suite whose id it does not play
    (:data:`planar3p_agents.controllers.registry.BASELINES`); a model against the environment's
    spaces, which it must match.  A model whose run recorded an argument that changes the
    observation (``travel_goal``) is loaded against ``play_envs``' variant of the suite's
    environment (:mod:`planar3p_agents.policies.play_envs`), the one :func:`run_benchmark`
    plays it in.  :class:`~planar3p_agents.policies.factory.PolicyError`
    (a ``ValueError``) for a bad specification, a label given twice, or a suite left without
    any policy.
    """
    variants = play_envs if play_envs is not None else PlayEnvs()
    try:
        return _load_suite_policies(specs, suites, envs, seed, device, warn, variants)
    finally:
        if play_envs is None:  # only the load checks used them
            variants.close()


def _load_suite_policies(
    specs: Sequence[str],
    suites: Sequence[str],
    envs: dict[str, Any],
    seed: int,
    device: str,
    warn: Callable[[str], None],
    variants: PlayEnvs,
) -> tuple[dict[str, dict[str, Any]], dict[str, tuple[str, int | None]]]:
    """:func:`load_suite_policies` with its play environments ``variants``."""
    per_suite: dict[str, dict[str, Any]] = {}
    meta: dict[str, tuple[str, int | None]] = {}
    shared: dict[str, Any] = {}
    for name in suites:
        task = name in TASK_SUITES
        base = TASK_SUITES[name].baselines if task else REACH_BASELINES
        # A name both in the suite's baselines and given on its own is played once.
        texts = list(
            dict.fromkeys(t for spec in specs for t in (base if spec == "baselines" else (spec,)))
        )
        pols: dict[str, Any] = {}
        for text in texts:
            label = policy_label(text)
            if label in pols:
                raise PolicyError(f"policy {text!r} given twice (as {label!r})")
            ps = parse_policy_spec(text)
            if ps.kind == "builtin":
                env_id = env_id_of(envs[name])
                if env_id not in BASELINES[ps.name].ids:
                    warn(
                        f"{text} does not apply to suite {name} ({env_id}; it plays on "
                        f"{', '.join(BASELINES[ps.name].ids)})"
                    )
                    continue
            if task or (ps.kind == "builtin" and BASELINES[ps.name].per_suite):
                env = envs[name]
                if ps.path is not None:  # a model: checked against the env it is played in
                    env = variants.get(env, run_env_kwargs(ps.path))
                pols[label] = load_policy(ps, env=env, seed=seed, device=device, suite=name)
            else:
                if label not in shared:
                    trained = run_env_kwargs(ps.path) if ps.path is not None else None
                    play_env = variants.get(envs[name], trained)
                    shared[label] = load_policy(ps, env=play_env, seed=seed, device=device)
                pols[label] = shared[label]
            trained_with = getattr(pols[label], "env_kwargs", None)
            if trained_with and label not in meta:
                seen = play_kwargs(trained_with, envs[name])
                warn(
                    f"{label} was trained with environment arguments {trained_with}; the "
                    "benchmark runs each suite's own environment"
                    + (f", with the model's interface arguments {seen}" if seen else "")
                )
            meta.setdefault(label, (text, training_seed(ps.path)))
        if not pols:
            raise PolicyError(f"no policy of {list(specs)} applies to suite {name!r}")
        per_suite[name] = pols
    return per_suite, meta


def build_suites(
    names: Sequence[str],
    n_episodes: int,
    seed: int,
    design: Design,
    *,
    suite_file: str | Path | None = None,
    envs: dict[str, Any] | None = None,
    **suite_kwargs: Any,
) -> dict[str, Suite]:
    """The suites ``names``: generated
    (:func:`planar3p_agents.evaluation.reach_suites.make_suite` with ``suite_kwargs``,
    :func:`planar3p_agents.evaluation.task_suites.make_task_suite` in ``envs[name]``) or, with
    ``suite_file``, read from a saved ``suites.json``, which must be for ``design`` (a task suite:
    for its environment's design) and hold them all.  ``ValueError`` with a clear message
    otherwise."""
    known = (*SUITE_NAMES, *TASK_SUITES)
    if suite_file is None:
        unknown = [s for s in names if s not in known]
        if unknown:
            raise ValueError(
                f"unknown suite(s) {', '.join(map(repr, unknown))}; known: {', '.join(known)}"
            )
        try:
            return {
                n: make_task_suite(n, n_episodes, seed, env=(envs or {}).get(n))
                if n in TASK_SUITES
                else make_suite(n, n_episodes, seed, design, **suite_kwargs)
                for n in names
            }
        except ValueError as exc:
            raise ValueError(f"cannot generate the suites: {exc}") from exc
    loaded, file_design = load_suites(suite_file)
    missing = [s for s in names if s not in loaded]
    if missing:
        raise ValueError(
            f"suite(s) {', '.join(missing)} not in {suite_file}; it has {', '.join(loaded)}"
        )
    for n in names:
        params = loaded[n].params
        if params.get("task") is None and file_design != design:
            raise ValueError(f"{suite_file} was made for another design: {file_design}")
        if params.get("task") is not None:
            if n not in TASK_SUITES or params.get("env_id") != TASK_SUITES[n].env_id:
                raise ValueError(f"suite {n!r} of {suite_file} is for {params.get('env_id')}")
            env_design = (envs or {})[n].unwrapped.design.to_dict()
            if params.get("design") != env_design:
                raise ValueError(f"suite {n!r} of {suite_file} was made for another design")
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
    suite_policies: dict[str, dict[str, Any]] | None = None,
    play_envs: PlayEnvs | None = None,
) -> BenchmarkRun:
    """Play every policy (label -> object with SB3's ``predict``) on every suite in ``env``
    and write the outputs into ``out`` (created; existing files are overwritten: check with
    :func:`check_output_dir` first).

    ``settings`` (the command and options, recorded in ``summary.json`` and the report) must
    hold ``command``; ``seed``, ``bootstrap``, ``episodes`` (the longest suite), ``design``
    (``"fig8"`` or its parameters), ``env`` (the environment's configuration),
    ``training_seeds`` and ``policy_env_kwargs`` (what each model's run recorded) are filled
    in.  ``envs`` maps a suite name to the environment it is played in (default ``env``);
    ``suite_policies`` maps a suite name to the policies played on it instead of ``policies``
    (task suites have their own baselines and environments).  A model trained with an
    argument that changes the observation is played in ``play_envs``' variant of the suite's
    environment (:mod:`planar3p_agents.policies.play_envs`).  Policies run label by label, in
    order of first appearance, each on its suites in order.
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
        "elapsed_s": 0.0,
    }
    per_suite = {n: (suite_policies or {}).get(n, policies) for n in suites}
    labels = list(dict.fromkeys(k for pols in per_suite.values() for k in pols))
    plan = [(k, n, per_suite[n][k]) for k in labels for n in suites if k in per_suite[n]]
    settings["policy_env_kwargs"] = {
        k: p.env_kwargs for k, _, p in plan if getattr(p, "env_kwargs", None)
    }
    results: dict[tuple[str, str], list[EpisodeResult]] = {}
    summaries: list[dict[str, Any]] = []
    total = sum(len(suites[n]) for _, n, _ in plan)
    bar = _progress(total, disable=not progress)
    status, error = 0, None
    variants = play_envs if play_envs is not None else PlayEnvs()

    def recorded(spec: EpisodeSpec) -> bool:
        return spec.index < TRAJECTORIES_PER_SUITE

    try:
        for label, name, policy in plan:
            bar.set_description(f"{label} / {name}")
            suite_env = (envs or {}).get(name, env)
            res = evaluate(
                variants.get(suite_env, getattr(policy, "env_kwargs", None)),
                policy,
                suites[name],
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
        if play_envs is None:  # made here: closed here
            variants.close()
    settings["elapsed_s"] = time.perf_counter() - t_start
    write_summary(out, settings, summaries)
    written: list[str] = []
    if summaries and plots:
        done = [s for s in suites if any(k[1] == s for k in results)]
        written.append(plot_success(out, summaries, done))
        written.append(plot_errors(out, results, done))
        mapped = [s for s in done if suites[s].params.get("task") in (None, "goal")]
        if mapped:  # trajectories are drawn on the reach workspace maps only
            traj = plot_trajectories(out, design, {s: suites[s] for s in mapped}, results)
            if traj:
                written.append(traj)
    scores = _scores_section(out, results, training_seeds, n_resamples, seed, plots)
    table = write_report(
        out,
        settings["command"],
        settings,
        suites,
        summaries,
        results,
        written,
        complete=status == 0,
        extra=scores,
    )
    return BenchmarkRun(status, summaries, results, settings, table, written, error)


def _scores_section(
    out: Path,
    results: dict[tuple[str, str], list[EpisodeResult]],
    training_seeds: dict[str, int | None] | None,
    n_resamples: int,
    seed: int,
    plots: bool,
) -> str:
    """The normalized scores of the suites that have reference values
    (:func:`planar3p_agents.evaluation.normalized_scores.write_scores`: ``scores.csv`` and
    rliable's figures); empty if none has (or there is no random policy to compare with)."""
    seeds = training_seeds or {}
    rows = []
    for res in results.values():
        for r in res:
            seed_of = seeds.get(r.policy)
            rows.append({**r.row(), "training_seed": "" if seed_of is None else seed_of})
    try:
        return write_scores(out, rows, n_resamples=n_resamples, seed=seed, plots=plots)
    except ValueError as exc:
        _warn(f"no normalized scores: {exc}")
        return ""


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
