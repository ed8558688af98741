"""Workspace and singularity study of the 3-PRR manipulator (docs/mechanism.md, Section 6).

Runs the paper's relative-workspace study S(L) on the fig8 preset (21 strokes from 0.10 to
0.30 m, 201 x 201 grid, 360 orientations, 8 working modes) on one core and prints its time,
writes the S(L) / usable S(L) table (markdown and CSV), recommends a stroke (the shortest one
without dead zones), and draws the figures into <out>/figures/:

  workspace_fig7.png                  the workspace map of the fig7 preset (paper, Figure 7)
  workspace_stroke.png                S and usable S versus the stroke (paper, Figure 8)
  workspace_dead_zones.png            the whole-plane workspace of fig8 at a few strokes
  workspace_singularities_ytheta.png  det A = 0 and det B = 0 over (y, theta), per mode
  workspace_singularities_plane.png   the same loci in the plane at a fixed orientation

Every file is written atomically, after all arguments have been checked.

examples:
  planar3p workspace            # full study, figures, tables -> docs/
  planar3p workspace --quick    # coarse settings, for a smoke test

Library: planar3p_gym.analysis.workspace_report (study, recommendation, tables) and
planar3p_gym.analysis.workspace_figures.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
from pathlib import Path

from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser


def add_arguments(p: CliParser) -> None:
    p.add_argument("--out", type=Path, default=Path("docs"), help="output directory")
    p.add_argument("--quick", action="store_true", help="coarse settings (smoke test)")
    p.add_argument(
        "--repeats",
        type=int,
        default=None,
        help="timed repeats of the study, median reported (default: 3, 1 with --quick)",
    )
    p.add_argument("--no-figures", action="store_true", help="skip the figures")
    p.add_argument(
        "--bench-only", action="store_true", help="only time the S(L) study (no tables, no figures)"
    )
    p.add_argument("--no-pin", action="store_true", help="do not pin the process to one CPU")
    p.add_argument(
        "--theta-plane",
        type=float,
        default=195.0,
        help="orientation (deg) of the fixed-orientation singularity figure",
    )


def check(args: argparse.Namespace) -> None:
    if args.repeats is not None:
        checks.at_least("--repeats", args.repeats, 1)
    checks.in_range("--theta-plane", args.theta_plane, -360, 360, unit="deg")
    if not (args.bench_only or args.no_figures):
        checks.extra_installed(
            "--no-figures", "matplotlib", "plots", "without it, drawing the figures"
        )
    if not args.bench_only:
        checks.output_dir("--out", args.out)
        checks.output_dir("--out", args.out / "figures")


def _rel(path: Path) -> str:
    """``path`` relative to the working directory if inside it."""
    try:
        return str(path.resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(path)


def _times(label: str, times: list[float]) -> str:
    runs = ", ".join(f"{t:.3f}" for t in times)
    return f"  {label:32s}: median {statistics.median(times):.3f} s (runs: {runs})"


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from planar3p_agents.commands.runtime import pin_one_core
    from planar3p_gym.analysis import workspace_figures as figures
    from planar3p_gym.analysis.workspace_report import (
        StudySettings,
        recommendation_text,
        run_study,
        time_study,
        verify,
        write_tables,
    )

    settings = StudySettings.preset(args.quick, args.repeats)
    n, nt = settings.grid, settings.orientations
    print(
        f"numpy {np.__version__}, python {sys.version.split()[0]}; "
        f"{'not pinned' if args.no_pin else pin_one_core()}; "
        f"load average {tuple(round(v, 2) for v in os.getloadavg())}"
    )
    print(
        f"S(L) study: fig8, 21 strokes 0.10..0.30 m, {n} x {n} grid, {nt} orientations, "
        "8 working modes"
    )
    if args.bench_only:
        res = time_study(settings)
        print(_times("reachable S(L) only", res["t_core"]))
        print(_times("S(L) + usable S(L) + dead zones", res["t_full"]))
        print(f"load average after: {os.getloadavg()}")
        return 0
    res = run_study(settings)
    print(_times("reachable S(L) only", res["t_core"]))
    print(_times("S(L) + usable S(L) + dead zones", res["t_full"]))
    print(f"  ({res['evals']:.3g} pose/mode tests, equivalent to brute-force IK on every one)")
    ver = verify(settings.quick)
    print(
        f"verification: {ver['tested']} grid points ({ver['n']} x {ver['n']}, {ver['nt']} "
        f"orientations, 3 strokes) -- fast grid vs brute-force kinematics.inverse: "
        f"{ver['mismatches']} mismatches; brute force {ver['rate']:.3g} pose/mode tests per s"
    )
    est = res["evals"] / ver["rate"]
    print(f"brute-force IK for the same study (extrapolated from that rate): ~{est:.0f} s")
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    md, csv_path = write_tables(out, res)[::-1]
    print(recommendation_text(res["rec"]).replace("**", ""))
    print("\nS(L) table:")
    print(f"{'L (m)':>7} {'S':>7} {'usable':>7} {'holes':>5} {'area cm2':>9}")
    for st in (res["study"], res["ext"]):
        for i, L in enumerate(st.strokes):
            print(
                f"{L:7.2f} {st.S[i]:7.4f} {st.S_usable[i]:7.4f} {st.dead_zones[i]:5d} "
                f"{st.dead_zone_area[i] * 1e4:9.1f}"
            )
    print(f"recommendation details: {res['rec']}")
    print(f"tables -> {_rel(md)}, {_rel(csv_path)}")
    if not args.no_figures:
        f7 = figures.fig_fig7(out, settings)
        print(
            f"fig7: S = {f7['S']:.4f}, usable S = {f7['S_usable']:.4f}, dead zones = "
            f"{f7['dead_zones']} ({f7['dz_area']:.3f} m^2) -> {_rel(f7['path'])}"
        )
        for path in (
            figures.fig_stroke(out, res),
            figures.fig_dead_zones(out, settings),
            figures.fig_sing_ytheta(out, settings),
            figures.fig_sing_plane(out, settings, args.theta_plane),
        ):
            print(f"-> {_rel(path)}")
    print(
        f"\nBENCHMARK: S(L) study (21 strokes, {n}x{n}, {nt} orientations, 8 modes, with usable "
        f"S and dead zones) median {statistics.median(res['t_full']):.2f} s on one core; "
        f"reachable S(L) alone {statistics.median(res['t_core']):.2f} s"
    )
    return 0
