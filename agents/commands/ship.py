"""Ship a trained model from a run directory into agents/zoo/pretrained/ under a name, or check
shipped models against the checksum manifest.

Shipping writes one rl-zoo3 log folder, agents/zoo/pretrained/<name>/: the model
<algo>/<env id>_1/<env id>.zip, in <algo>/<env id>_1/<env id>/ its observation statistics
vecnormalize.pkl (if the run normalised), config.yml and args.yml, and the provenance record
provenance.json (the run's config and command, its metrics, the versions); then it rewrites the
checksum manifest SHA256SUMS.  pretrained:<name> loads it (after checking the manifest), and
`python -m rl_zoo3.enjoy --algo ALGO --env ID -f agents/zoo/pretrained/<name> --exp-id 1
--gym-packages planar3p_gym` plays it.  Ship only models you trust: model and statistics files
are code.

rl-zoo3 loads the files without checking them: --verify NAME (or --verify for all) checks a
model folder against SHA256SUMS and exits 1 naming the first file that is missing, altered or
not listed.

examples:
  planar3p ship runs/ppo-mc-s1 --name ppo_mode_change --model model
  planar3p ship --zoo-only --name ppo_mode_change   # rewrite config/args.yml
  planar3p ship --verify ppo_mode_change            # before rl_zoo3.enjoy
  planar3p ship --verify                            # every shipped model

Library: planar3p_agents.zoo.shipping, planar3p_agents.zoo.manifest.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser, UsageError

#: ``--verify`` without a name, or with this one: every model folder.
ALL = "all"


def add_arguments(p: CliParser) -> None:
    from planar3p_agents.policies.factory import PRETRAINED_DIR
    from planar3p_agents.zoo.shipping import MODELS

    p.add_argument("run", type=Path, nargs="?", help="run directory written by `planar3p train`")
    p.add_argument("--name", help="name of the shipped policy (required to ship)")
    p.add_argument(
        "--model",
        default="best_model",
        help=f"one of {', '.join(sorted(MODELS))}, or checkpoint:STEPS (the run's checkpoint "
        "after STEPS environment steps)",
    )
    p.add_argument(
        "--out",
        "--dir",
        dest="out",
        type=Path,
        default=PRETRAINED_DIR,
        help="the pretrained directory (default: agents/zoo/pretrained of the package)",
    )
    p.add_argument("--note", default="", help="free text recorded in <name>/provenance.json")
    p.add_argument(
        "--zoo-only",
        action="store_true",
        help="only rewrite rl-zoo3's config.yml and args.yml of <name> from its provenance",
    )
    p.add_argument(
        "--verify",
        nargs="?",
        const=ALL,
        metavar="NAME|all|FOLDER",
        help="check a shipped model's folder (or every one) against SHA256SUMS and exit 1 "
        "naming a missing, altered or unlisted file; rl-zoo3's enjoy checks nothing, so run "
        "this before it",
    )


def check(args: argparse.Namespace) -> None:
    if args.verify is not None:
        if args.run is not None or args.name is not None or args.zoo_only:
            raise UsageError("--verify takes no run directory, --name or --zoo-only")
        return
    if args.name is None:
        raise UsageError("--name: give the name of the shipped policy")
    if args.zoo_only and args.run is not None:
        raise UsageError("--zoo-only takes no run directory")
    if not args.zoo_only and args.run is None:
        raise UsageError("give the run directory")
    checks.output_dir("--out", args.out)


def _verify(target: str, directory: Path) -> int:
    """Check ``target`` (a name, :data:`ALL`, or the path of a model folder) against the
    manifest of ``directory``; 0 if every file matches, else 1."""
    from planar3p_agents.policies.spec import PolicyError
    from planar3p_agents.zoo.manifest import manifest_names, verify_zoo_folder

    if target != ALL and ("/" in target or "\\" in target):  # a folder given to rl-zoo3's -f
        folder = Path(target)
        directory, names = folder.resolve().parent, [folder.resolve().name]
    else:
        try:
            names = manifest_names(directory) if target == ALL else [target]
        except (PolicyError, OSError) as exc:
            print(f"FAILED: {exc}", file=sys.stderr)
            return 1
    failed = 0
    for name in names:
        try:
            model = verify_zoo_folder(name, directory)
        except PolicyError as exc:
            failed += 1
            print(f"FAILED pretrained:{name}: {exc}", file=sys.stderr)
            continue
        print(f"ok pretrained:{name}: {len(model.files())} files match {directory / 'SHA256SUMS'}")
    if not names:
        print(f"error: no shipped model in {directory}", file=sys.stderr)
        return 1
    return 1 if failed else 0


def run(args: argparse.Namespace) -> int:
    from planar3p_agents.policies.factory import write_manifest
    from planar3p_agents.zoo.shipping import ship, zoo_layout

    if args.verify is not None:
        return _verify(args.verify, args.out)
    try:
        if args.zoo_only:
            exp = zoo_layout(args.name, args.out)
            write_manifest(args.out)
            print(f"rl-zoo3 files of pretrained:{args.name} rewritten in {exp}")
            return 0
        written = ship(args.run, args.name, args.model, args.out, args.note)
    except (ValueError, OSError) as exc:
        raise UsageError(str(exc)) from exc
    print(f"shipped {args.run} ({args.model}) as pretrained:{args.name} in {args.out}:")
    for path in written:
        print(f"  {path}")
    return 0
