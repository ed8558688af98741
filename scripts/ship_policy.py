#!/usr/bin/env python
"""Ship a trained model from a run directory into ``agents/zoo/pretrained/`` under a name, or
check shipped models against the checksum manifest.

Shipping writes one rl-zoo3 log folder, ``agents/zoo/pretrained/<name>/``: the model
``<algo>/<env id>_1/<env id>.zip``, in ``<algo>/<env id>_1/<env id>/`` its observation statistics
``vecnormalize.pkl`` (if the run normalised), ``config.yml`` and ``args.yml``, and the provenance
record ``provenance.json`` (the run's config and command, its metrics, the versions); then it
rewrites the checksum manifest ``SHA256SUMS``.  ``pretrained:<name>`` loads it (after checking
the manifest), and ``python -m rl_zoo3.enjoy --algo ALGO --env ID -f agents/zoo/pretrained/<name>
--exp-id 1 --gym-packages planar3p_gym`` plays it.  Ship only models you trust: model and
statistics files are code.  See :mod:`planar3p_agents.zoo.layout`.

rl-zoo3 loads the files without checking them: ``--verify NAME`` (or ``--verify`` for all)
checks a model folder against ``SHA256SUMS`` and exits 1 naming the first file that is missing,
altered or not listed.

    python scripts/ship_policy.py runs/ppo-mc-s1 --name ppo_mode_change --model model
    python scripts/ship_policy.py --zoo-only --name ppo_mode_change  # rewrite config/args.yml
    python scripts/ship_policy.py --verify ppo_mode_change           # before rl_zoo3.enjoy
    python scripts/ship_policy.py --verify                           # every shipped model
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from planar3p_agents.policies.factory import PRETRAINED_DIR, write_manifest  # noqa: E402
from planar3p_agents.policies.spec import PolicyError  # noqa: E402
from planar3p_agents.zoo.manifest import manifest_names, verify_zoo_folder  # noqa: E402
from planar3p_agents.zoo.shipping import MODELS, ship, zoo_layout  # noqa: E402

#: ``--verify`` without a name, or with this one: every model folder.
ALL = "all"


def _verify(target: str, directory: Path) -> int:
    """Check ``target`` (a name, :data:`ALL`, or the path of a model folder) against the
    manifest of ``directory``; 0 if every file matches, else 1."""
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


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("run", type=Path, nargs="?", help="run directory written by scripts/train.py")
    p.add_argument("--name", help="name of the shipped policy (required to ship)")
    p.add_argument(
        "--model",
        default="best_model",
        help=f"one of {', '.join(sorted(MODELS))}, or checkpoint:STEPS (the run's checkpoint "
        "after STEPS environment steps) (default: %(default)s)",
    )
    p.add_argument(
        "--out",
        "--dir",
        dest="out",
        type=Path,
        default=PRETRAINED_DIR,
        help="the pretrained directory (default: agents/zoo/pretrained)",
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
    args = p.parse_args(argv)
    try:
        if args.verify is not None:
            if args.run is not None or args.name is not None or args.zoo_only:
                raise ValueError("--verify takes no run directory, --name or --zoo-only")
            return _verify(args.verify, args.out)
        if args.name is None:
            raise ValueError("give --name (the name of the shipped policy)")
        if args.zoo_only:
            if args.run is not None:
                raise ValueError("--zoo-only takes no run directory")
            exp = zoo_layout(args.name, args.out)
            write_manifest(args.out)
            print(f"rl-zoo3 files of pretrained:{args.name} rewritten in {exp}")
            return 0
        if args.run is None:
            raise ValueError("give the run directory")
        written = ship(args.run, args.name, args.model, args.out, args.note)
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"shipped {args.run} ({args.model}) as pretrained:{args.name} in {args.out}:")
    for path in written:
        print(f"  {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
