#!/usr/bin/env python
"""Baselines on Planar3PModeChange-v0 / Planar3PAssemblyChange-v0, and the crossing-fidelity study.

Default: every baseline of each id in --ids plays the same seeded episodes (reset(seed=seed +
i)); one table row per id and policy (success rate with a 95 % Wilson interval, time to
success, final errors, end reasons).  --fidelity: the crossing-fidelity study (assembly change
with the crossing controller, and reach with the analytic one, per physics and gravity).
--verify-rates: how often the assembly-change demonstration reaches its target, per physics,
gravity, force and speed.

examples:
  python scripts/task_baselines.py --episodes 50 --seed 0
  python scripts/task_baselines.py --fidelity --episodes 20
  python scripts/task_baselines.py --verify-rates --episodes 25
  python scripts/task_baselines.py --ids Planar3PAssemblyChange-v0 --gravity 9.81

Library: tooling.task_baselines.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser, UsageError
from tooling import script

#: Rows of the --verify-rates table: gravity (m/s^2), projection, max force (N), speed fraction.
VERIFY_SETTINGS = (
    (0.0, True, 40.0, 1.0),
    (0.0, False, 40.0, 1.0),
    (9.81, True, 40.0, 1.0),
    (9.81, False, 40.0, 1.0),
    (9.81, False, 40.0, 0.25),
    (9.81, False, 100.0, 0.25),
)
ASSEMBLY_CHANGE = "Planar3PAssemblyChange-v0"


def add_arguments(p: CliParser) -> None:
    from tooling.task_baselines import STUDY_POLICIES

    p.add_argument("--episodes", type=int, default=50, help="episodes per id and policy")
    p.add_argument("--seed", type=int, default=0, help="first episode seed")
    p.add_argument("--ids", default=",".join(STUDY_POLICIES), help="env ids, comma-separated")
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
        help=f"gravity (m/s^2) of the {ASSEMBLY_CHANGE} design (default: the id's, 0)",
    )


def check(args: argparse.Namespace) -> None:
    from tooling.task_baselines import STUDY_POLICIES

    checks.at_least("--episodes", args.episodes, 1)
    checks.at_least("--seed", args.seed, 0)
    args.ids = checks.split_list("--ids", args.ids)
    checks.known("--ids", args.ids, STUDY_POLICIES, "id")
    if args.gravity is not None:
        checks.in_range("--gravity", args.gravity, 0, 1000, high_open=True, unit="m/s^2")
    if args.fidelity and args.verify_rates:
        raise UsageError("give --fidelity or --verify-rates, not both")


def _print(label: str, figures: dict[str, float]) -> None:
    print(label)
    for k, v in figures.items():
        print(f"  {k}: {v:.6g}")


def verify_rates(episodes: int, seed: int) -> None:
    """The --verify-rates table."""
    from tooling.task_baselines import verification_rate

    print(
        "| gravity m/s^2 | physics | max force N | peak slider rate m/s | pairs | "
        "within 1 cm | within 5 cm |"
    )
    print("|---|---|---|---|---|---|---|")
    for gravity, projection, force, speed in VERIFY_SETTINGS:
        r = verification_rate(
            episodes,
            seed,
            gravity=gravity,
            projection=projection,
            speed_fraction=speed,
            max_force=force,
        )
        print(
            f"| {gravity} | {'projected' if projection else 'plain (8 x 18)'} | {force:.0f} "
            f"| {0.2 * speed:.2f} | {episodes} | {100 * r['within_1cm']:.0f} % "
            f"| {100 * r['within_5cm']:.0f} % |",
            flush=True,
        )


def fidelity(episodes: int, seed: int) -> None:
    """The crossing-fidelity study."""
    from tooling.task_baselines import run_fidelity, run_reach_fidelity

    for projection, gravity in ((True, None), (False, None), (True, 9.81), (False, 9.81)):
        f = run_fidelity(episodes, seed, projection, gravity)
        g = gravity if gravity is not None else 0.0
        _print(f"assembly change, crossing controller: projection={projection} gravity={g}", f)
    for projection in (True, False):
        for g in (0.0, 9.81):
            f = run_reach_fidelity(episodes, seed, projection, g)
            _print(f"reach (no crossing), analytic: projection={projection} gravity={g}", f)


def run(args: argparse.Namespace) -> int:
    from tooling.task_baselines import STUDY_POLICIES, TABLE_HEADER, run_baselines

    if args.verify_rates:
        verify_rates(args.episodes, args.seed)
        return 0
    if args.fidelity:
        fidelity(args.episodes, args.seed)
        return 0
    print(TABLE_HEADER)
    for env_id in args.ids:
        kwargs = {}
        if args.gravity is not None and env_id == ASSEMBLY_CHANGE:
            from planar3p_gym.envs.assembly_change import assembly_change_design

            kwargs["design"] = assembly_change_design().with_(gravity=args.gravity)
        for policy in STUDY_POLICIES[env_id]:
            print(run_baselines(env_id, policy, args.episodes, args.seed, kwargs).row(), flush=True)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run this script with ``argv`` (default: the process's arguments); the exit status."""
    return script.main(__name__, argv)


if __name__ == "__main__":
    raise SystemExit(main())
