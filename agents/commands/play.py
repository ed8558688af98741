"""Play a policy on a registered id and print each episode: a baseline, a shipped model or a
trained one.

POLICY is what `planar3p benchmark --policies` takes: a baseline name (`planar3p list
baselines`), pretrained:<name> (`planar3p list pretrained`; checked against SHA256SUMS before
it loads) or a model .zip (optionally :stats=PATH.pkl). A model plays its own training id by
default, with the observation arguments its run recorded. Each episode is reset with seed
--seed + k and played deterministically; the table gives its steps, why it ended, its return
and final position error. --render human opens a window (pygame); --gif records every
--frame-every-th step of the episodes to an animated GIF (the video extra).

examples:
  planar3p play pretrained:ppo_reach_line --episodes 5
  planar3p play analytic-simultaneous --env Planar3PReal-v0 --episodes 3 --seed 100
  planar3p play crossing --env Planar3PAssemblyChange-v0 --gif crossing.gif
  planar3p play runs/ppo-s1/model.zip:stats=runs/ppo-s1/vecnormalize.pkl --render human

Exit status: 0 done; 2 bad input (an unknown policy or id, a model that cannot play the id, a
bad option or output path), found before any episode is played. Model and statistics files
are code: play only files you trust.
Library: planar3p_agents.evaluation.play.
"""

from __future__ import annotations

import argparse
import json

from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser, UsageError


def add_arguments(p: CliParser) -> None:
    p.add_argument("policy", help="baseline name, pretrained:<name> or a model .zip")
    p.add_argument("--env", help="registered id (default: a model's training id, else Planar3P-v0)")
    p.add_argument("--episodes", type=int, default=1, help="episodes to play")
    p.add_argument("--seed", type=int, default=0, help="seed of the first episode's reset")
    p.add_argument(
        "--env-kwargs", nargs="*", default=[], metavar="KEY=JSON", help="environment arguments"
    )
    p.add_argument(
        "--render", choices=("none", "human"), default="none", help="human: a pygame window"
    )
    p.add_argument("--gif", help="also write the episodes to this animated GIF")
    p.add_argument("--frame-every", type=int, default=2, help="record every n-th step into the GIF")
    p.add_argument("--json", dest="json_out", help="also write the outcomes here (JSON)")
    p.add_argument("--device", default="cpu", help="torch device of a model")


def check(args: argparse.Namespace) -> None:
    import gymnasium as gym

    import planar3p_gym  # noqa: F401  (registers the ids)
    from planar3p_agents.policies.spec import PolicyError, parse_policy_spec
    from planar3p_agents.training.config import parse_env_kwargs

    checks.at_least("--episodes", args.episodes, 1)
    checks.at_least("--seed", args.seed, 0)
    checks.at_least("--frame-every", args.frame_every, 1)
    try:
        parse_policy_spec(args.policy)
    except PolicyError as exc:
        raise UsageError(f"policy: {exc}") from None
    if args.env is not None and args.env not in gym.registry:
        raise UsageError(f"--env: unknown environment id {args.env!r} (planar3p list ids)")
    try:
        args.env_kwargs = parse_env_kwargs(args.env_kwargs)
    except ValueError as exc:
        raise UsageError(f"--env-kwargs: {exc}") from None
    if args.gif is not None:
        if args.render == "human":
            raise UsageError("--gif: cannot record while --render human draws to a window")
        checks.extra_installed("--gif", "imageio", "video", "writing a GIF")
        checks.output_file("--gif", args.gif)
    if args.render == "human":
        checks.extra_installed("--render", "pygame", "video", "a window")
    if args.json_out is not None:
        checks.output_file("--json", args.json_out)


def _row(ep) -> str:  # ep: PlayedEpisode
    error = "" if ep.position_error_mm is None else f"{ep.position_error_mm:.2f}"
    return f"{ep.seed:>6} {ep.steps:>6} {ep.end_reason:<24} {ep.episode_return:>10.2f} {error:>9}"


def run(args: argparse.Namespace) -> int:
    from planar3p_agents.evaluation.play import play, play_env_id
    from planar3p_agents.policies.spec import PolicyError
    from planar3p_gym.atomic_files import write_atomic

    env_id = args.env or play_env_id(args.policy)

    def show(ep) -> None:  # the header before the first row: bad input prints nothing
        if ep.seed == args.seed:
            print(f"{args.policy} on {env_id}")
            print(f"{'seed':>6} {'steps':>6} {'end':<24} {'return':>10} {'error mm':>9}")
        print(_row(ep), flush=True)

    try:
        outcomes = play(
            args.policy,
            env_id,
            episodes=args.episodes,
            seed=args.seed,
            env_kwargs=args.env_kwargs,
            render_mode="human" if args.render == "human" else None,
            gif=args.gif,
            frame_every=args.frame_every,
            device=args.device,
            on_episode=show,
        )
    except (PolicyError, ValueError) as exc:
        raise UsageError(str(exc)) from None
    successes = sum(ep.success for ep in outcomes)
    print(f"success: {successes}/{len(outcomes)}")
    if args.gif is not None:
        print(f"wrote {args.gif}")
    if args.json_out is not None:
        record = {"policy": args.policy, "env": env_id, "episodes": [e.as_dict() for e in outcomes]}
        write_atomic(args.json_out, json.dumps(record, indent=2) + "\n")
    return 0
