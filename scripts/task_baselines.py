"""Baselines on Planar3PModeChange-v0 / Planar3PAssemblyChange-v0 and the crossing-fidelity
study.  Logic: agents/studies/task_baselines.py.

    python scripts/task_baselines.py --episodes 50 --seed 0
    python scripts/task_baselines.py --fidelity --episodes 20
    python scripts/task_baselines.py --verify-rates --episodes 25
    python scripts/task_baselines.py --ids Planar3PAssemblyChange-v0 --gravity 9.81
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def _print(label: str, figures: dict[str, float]) -> None:
    print(label)
    for k, v in figures.items():
        print(f"  {k}: {v:.6g}")


def main(argv: list[str] | None = None) -> int:
    from planar3p_agents.studies.task_baselines import (
        STUDY_POLICIES,
        TABLE_HEADER,
        run_baselines,
        run_fidelity,
        run_reach_fidelity,
        verification_rate,
    )

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--episodes", type=int, default=50, help="episodes per id and policy")
    p.add_argument("--seed", type=int, default=0, help="first episode seed")
    p.add_argument("--ids", default=",".join(STUDY_POLICIES), help="comma-separated env ids")
    p.add_argument("--fidelity", action="store_true", help="run the crossing-fidelity study")
    p.add_argument(
        "--verify-rates",
        action="store_true",
        help="how often the assembly-change demonstration reaches the target, per physics",
    )
    p.add_argument(
        "--gravity",
        type=float,
        default=None,
        help="gravity (m/s^2) of the assembly-change design (default: the id's, 0)",
    )
    args = p.parse_args(argv)
    if args.episodes < 1:
        print("error: --episodes must be >= 1", file=sys.stderr)
        return 2
    if args.verify_rates:
        print(
            "| gravity m/s^2 | physics | max force N | peak slider rate m/s | pairs | "
            "within 1 cm | within 5 cm |"
        )
        print("|---|---|---|---|---|---|---|")
        for gravity, projection, force, speed in (
            (0.0, True, 40.0, 1.0),
            (0.0, False, 40.0, 1.0),
            (9.81, True, 40.0, 1.0),
            (9.81, False, 40.0, 1.0),
            (9.81, False, 40.0, 0.25),
            (9.81, False, 100.0, 0.25),
        ):
            r = verification_rate(
                args.episodes,
                args.seed,
                gravity=gravity,
                projection=projection,
                speed_fraction=speed,
                max_force=force,
            )
            print(
                f"| {gravity} | {'projected' if projection else 'plain (8 x 18)'} | {force:.0f} "
                f"| {0.2 * speed:.2f} | {args.episodes} | {100 * r['within_1cm']:.0f} % "
                f"| {100 * r['within_5cm']:.0f} % |",
                flush=True,
            )
        return 0
    if args.fidelity:
        settings = [(True, None), (False, None), (True, 9.81), (False, 9.81)]
        for projection, gravity in settings:
            f = run_fidelity(args.episodes, args.seed, projection, gravity)
            g = gravity if gravity is not None else 0.0
            _print(f"assembly change, crossing controller: projection={projection} gravity={g}", f)
        for projection in (True, False):
            for g in (0.0, 9.81):
                f = run_reach_fidelity(args.episodes, args.seed, projection, g)
                _print(f"reach (no crossing), analytic: projection={projection} gravity={g}", f)
        return 0
    ids = [s for s in args.ids.split(",") if s]
    unknown = [i for i in ids if i not in STUDY_POLICIES]
    if unknown:
        print(f"error: unknown ids {unknown}; known: {list(STUDY_POLICIES)}", file=sys.stderr)
        return 2
    if args.gravity is not None and not (args.gravity >= 0 and args.gravity < 1e3):
        print("error: --gravity must be in [0, 1000) m/s^2", file=sys.stderr)
        return 2
    print(TABLE_HEADER)
    for env_id in ids:
        kwargs = {}
        if args.gravity is not None and env_id == "Planar3PAssemblyChange-v0":
            from planar3p_gym.envs.assembly_change import assembly_change_design

            kwargs["design"] = assembly_change_design().with_(gravity=args.gravity)
        for policy in STUDY_POLICIES[env_id]:
            try:
                res = run_baselines(env_id, policy, args.episodes, args.seed, kwargs)
            except ValueError as exc:
                print(f"error: {exc}", file=sys.stderr)
                return 2
            print(res.row(), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
