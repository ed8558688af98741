#!/usr/bin/env python
"""Copy a trained model from a run directory into ``agents/pretrained/`` under a name.

Writes ``<name>.zip`` (the model), ``<name>_vecnormalize.pkl`` (its observation statistics, if
the run normalised) and ``<name>.json`` (where it came from: the run's config and command, its
metrics, the versions), which ``pretrained:<name>`` then loads, and records the SHA-256 of every
shipped file in ``SHA256SUMS`` (checked before loading).  Ship only models you trust: model and
statistics files are code.

    python scripts/ship_policy.py runs/ppo-ks-s2 --name ppo_kickstart --model best_model
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PRETRAINED = ROOT / "agents" / "pretrained"
STATS = {
    "model": "vecnormalize.pkl",
    "best_model": "best_vecnormalize.pkl",
    "kickstart_model": "kickstart_vecnormalize.pkl",
}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("run", type=Path, help="run directory written by scripts/train.py")
    p.add_argument("--name", required=True, help="name of the shipped policy")
    p.add_argument("--model", default="best_model", choices=sorted(STATS))
    p.add_argument("--out", type=Path, default=PRETRAINED)
    p.add_argument("--note", default="", help="free text recorded in <name>.json")
    args = p.parse_args(argv)
    if not args.name.replace("_", "").replace("-", "").isalnum():
        print(f"error: invalid name {args.name!r} (letters, digits, - and _)", file=sys.stderr)
        return 2
    model = args.run / f"{args.model}.zip"
    config = args.run / "config.json"
    for path in (model, config):
        if not path.is_file():
            print(f"error: {path} does not exist", file=sys.stderr)
            return 2
    args.out.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(model, args.out / f"{args.name}.zip")
    stats = args.run / STATS[args.model]
    if stats.is_file():
        shutil.copyfile(stats, args.out / f"{args.name}_vecnormalize.pkl")
    record = {
        "name": args.name,
        "source_run": args.run.name,
        "source_model": f"{args.model}.zip",
        "note": args.note,
        "run": json.loads(config.read_text()),
    }
    for extra in ("metrics.json", "versions.json"):
        path = args.run / extra
        if path.is_file():
            record[extra.removesuffix(".json")] = json.loads(path.read_text())
    (args.out / f"{args.name}.json").write_text(json.dumps(record, indent=2))
    sys.path.insert(0, str(ROOT))
    from agents.policies import MANIFEST, write_manifest

    write_manifest(args.out)  # pretrained:<name> loads only files whose SHA-256 is recorded
    print(f"shipped {model} as pretrained:{args.name} in {args.out} (sums in {MANIFEST})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
