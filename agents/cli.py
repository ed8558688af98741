"""``planar3p``: the project's one command line (rl-zoo3's ``cli.py`` style).

``planar3p <command> [options]`` runs the command's module of :mod:`planar3p_agents.commands`
(``planar3p <command> --help`` shows its options); ``python -m planar3p_agents`` and the
one-line files of the repository's ``scripts/`` folder are the same entry.  Each command parses
and checks its arguments and output locations before any work (bad input: exit 2 with one
line naming the flag) and leaves the work to the library.
"""

from __future__ import annotations

import importlib
import sys

__all__ = ["COMMANDS", "main"]

#: Command name -> (module of :mod:`planar3p_agents.commands`, one-line description).
COMMANDS: dict[str, tuple[str, str]] = {
    "train": ("train", "train an SB3 agent (PPO, SAC, TD3, TQC; HER on the goal ids)"),
    "benchmark": ("benchmark", "play policies on the fixed suites and write the report"),
    "demo": ("demo", "the main job: shipped policies against the analytic controller"),
    "workspace": ("workspace", "the paper's workspace-versus-stroke study, tables and figures"),
    "sweep": ("sweep", "training sweeps as Ray Tune trials"),
    "ship": ("ship_policy", "ship a trained model into the zoo, or verify the zoo's files"),
    "seed-report": ("seed_report", "success or a metric across training seeds (IQM, CIs)"),
    "plot-learning": ("plot_learning", "learning curves of training runs"),
    "fidelity": ("fidelity", "closure error and DK gap of the physics models"),
    "bench-env": ("bench_env", "environment throughput against Gymnasium's references"),
    "bench-kinematics": ("bench_kinematics", "throughput of the vectorised kinematics"),
    "task-baselines": ("task_baselines", "baselines on the mode- and assembly-change ids"),
    "goal-track-baselines": ("goal_track_baselines", "baselines on the goal and tracking ids"),
    "track-curves": ("track_curves", "learning curves of tracking policies in tracking error"),
    "track-gains": ("track_gains", "the feed-forward tracking controller at other gains"),
    "soak-end-stops": ("soak_end_stops", "random and bang-bang soak of the end stops"),
    "docs-media": ("docs_media", "the frames and GIFs of the environment pages"),
}


def _usage() -> str:
    width = max(len(n) for n in COMMANDS)
    lines = [
        "usage: planar3p <command> [options]   (planar3p <command> --help: its options)",
        "",
        "commands:",
    ]
    lines += [f"  {name:<{width}}  {text}" for name, (_, text) in COMMANDS.items()]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Run ``planar3p`` with ``argv`` (default ``sys.argv[1:]``); returns the exit status."""
    args = list(sys.argv[1:] if argv is None else argv)
    if not args or args[0] in ("-h", "--help"):
        print(_usage())
        return 0 if args else 2
    name, rest = args[0], args[1:]
    if name not in COMMANDS:
        print(
            f"planar3p: error: unknown command {name!r}; one of {', '.join(COMMANDS)}",
            file=sys.stderr,
        )
        return 2
    module = importlib.import_module(f"planar3p_agents.commands.{COMMANDS[name][0]}")
    program = sys.argv[0]
    sys.argv[0] = f"planar3p {name}"  # argparse's prog: usage and errors name the command
    try:
        status = module.main(rest)
    finally:
        sys.argv[0] = program
    return int(status or 0)


if __name__ == "__main__":
    raise SystemExit(main())
