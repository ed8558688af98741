"""Fitting the learned pose correction (:mod:`planar3p_agents.controllers.pose_correction`) on
simulated episodes of the machine as built.

The bias of the pose reading needs the true pose, which only a simulation reports
(``info["pose"]``), so the samples come from episodes of a task suite's environment on the
machine as built (:data:`SUITES`), each on a machine drawn by the environment: a baseline
drives them (the states a controller on that machine visits; by default the suite's first,
``analytic-on-off-predictive`` on ``real-on-off``, ``analytic-simultaneous`` on the others;
``--driver planner`` for the mode change, which the simple motions fail),
and every ``every``-th step and the last of each episode is a sample.  The episodes are the
environment's own draws from the reset seed, not the suite's fixed episodes.  Nothing here is
in SB3: it is a least-squares fit, not reinforcement learning.

    python -m planar3p_agents.training.pose_correction --seed 1 --out runs/onoff/corr-s1.json
    python -m planar3p_agents.training.pose_correction --suite real-assembly-change \
        --seed 1001 --out runs/rac/correction-s1.json
    python -m planar3p_agents.training.pose_correction --suite real-mode-change \
        --driver planner --seed 1001 --out runs/rmc/correction-s1.json
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

import numpy as np

import planar3p_gym  # noqa: F401  (registers the ids)
from planar3p_agents.commands import checks as cli_checks
from planar3p_agents.commands.parser import UsageError
from planar3p_agents.controllers.pose_correction import (
    PoseCorrection,
    fit_pose_correction,
    pose_bias,
)
from planar3p_agents.controllers.registry import baselines_for
from planar3p_agents.evaluation.task_suites import TASK_SUITES, make_task_env
from planar3p_agents.policies.factory import load_policy
from planar3p_gym import checks

__all__ = ["SUITES", "collect_samples", "driver_of", "drivers", "fit_on_episodes", "main"]

#: The task suites on the machine as built whose observed pose is read through the nominal
#: model (the ones a correction applies to).
SUITES: tuple[str, ...] = ("real-on-off", "real-reach", "real-mode-change", "real-assembly-change")


def drivers(suite: str) -> tuple[str, ...]:
    """The baselines that can drive the episodes of task suite ``suite`` (those of its id)."""
    return baselines_for(TASK_SUITES[suite].env_id)


def driver_of(suite: str, driver: str | None = None) -> str:
    """The baseline that drives ``suite``'s episodes: ``driver``, one of :func:`drivers`, or
    for ``None`` the suite's first baseline; ``ValueError`` for another."""
    driver = TASK_SUITES[suite].baselines[0] if driver is None else driver
    if driver not in drivers(suite):
        raise ValueError(f"driver must be one of {', '.join(drivers(suite))}, got {driver!r}")
    return driver


def collect_samples(
    suite: str = "real-on-off",
    episodes: int = 300,
    seed: int = 0,
    every: int = 25,
    driver: str | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Observations ``(n, d)`` and pose biases ``(n, 3)`` of ``episodes`` episodes of the
    environment of task suite ``suite`` (one of :data:`SUITES`), driven by the baseline
    ``driver`` (``None``: the suite's first baseline; one of :func:`drivers`), reset with
    ``seed`` once, then from the environment's own stream."""
    if suite not in SUITES:
        raise ValueError(f"suite must be one of {', '.join(SUITES)}, got {suite!r}")
    driver = driver_of(suite, driver)
    episodes = checks.integer(episodes, "episodes", low=1)
    every = checks.integer(every, "every", low=1)
    env = make_task_env(suite)
    policy = load_policy(driver, env)
    obs_rows: list[np.ndarray] = []
    true_poses: list[Any] = []
    try:
        for i in range(episodes):
            obs, _ = env.reset(seed=int(seed) if i == 0 else None)
            state, start = None, np.ones(1, dtype=bool)
            for t in range(10**6):
                action, state = policy.predict(obs, state=state, episode_start=start)
                start = np.zeros(1, dtype=bool)
                obs, _, terminated, truncated, info = env.step(action)
                if t % every == 0 or terminated or truncated:
                    obs_rows.append(np.asarray(obs, dtype=np.float64))
                    true_poses.append(info["pose"])
                if terminated or truncated:
                    break
    finally:
        env.close()
    obs_arr = np.stack(obs_rows)
    return obs_arr, pose_bias(obs_arr, true_poses)


def fit_on_episodes(
    suite: str = "real-on-off",
    episodes: int = 300,
    seed: int = 0,
    every: int = 25,
    driver: str | None = None,
) -> PoseCorrection:
    """:func:`fit_pose_correction` of :func:`collect_samples`."""
    return fit_pose_correction(*collect_samples(suite, episodes, seed, every, driver))


def main(argv: list[str] | None = None) -> int:
    """Command line: fit a correction and write it as JSON (exit 2 on a bad flag)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--suite", default="real-on-off", help=f"task suite: one of {', '.join(SUITES)}"
    )
    parser.add_argument(
        "--driver",
        default=None,
        help="baseline that drives the episodes (default: the suite's first)",
    )
    parser.add_argument("--episodes", type=int, default=300, help="episodes simulated")
    parser.add_argument("--seed", type=int, default=0, help="seed of the first reset")
    parser.add_argument("--every", type=int, default=25, help="steps between samples")
    parser.add_argument("--out", required=True, help="JSON file to write")
    args = parser.parse_args(argv)
    try:  # every flag, the output path included, before the episodes are simulated
        cli_checks.at_least("--episodes", args.episodes, 1)
        cli_checks.at_least("--every", args.every, 1)
        cli_checks.at_least("--seed", args.seed, 0)
        cli_checks.known("--suite", [args.suite], SUITES, "suite")
        if args.driver is not None:
            cli_checks.known("--driver", [args.driver], drivers(args.suite), "baseline")
        cli_checks.output_file("--out", args.out)
    except UsageError as exc:
        parser.error(str(exc))
    driver = driver_of(args.suite, args.driver)
    correction = fit_on_episodes(args.suite, args.episodes, args.seed, args.every, driver)
    env_id = TASK_SUITES[args.suite].env_id
    correction.save(
        args.out,
        suite=args.suite,
        driver=driver,
        env_id=env_id,
        episodes=args.episodes,
        seed=args.seed,
        every=args.every,
    )
    print(f"pose correction fitted on {args.episodes} episodes of {args.suite}: {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
