#!/usr/bin/env python
"""Train a PPO, SAC or TD3 agent on Planar3P-v0 (or any registered variant) with SB3.

Examples::

    python scripts/train.py --algo sac --timesteps 300000 --seed 1
    python scripts/train.py --algo ppo --n-envs 8 --env-kwargs working_mode='[1,1,-1]'
    python scripts/train.py --algo sac --run-dir runs/sac-s1 --resume

Hyperparameters come from ``agents/hyperparams/<algo>.yml`` (rl-zoo3 format, keyed by the
environment id) unless ``--hyperparams`` names another file.  Every run writes a
self-contained directory (see :mod:`agents.training`); ``--resume`` continues from its last
checkpoint.
"""

from __future__ import annotations

import argparse
import json
import re
import shlex
import sys
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from agents.training import (  # noqa: E402
    ALGORITHMS,
    HYPERPARAMS_DIR,
    EnvFactory,
    TrainConfig,
    load_hyperparams,
    parse_env_kwargs,
    parse_overrides,
    resolve,
    to_jsonable,
    versions,
)


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--algo", required=True, help=f"one of {', '.join(ALGORITHMS)}")
    p.add_argument("--env", default="Planar3P-v0", help="registered environment id")
    p.add_argument("--timesteps", type=float, default=None, help="total environment steps")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--n-envs", type=int, default=None, help="parallel environments")
    p.add_argument("--env-kwargs", nargs="*", default=[], metavar="KEY=JSON")
    p.add_argument("--hyperparams", default=None, help="YAML file (rl-zoo3 format)")
    p.add_argument(
        "--params", nargs="*", default=[], metavar="KEY=YAML", help="override hyperparameters"
    )
    p.add_argument(
        "--run-dir", default=None, help="output directory (default runs/<algo>-<env>-s<seed>)"
    )
    p.add_argument("--resume", action="store_true", help="continue the run in --run-dir")
    p.add_argument("--eval-freq", type=int, default=10_000, help="steps between evaluations")
    p.add_argument("--eval-episodes", type=int, default=20)
    p.add_argument("--final-eval-episodes", type=int, default=100)
    p.add_argument("--checkpoint-freq", type=int, default=50_000)
    p.add_argument("--threads", type=int, default=1, help="torch threads")
    p.add_argument("--no-progress-bar", action="store_true")
    p.add_argument("--verbose", type=int, default=0)
    p.add_argument(
        "--kickstart",
        default=None,
        metavar="POLICY",
        help="PPO only: behaviour-clone this teacher (e.g. analytic-simultaneous) before RL",
    )
    p.add_argument("--kickstart-steps", type=int, default=20_000, help="teacher env steps")
    p.add_argument("--kickstart-epochs", type=int, default=40)
    p.add_argument(
        "--kickstart-log-std",
        type=float,
        default=-1.5,
        help="log standard deviation of the exploration noise after kick-starting",
    )
    return p.parse_args(argv)


class UsageError(Exception):
    """Bad input detected before training starts."""


def _check_env_id(env_id: str) -> None:
    import gymnasium as gym

    import planar3p_gym  # noqa: F401  (registers the ids)

    try:
        gym.spec(env_id)
    except gym.error.Error as exc:
        raise UsageError(f"unknown environment id {env_id!r}: {exc}") from exc


def _latest_checkpoint(run_dir: Path) -> tuple[Path, int]:
    best: tuple[Path, int] | None = None
    for path in (run_dir / "checkpoints").glob("rl_model_*_steps.zip"):
        m = re.fullmatch(r"rl_model_(\d+)_steps\.zip", path.name)
        if m and (best is None or int(m.group(1)) > best[1]):
            best = (path, int(m.group(1)))
    if best is None:
        raise UsageError(f"--resume: no checkpoint in {run_dir / 'checkpoints'}")
    return best


def prepare(args: argparse.Namespace) -> tuple[TrainConfig, Path]:
    """Validate everything and return the run's config and directory (nothing written)."""
    algo = args.algo.lower()
    if algo not in ALGORITHMS:
        raise UsageError(f"unknown algorithm {args.algo!r}; choose one of {', '.join(ALGORITHMS)}")
    if args.kickstart is not None:
        if algo != "ppo":
            raise UsageError("--kickstart is implemented for PPO only")
        if args.resume:
            raise UsageError("--kickstart applies to a new run, not to --resume")
        from agents.policies import PolicyError, parse_policy_spec

        try:
            parse_policy_spec(args.kickstart)
        except PolicyError as exc:
            raise UsageError(f"--kickstart: {exc}") from exc
    _check_env_id(args.env)
    run_dir = Path(args.run_dir or ROOT / "runs" / f"{algo}-{args.env}-s{args.seed}")
    if args.resume:
        cfg_path = run_dir / "config.json"
        try:
            saved = json.loads(cfg_path.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise UsageError(f"--resume: cannot read {cfg_path}: {exc}") from exc
        entry = dict(saved["entry"])
        env_kwargs = saved["config"]["env_kwargs"]
        seed = saved["config"]["seed"]
        n_envs = saved["config"]["n_envs"]
        _latest_checkpoint(run_dir)
    else:
        if run_dir.exists():
            raise UsageError(f"run directory {run_dir} exists; pass --resume or another --run-dir")
        hp_path = Path(args.hyperparams) if args.hyperparams else HYPERPARAMS_DIR / f"{algo}.yml"
        try:
            entry = load_hyperparams(hp_path, args.env, algo)
            entry.update(parse_overrides(args.params))
            env_kwargs = parse_env_kwargs(args.env_kwargs)
        except ValueError as exc:
            raise UsageError(str(exc)) from exc
        seed, n_envs = args.seed, args.n_envs
    try:
        cfg = resolve(
            algo,
            args.env,
            seed,
            entry,
            n_timesteps=int(args.timesteps) if args.timesteps is not None else None,
            n_envs=n_envs,
            env_kwargs=env_kwargs,
        )
    except ValueError as exc:
        raise UsageError(str(exc)) from exc
    # Constructing the environment once validates the kwargs before any training starts.
    import gymnasium as gym

    try:
        gym.make(cfg.env_id, **cfg.env_kwargs).close()
    except (TypeError, ValueError) as exc:
        raise UsageError(f"invalid environment kwargs {cfg.env_kwargs}: {exc}") from exc
    return cfg, run_dir


def _make_envs(cfg: TrainConfig, run_dir: Path, resume_stats: Path | None):
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecNormalize

    vec_cls = SubprocVecEnv if cfg.n_envs > 1 else DummyVecEnv
    factory = EnvFactory(cfg.env_id, cfg.env_kwargs)
    venv = make_vec_env(
        factory,
        n_envs=cfg.n_envs,
        seed=cfg.seed,
        vec_env_cls=vec_cls,
        monitor_kwargs={"info_keywords": ("is_success",)},
    )
    eval_env = make_vec_env(factory, n_envs=1, seed=cfg.seed + 10_000)
    if cfg.normalize is not None:
        gamma = cfg.algo_kwargs.get("gamma", 0.99)
        if resume_stats is not None:
            venv = VecNormalize.load(str(resume_stats), venv)
            venv.training = True
        else:
            venv = VecNormalize(venv, gamma=gamma, **cfg.normalize)
        eval_env = VecNormalize(eval_env, training=False, norm_reward=False, gamma=gamma)
    return venv, eval_env


def _evaluate(model: Any, eval_env: Any, episodes: int) -> dict[str, Any]:
    """Deterministic evaluation: success rate, returns, final errors."""
    returns, successes, pos_err, ang_err, lengths, reasons = [], [], [], [], [], {}
    obs = eval_env.reset()
    ep_ret, ep_len = 0.0, 0
    while len(returns) < episodes:
        action, _ = model.predict(obs, deterministic=True)
        obs, reward, done, infos = eval_env.step(action)
        ep_ret += float(reward[0])
        ep_len += 1
        if done[0]:
            info = infos[0]
            returns.append(ep_ret)
            lengths.append(ep_len)
            successes.append(bool(info.get("is_success", False)))
            pos_err.append(float(info.get("position_error", np.nan)))
            ang_err.append(float(info.get("orientation_error", np.nan)))
            reason = info.get("termination_reason") or "time_limit"
            reasons[reason] = reasons.get(reason, 0) + 1
            ep_ret, ep_len = 0.0, 0
    return {
        "episodes": episodes,
        "success_rate": float(np.mean(successes)),
        "mean_return": float(np.mean(returns)),
        "std_return": float(np.std(returns)),
        "median_position_error_mm": float(np.median(pos_err) * 1000),
        "median_orientation_error_deg": float(np.degrees(np.median(np.abs(ang_err)))),
        "mean_episode_length": float(np.mean(lengths)),
        "end_reasons": reasons,
    }


def _restore_learning_curve(evaluator: Any, path: Path, up_to: int) -> None:
    """Continue the learning curve of a resumed run: evaluations up to the checkpoint."""
    if not path.is_file():
        return
    with np.load(path) as data:
        keep = data["timesteps"] <= up_to
        evaluator.evaluations_timesteps = data["timesteps"][keep].tolist()
        evaluator.evaluations_results = data["results"][keep].tolist()
        evaluator.evaluations_length = data["ep_lengths"][keep].tolist()
        if "successes" in data:
            evaluator.evaluations_successes = data["successes"][keep].tolist()


def train(args: argparse.Namespace, cfg: TrainConfig, run_dir: Path) -> dict[str, Any]:
    import torch
    from stable_baselines3 import PPO, SAC, TD3
    from stable_baselines3.common.callbacks import (
        BaseCallback,
        CallbackList,
        CheckpointCallback,
        EvalCallback,
    )
    from stable_baselines3.common.noise import NormalActionNoise
    from stable_baselines3.common.vec_env import VecNormalize

    torch.set_num_threads(max(1, args.threads))
    algo_cls = {"ppo": PPO, "sac": SAC, "td3": TD3}[cfg.algo]
    off_policy = cfg.algo in ("sac", "td3")
    checkpoint, done_steps, stats = None, 0, None
    kick_report, kick_eval = None, None
    if args.resume:
        checkpoint, done_steps = _latest_checkpoint(run_dir)
        candidate = run_dir / "checkpoints" / f"rl_model_vecnormalize_{done_steps}_steps.pkl"
        stats = candidate if candidate.exists() else None
    run_dir.mkdir(parents=True, exist_ok=True)
    venv, eval_env = _make_envs(cfg, run_dir, stats)

    if checkpoint is not None:
        model = algo_cls.load(str(checkpoint), env=venv, tensorboard_log=str(run_dir / "tb"))
        buffer = run_dir / "checkpoints" / f"rl_model_replay_buffer_{done_steps}_steps.pkl"
        if off_policy and buffer.exists():
            model.load_replay_buffer(str(buffer))
    else:
        kwargs = dict(cfg.algo_kwargs)
        if cfg.noise_type == "normal":
            n = venv.action_space.shape[0]
            kwargs["action_noise"] = NormalActionNoise(np.zeros(n), cfg.noise_std * np.ones(n))
        model = algo_cls(
            cfg.policy,
            venv,
            seed=cfg.seed,
            verbose=args.verbose,
            tensorboard_log=str(run_dir / "tb"),
            **kwargs,
        )
        if args.kickstart is not None:
            from agents.kickstart import kickstart_ppo
            from agents.policies import load_policy

            teacher_env = EnvFactory(cfg.env_id, cfg.env_kwargs)()
            teacher = load_policy(args.kickstart, env=teacher_env, seed=cfg.seed)
            teacher_env.close()
            kick_report = kickstart_ppo(
                model,
                teacher,
                args.kickstart,
                args.kickstart_steps,
                epochs=args.kickstart_epochs,
                log_std=args.kickstart_log_std,
                seed=cfg.seed,
            )
            # The kick-started policy before any RL, saved and evaluated like the final one.
            model.save(str(run_dir / "kickstart_model.zip"))
            if isinstance(venv, VecNormalize):
                venv.save(str(run_dir / "kickstart_vecnormalize.pkl"))
                eval_env.obs_rms = venv.obs_rms
            kick_eval = _evaluate(model, eval_env, args.eval_episodes)
        record = {
            "config": to_jsonable(cfg.to_json()),
            "kickstart": to_jsonable({**asdict(kick_report), "evaluation": kick_eval})
            if kick_report is not None
            else None,
            "entry": to_jsonable(cfg.entry),
            "command": " ".join(shlex.quote(a) for a in sys.argv),
        }
        (run_dir / "config.json").write_text(json.dumps(record, indent=2))
        (run_dir / "versions.json").write_text(json.dumps(versions(), indent=2))

    class SaveStatsOnBest(BaseCallback):
        def _on_step(self) -> bool:
            if isinstance(venv, VecNormalize):
                venv.save(str(run_dir / "best_vecnormalize.pkl"))
            return True

    per_env = max(1, cfg.n_envs)
    evaluator = EvalCallback(
        eval_env,
        callback_on_new_best=SaveStatsOnBest(),
        n_eval_episodes=args.eval_episodes,
        eval_freq=max(1, args.eval_freq // per_env),
        log_path=str(run_dir),
        best_model_save_path=str(run_dir),
        deterministic=True,
        verbose=args.verbose,
    )
    if checkpoint is not None:
        _restore_learning_curve(evaluator, run_dir / "evaluations.npz", done_steps)
    callbacks = CallbackList(
        [
            evaluator,
            CheckpointCallback(
                save_freq=max(1, args.checkpoint_freq // per_env),
                save_path=str(run_dir / "checkpoints"),
                save_replay_buffer=off_policy,
                save_vecnormalize=True,
            ),
        ]
    )
    remaining = max(0, cfg.n_timesteps - done_steps)
    start = time.perf_counter()
    model.learn(
        total_timesteps=remaining,
        callback=callbacks,
        progress_bar=not args.no_progress_bar,
        reset_num_timesteps=checkpoint is None,
        tb_log_name=cfg.algo.upper(),
    )
    wall = time.perf_counter() - start
    model.save(str(run_dir / "model.zip"))
    if isinstance(venv, VecNormalize):
        venv.save(str(run_dir / "vecnormalize.pkl"))
        eval_env.obs_rms = venv.obs_rms
    final = _evaluate(model, eval_env, args.final_eval_episodes)
    metrics = {
        "final_evaluation": final,
        "timesteps": int(model.num_timesteps),
        "timesteps_this_session": int(model.num_timesteps - done_steps),
        "wall_time_s": wall,
        "steps_per_s": (model.num_timesteps - done_steps) / wall if wall > 0 else None,
        "resumed_from": done_steps if checkpoint is not None else None,
    }
    previous = run_dir / "metrics.json"
    if checkpoint is not None and previous.exists():
        metrics["previous_sessions"] = json.loads(previous.read_text())
    previous.write_text(json.dumps(metrics, indent=2))
    venv.close()
    eval_env.close()
    return metrics


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        cfg, run_dir = prepare(args)
    except UsageError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    metrics = train(args, cfg, run_dir)
    final = metrics["final_evaluation"]
    print(
        f"{cfg.algo.upper()} seed {cfg.seed}: {metrics['timesteps']} steps in "
        f"{metrics['wall_time_s']:.0f} s ({metrics['steps_per_s']:.0f} steps/s); "
        f"success {final['success_rate']:.2%} over {final['episodes']} episodes; "
        f"run directory {run_dir}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
