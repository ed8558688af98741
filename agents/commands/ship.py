"""Copy a trained model from a run directory into agents/zoo/pretrained/ under a name.

Writes <name>.zip (the model), <name>_vecnormalize.pkl (its observation statistics, if the
run normalised) and <name>.json (where it came from: the run's config and command, its
metrics, the versions), which pretrained:<name> then loads; also the same model in rl-zoo3's
folder layout (<algo>/<env id>_<n>/), so that `python -m rl_zoo3.enjoy --algo ALGO --env ID
-f agents/zoo/pretrained --gym-packages planar3p_gym` plays it; and rewrites the checksum
manifest SHA256SUMS (checked before loading).  Ship only models you trust: model and
statistics files are code.

examples:
  planar3p ship runs/ppo-ks-s2 --name ppo_kickstart --model best_model
  planar3p ship --zoo-only --name ppo_kickstart   # (re)write the zoo layout

Library: planar3p_agents.zoo.shipping.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser, UsageError


def add_arguments(p: CliParser) -> None:
    from planar3p_agents.policies.factory import PRETRAINED_DIR
    from planar3p_agents.zoo.shipping import MODELS

    p.add_argument("run", type=Path, nargs="?", help="run directory written by `planar3p train`")
    p.add_argument("--name", required=True, help="name of the shipped policy")
    p.add_argument(
        "--model",
        default="best_model",
        help=f"one of {', '.join(sorted(MODELS))}, or checkpoint:STEPS (the run's checkpoint "
        "after STEPS environment steps)",
    )
    p.add_argument(
        "--out",
        type=Path,
        default=PRETRAINED_DIR,
        help="the pretrained directory (default: agents/zoo/pretrained of the package)",
    )
    p.add_argument("--note", default="", help="free text recorded in <name>.json")
    p.add_argument(
        "--zoo-only", action="store_true", help="only (re)write the rl-zoo3 layout of <name>"
    )


def check(args: argparse.Namespace) -> None:
    if args.zoo_only and args.run is not None:
        raise UsageError("--zoo-only takes no run directory")
    if not args.zoo_only and args.run is None:
        raise UsageError("give the run directory")
    checks.output_dir("--out", args.out)


def run(args: argparse.Namespace) -> int:
    from planar3p_agents.policies.factory import write_manifest
    from planar3p_agents.zoo.shipping import ship, zoo_layout

    try:
        if args.zoo_only:
            exp = zoo_layout(args.name, args.out)
            write_manifest(args.out)
            print(f"rl-zoo3 layout of pretrained:{args.name} in {exp}")
            return 0
        written = ship(args.run, args.name, args.model, args.out, args.note)
    except ValueError as exc:
        raise UsageError(str(exc)) from exc
    print(f"shipped {args.run} ({args.model}) as pretrained:{args.name} in {args.out}:")
    for path in written:
        print(f"  {path}")
    return 0
