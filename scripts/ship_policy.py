#!/usr/bin/env python
"""Copy a trained model from a run directory into ``agents/zoo/pretrained/`` under a name.

Writes ``<name>.zip`` (the model), ``<name>_vecnormalize.pkl`` (its observation statistics, if
the run normalised) and ``<name>.json`` (where it came from: the run's config and command, its
metrics, the versions), which ``pretrained:<name>`` then loads; also the same model in
rl-zoo3's folder layout (``<algo>/<env id>_<n>/``), so that ``python -m rl_zoo3.enjoy --algo
ALGO --env ID -f agents/zoo/pretrained --gym-packages planar3p_gym`` plays it; and rewrites the
checksum manifest ``SHA256SUMS`` (checked before loading).  Ship only models you trust:
model and statistics files are code.  See :mod:`planar3p_agents.zoo.shipping`.

    python scripts/ship_policy.py runs/ppo-ks-s2 --name ppo_kickstart --model best_model
    python scripts/ship_policy.py --zoo-only --name ppo_kickstart   # (re)write the zoo layout
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from planar3p_agents.policies.factory import PRETRAINED_DIR, write_manifest  # noqa: E402
from planar3p_agents.zoo.shipping import MODELS, ship, zoo_layout  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("run", type=Path, nargs="?", help="run directory written by scripts/train.py")
    p.add_argument("--name", required=True, help="name of the shipped policy")
    p.add_argument(
        "--model",
        default="best_model",
        help=f"one of {', '.join(sorted(MODELS))}, or checkpoint:STEPS (the run's checkpoint "
        "after STEPS environment steps)",
    )
    p.add_argument("--out", type=Path, default=PRETRAINED_DIR)
    p.add_argument("--note", default="", help="free text recorded in <name>.json")
    p.add_argument(
        "--zoo-only", action="store_true", help="only (re)write the rl-zoo3 layout of <name>"
    )
    args = p.parse_args(argv)
    try:
        if args.zoo_only:
            if args.run is not None:
                raise ValueError("--zoo-only takes no run directory")
            exp = zoo_layout(args.name, args.out)
            write_manifest(args.out)
            print(f"rl-zoo3 layout of pretrained:{args.name} in {exp}")
            return 0
        if args.run is None:
            raise ValueError("give the run directory")
        written = ship(args.run, args.name, args.model, args.out, args.note)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"shipped {args.run} ({args.model}) as pretrained:{args.name} in {args.out}:")
    for path in written:
        print(f"  {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
