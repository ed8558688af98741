"""The main job: shipped learned policies against the strongest analytic baselines and the
paper's controller, on quick suites.

1. Reach, on Planar3P-v0: the quick benchmark (reach suites standard, hard, far; 20 episodes
   each) of the shipped reach policy (pretrained:ppo_reach_line: PPO's learned correction to
   the certified slider line, the best shipped reach policy), the strongest reach baseline
   (certified-line: the slider line where the kinematics certify it, else the simple
   motions) and the paper's simultaneous simple-motion controller.  The report gives each
   policy's time to success over the episode's speed bound.
2. Working-mode change, where the simple motions fail by construction (they never pass the
   serial singularity a leg must cross): the shipped ppo_mode_change policy against the simple
   motions and the certified travel-space planner, on the quick mode-change suite.

Each part records one episode of its first two policies (the learned policy and the strongest
baseline of the reach part; the learned policy and the simple motions of the mode change) as
animated GIFs (the same start and target for both) and prints where everything is.  Both
parts are checked (the policies loaded, the suites generated) before either runs.  Trains
nothing; a minute or two on a laptop-class CPU.  Writes <out>/reach/ and <out>/mode-change/
(a rerun replaces them).
"""

from __future__ import annotations

import argparse
import math
import textwrap
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import planar3p_gym
from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser, UsageError

ANALYTIC = "analytic-simultaneous"
#: The strongest of the benchmark's reach baselines
#: (:data:`planar3p_agents.controllers.registry.STRONGEST_REACH_BASELINES`) on the fixed reach
#: suites (their scores: docs/benchmark.md).
REACH_BASELINE = "certified-line"
MODE_CHANGE = "mode-change"
MODE_CHANGE_POLICY = "pretrained:ppo_mode_change"
#: The shipped reach policy the demo plays by default, and the id it was trained on.
REACH_POLICY = "pretrained:ppo_reach_line"
REACH_ENV = planar3p_gym.ENV_ID


def add_arguments(p: CliParser) -> None:
    from planar3p_agents.policies.factory import TRUSTED_FILES_NOTE

    p.note(TRUSTED_FILES_NOTE)
    p.add_argument("--out", default="results/demo", help="output directory")
    p.add_argument("--policy", default=REACH_POLICY, help=f"learned reach policy ({REACH_ENV})")
    p.add_argument(
        "--mode-change-policy",
        default=MODE_CHANGE_POLICY,
        help="learned working-mode change policy (Planar3PModeChange-v0)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the suites and of the policies")


def check(args: argparse.Namespace) -> None:
    checks.at_least("--seed", args.seed, 0)
    checks.output_dir("--out", args.out)


@dataclass
class Part:
    """One part of the demo: its policies (the first two get a GIF), suites, the episode the
    GIFs play, and its output directory."""

    title: str
    suites: list[str]
    policies: list[str]
    env_id: str
    episode: Any
    task_suite: str | None
    out: Path


def parts(out: Path, learned: str, mode_change_policy: str, seed: int) -> list[Part]:
    """The demo's two parts."""
    from planar3p_agents.evaluation import reach_suites as su
    from planar3p_agents.evaluation.task_suites import TASK_SUITES, make_task_suite

    return [
        Part(
            "Reach",
            list(su.SUITE_NAMES),
            [learned, REACH_BASELINE, ANALYTIC],
            REACH_ENV,
            su.make_suite("standard", 1, seed).episodes[0],
            None,
            out / "reach",
        ),
        Part(
            "Working-mode change",
            [MODE_CHANGE],
            [mode_change_policy, ANALYTIC, "planner"],
            TASK_SUITES[MODE_CHANGE].env_id,
            make_task_suite(MODE_CHANGE, 1, seed).episodes[0],
            MODE_CHANGE,
            out / "mode-change",
        ),
    ]


def _check_policies(learned: str, mode_change_policy: str) -> None:
    """Load the learned policies once on their ids (cheap; before any suite is generated)."""
    import gymnasium as gym

    from planar3p_agents.evaluation.task_suites import TASK_SUITES
    from planar3p_agents.policies.factory import PolicyError, load_policy

    for spec, env_id in (
        (learned, REACH_ENV),
        (mode_change_policy, TASK_SUITES[MODE_CHANGE].env_id),
    ):
        env = gym.make(env_id)
        try:
            load_policy(spec, env=env)
        except PolicyError as exc:
            raise UsageError(str(exc)) from exc
        finally:
            env.close()


def _maker(spec: str, suite: str | None, seed: int):
    """``env -> policy`` for a GIF (:func:`load_policy` for the GIF's environment)."""
    from planar3p_agents.policies.factory import load_policy

    return lambda env: load_policy(spec, env=env, seed=seed)


def _cell(value: float, digits: int, scale: float = 1.0) -> str:
    return "-" if not math.isfinite(value) else f"{scale * value:.{digits}f}"


#: What the columns of :func:`brief_table` hold, printed below it.
BRIEF_LEGEND = {
    False: "success: % of n episodes [95 % interval]; time/bound: time to success over the "
    "episode's speed bound, median/90th percentile; crossings: singularity crossings",
    True: "success: % of n episodes [95 % interval]; time s: median time to success; "
    "crossings: singularity crossings",
}


def brief_table(summaries: list[dict[str, Any]], task: bool) -> str:
    """The part's results as a narrow plain-text table (under 80 columns for the demo's
    policy names), with its legend: policy, suite, episodes, success % with its 95 % Wilson
    interval, then the median time over the speed bound with its 90th percentile (reach) or
    the median time to success, s (the mode change), and the singularity crossings. The full
    table is the report's."""
    timing = "time s" if task else "time/bound"
    head = ("policy", "suite", "n", "success", timing, "crossings")
    rows = [head]
    for s in summaries:
        lo, hi = s["success_ci"]
        time_cell = (
            _cell(s["median_time_to_success"], 2)
            if task
            else f"{_cell(s.get('median_time_over_bound', math.nan), 2)}/"
            f"{_cell(s.get('p90_time_over_bound', math.nan), 2)}"
        )
        rows.append(
            (
                s["policy"],
                s["suite"],
                str(s["episodes"]),
                f"{_cell(s['success_rate'], 0, 100)} [{_cell(lo, 0, 100)}, {_cell(hi, 0, 100)}]",
                time_cell,
                str(s["singularity_crossings"]),
            )
        )
    widths = [max(len(r[i]) for r in rows) for i in range(len(head))]
    lines = [
        "  ".join(
            c.ljust(w) if i < 2 else c.rjust(w)
            for i, (c, w) in enumerate(zip(r, widths, strict=True))
        )
        for r in rows
    ]
    lines.insert(1, "  ".join("-" * w for w in widths))
    legend = textwrap.fill(BRIEF_LEGEND[task], 79, initial_indent="  ", subsequent_indent="  ")
    return "\n".join(line.rstrip() for line in lines) + "\n" + legend


def record(part: Part, seed: int) -> dict[str, tuple[Path, dict[str, Any]]]:
    """GIFs of the part's episode played by its first two policies: spec -> (path, outcome)."""
    from planar3p_agents.evaluation.episode_gif import record_gif
    from planar3p_agents.policies.factory import policy_label

    gifs = {}
    for spec in part.policies[:2]:
        path = part.out / f"{policy_label(spec).replace(':', '_').replace('/', '_')}.gif"
        maker = _maker(spec, part.task_suite, seed)
        gifs[spec] = (
            path,
            record_gif(
                part.env_id,
                maker,
                part.episode.reset_options(),
                path,
                seed,
                title=f"{policy_label(spec)} on {part.env_id}",
            ),
        )
    return gifs


def _print(out: Path, gifs: dict[str, tuple[Path, dict[str, Any]]]) -> None:
    print(f"  report:        {out / 'benchmark' / 'report.md'}")
    print(f"  per episode:   {out / 'benchmark' / 'episodes.csv'}")
    print(f"  plots:         {out / 'benchmark'}/*.png")
    for spec, (path, outcome) in gifs.items():
        print(f"  animation:     {path}")
        print(
            f"                 {spec}: {outcome['reason']} after {outcome['steps']} steps, "
            f"final error {outcome['position_error_mm']:.1f} mm"
        )


def run(args: argparse.Namespace) -> int:
    from planar3p_agents.commands import benchmark

    _check_policies(args.policy, args.mode_change_policy)
    plan = parts(Path(args.out), args.policy, args.mode_change_policy, args.seed)
    jobs: list[benchmark.Job] = []
    try:
        for part in plan:  # every part checked before any runs
            jobs.append(
                benchmark.prepare(
                    part.policies,
                    part.suites,
                    episodes=benchmark.QUICK_EPISODES,
                    bootstrap=benchmark.QUICK_BOOTSTRAP,
                    seed=args.seed,
                    out=part.out / "benchmark",
                    force=True,  # the demo's own directory: a rerun replaces its results
                    command=args.command_line,
                    # The loader's notes concern the project's own shipped models on its own
                    # suites (e.g. the environment arguments they were trained with): not the
                    # user's to act on; the report records the settings.
                    warn=lambda text: None,
                )
            )
        done = []
        for part, job in zip(plan, jobs, strict=True):
            print(f"{part.title}: benchmarking {', '.join(part.policies)} ...", flush=True)
            result = benchmark.execute(job)
            print(brief_table(result.summaries, task=part.task_suite is not None))
            if result.status != 0:
                print(f"{part.title}: {result.error}")
                return result.status
            done.append((part, record(part, args.seed)))
    finally:
        for job in jobs:
            job.close()
    print("\nDone.")
    for part, gifs in done:
        extra = (
            " (the simple motions cannot pass the serial singularity)" if part.task_suite else ""
        )
        print(f"{part.title}{extra}:")
        _print(part.out, gifs)
    return 0
