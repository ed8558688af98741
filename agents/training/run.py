"""One training run, from validated settings to a finished run directory.

:func:`plan_run` checks everything a run needs (algorithm, environment id and kwargs,
hyperparameters, the run's options, the run directory) and raises ``ValueError`` on bad input
*before anything is written*; :func:`execute` then trains and fills the run directory described
in :mod:`planar3p_agents.training.config`.  ``scripts/train.py`` and the sweeps
(:mod:`planar3p_agents.training.sweep`) both go through these two functions, so a sweep trial is the
same code path as a command-line run.

SB3 and rl-zoo3 do the standard parts: ``make_vec_env``, ``VecNormalize``, ``EvalCallback`` with
rl-zoo3's ``SaveVecNormalizeCallback`` on each new best, ``CheckpointCallback``,
``evaluate_policy``.  What is specific to this project: kick-starting from a teacher
(:mod:`planar3p_agents.training.kickstart`), the final evaluation's task metrics (success rate,
final errors, how episodes ended, from the env's ``info``), and resuming a run from its last
checkpoint with its learning curve.
"""

from __future__ import annotations

import inspect
import json
import time
import warnings
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from planar3p_agents.training.checkpoints import (
    CHECKPOINT_DIR,
    checkpoint_path,
    prune_replay_buffers,
    run_checkpoints,
)
from planar3p_agents.training.config import (
    ALGORITHMS,
    HYPERPARAMS_DIR,
    OFF_POLICY,
    EnvFactory,
    TrainConfig,
    import_rl_zoo3,
    load_hyperparams,
    parse_env_kwargs,
    parse_overrides,
    policy_class,
    resolve,
    to_jsonable,
    versions,
)
from planar3p_gym.atomic_files import write_atomic

__all__ = [
    "VEC_ENVS",
    "RunOptions",
    "RunPlan",
    "algo_class",
    "evaluate",
    "execute",
    "latest_checkpoint",
    "make_envs",
    "model_kwargs",
    "plan_run",
    "vec_env_kind",
]

#: Vectorised-environment choices: ``native`` = all environments in one process through the
#: native vector env (:func:`planar3p_agents.training.vec_adapter.make_native_vec_env`; ids
#: with a native vector env); ``auto`` = ``native`` where the id has one and takes the run's
#: environment arguments, else ``SubprocVecEnv`` when ``n_envs > 1``, else ``DummyVecEnv``
#: (:func:`vec_env_kind`).
VEC_ENVS = ("auto", "dummy", "subproc", "native")


@dataclass
class RunOptions:
    """How a run evaluates, checkpoints and kick-starts (everything but the hyperparameters).

    Frequencies are in environment steps (summed over the parallel environments).
    """

    eval_freq: int = 10_000
    eval_episodes: int = 20
    final_eval_episodes: int = 100
    checkpoint_freq: int = 50_000
    threads: int = 1
    progress_bar: bool = True
    verbose: int = 0
    vec_env: str = "auto"
    kickstart: str | None = None
    kickstart_steps: int = 20_000
    kickstart_epochs: int = 40
    kickstart_log_std: float = -1.5

    def validate(self) -> None:
        """``ValueError`` naming the first bad option."""
        for name in (
            "eval_freq",
            "eval_episodes",
            "final_eval_episodes",
            "checkpoint_freq",
            "threads",
            "kickstart_steps",
            "kickstart_epochs",
        ):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                flag = "--" + name.replace("_", "-")
                raise ValueError(f"{flag} must be a positive integer, got {value!r}")
        if not np.isfinite(self.kickstart_log_std):
            raise ValueError(f"--kickstart-log-std must be finite, got {self.kickstart_log_std}")
        if self.vec_env not in VEC_ENVS:
            raise ValueError(f"--vec-env must be one of {', '.join(VEC_ENVS)}")


@dataclass
class RunPlan:
    """A validated run: its configuration, directory, options and what it resumes from."""

    cfg: TrainConfig
    run_dir: Path
    options: RunOptions
    resume_from: tuple[Path, int] | None = None  # (checkpoint, its step count)
    command: str = ""
    extra: dict[str, Any] = field(default_factory=dict)  # recorded in config.json
    #: ``cfg.task_schedule`` checked against the run's environment
    #: (:mod:`planar3p_agents.training.task_schedule`).
    task_schedule: list[tuple[int, dict[str, Any]]] | None = None
    #: The vectorised environment the run uses (``options.vec_env`` resolved,
    #: :func:`vec_env_kind`): ``native``, ``subproc`` or ``dummy``.
    vec_env: str = "dummy"


def latest_checkpoint(run_dir: Path) -> tuple[Path, int]:
    """The newest ``checkpoints/rl_model_<n>_steps.zip`` of a run and ``n``, or ``ValueError``."""
    found = run_checkpoints(run_dir)
    if not found:
        raise ValueError(f"--resume: no checkpoint in {run_dir / CHECKPOINT_DIR}")
    steps = max(found)
    return found[steps], steps


def _checkpoint_callback(base: type) -> type:
    """SB3's ``CheckpointCallback`` (``base``, imported lazily with SB3) that keeps only the
    newest replay buffer (:func:`~planar3p_agents.training.checkpoints.prune_replay_buffers`),
    after the new one is written."""

    class KeepNewestReplayBuffer(base):  # type: ignore[misc, valid-type]
        def _on_step(self) -> bool:
            out = super()._on_step()
            if self.save_replay_buffer and self.n_calls % self.save_freq == 0:
                prune_replay_buffers(Path(self.save_path).parent)
            return out

    return KeepNewestReplayBuffer


def algo_class(algo: str) -> Any:
    """The SB3 (or sb3-contrib) class of an algorithm name (``ppo``, ``sac``, ``td3``,
    ``dqn``, ``tqc``)."""
    from stable_baselines3 import DQN, PPO, SAC, TD3

    if algo == "tqc":
        from sb3_contrib import TQC

        return TQC
    return {"ppo": PPO, "sac": SAC, "td3": TD3, "dqn": DQN}[algo]


def _check_env(env_id: str, env_kwargs: dict[str, Any]) -> None:
    import gymnasium as gym

    import planar3p_gym  # noqa: F401  (registers the ids)

    try:
        gym.spec(env_id)
    except gym.error.Error as exc:
        raise ValueError(f"unknown environment id {env_id!r}: {exc}") from exc
    try:
        gym.make(env_id, **env_kwargs).close()
    except (TypeError, ValueError) as exc:
        raise ValueError(f"invalid environment kwargs {env_kwargs}: {exc}") from exc


def _task_schedule(cfg: TrainConfig) -> list[tuple[int, dict[str, Any]]] | None:
    """The run's validated ``task_schedule`` (:mod:`planar3p_agents.training.task_schedule`)
    against the task configuration of its environment, or None without one."""
    if cfg.task_schedule is None:
        return None
    import gymnasium as gym

    from planar3p_agents.training.task_schedule import parse_task_schedule

    env = gym.make(cfg.env_id, **cfg.env_kwargs)
    try:
        base = getattr(env.unwrapped, "task_config", None)
        if base is None or not hasattr(env.unwrapped, "set_task_config"):
            raise ValueError(f"task_schedule: {cfg.env_id} has no task configuration to change")
        return parse_task_schedule(cfg.task_schedule, base)
    finally:
        env.close()


def _check_native(cfg: TrainConfig) -> None:
    from planar3p_agents.training.vec_adapter import make_native_vec_env

    try:
        make_native_vec_env(cfg.env_id, n_envs=1, env_kwargs=cfg.env_kwargs).close()
    except (TypeError, ValueError) as exc:
        raise ValueError(f"--vec-env native: {exc}") from exc


def _native_fits(cfg: TrainConfig) -> bool:
    """Whether the native vector env takes the run's environment arguments, has the single
    environment's spaces and steps with its actions (else SB3's own vector envs run the
    single environments)."""
    import gymnasium as gym

    from planar3p_agents.training.vec_adapter import make_native_vec_env

    try:
        venv = make_native_vec_env(cfg.env_id, n_envs=1, env_kwargs=cfg.env_kwargs)
    except (TypeError, ValueError):
        return False
    single = gym.make(cfg.env_id, **cfg.env_kwargs)
    try:
        if not (
            venv.action_space == single.action_space
            and venv.observation_space == single.observation_space
        ):
            return False
        venv.seed(0)
        venv.reset()
        try:  # one step with the single environment's kind of action
            venv.step(np.array([single.action_space.sample()]))
        except (TypeError, ValueError):
            return False
        return True
    finally:
        venv.close()
        single.close()


def vec_env_kind(cfg: TrainConfig, choice: str) -> str:
    """The vectorised environment of ``choice`` (one of :data:`VEC_ENVS`) for ``cfg``:
    ``native``, ``subproc`` or ``dummy``. ``auto`` is ``native`` where the id has a native
    vector env that takes the run's environment arguments with the same spaces (all
    environments in this process: no worker processes to start, the fastest here), else
    ``subproc`` for several environments, else ``dummy``. An explicit ``native`` that cannot
    be made raises ``ValueError``."""
    if choice == "native":
        _check_native(cfg)
        return "native"
    if choice == "auto":
        import gymnasium as gym

        if gym.spec(cfg.env_id).vector_entry_point is not None and _native_fits(cfg):
            return "native"
        return "subproc" if cfg.n_envs > 1 else "dummy"
    return choice


def _check_model(cfg: TrainConfig) -> Any:
    """Build the model once on throw-away environments, so that every hyperparameter SB3
    rejects is reported before the run directory exists; returns that model."""
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    cls = algo_class(cfg.algo)
    signature = inspect.signature(cls.__init__).parameters
    unknown = sorted(set(cfg.algo_kwargs) - set(signature) - {"self", "policy", "env"})
    if unknown:
        raise ValueError(f"{cfg.algo.upper()} has no hyperparameter {', '.join(unknown)}")
    for key, value in cfg.algo_kwargs.items():
        default = signature[key].default
        _check_type(key, value, default)
        if isinstance(default, int) and not isinstance(default, bool):
            if isinstance(value, float):  # YAML's !!float 1e6 for a count
                cfg.algo_kwargs[key] = int(value)
            elif isinstance(value, list):  # YAML has no tuples: train_freq [1, "episode"]
                cfg.algo_kwargs[key] = tuple(value)
    venv = _command_memory(cfg, DummyVecEnv([EnvFactory(cfg.env_id, cfg.env_kwargs)] * cfg.n_envs))
    try:
        _check_action_space(cfg, venv.action_space)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if cfg.normalize is not None:
                venv = VecNormalize(venv, gamma=cfg.algo_kwargs.get("gamma", 0.99), **cfg.normalize)
            return cls(policy_class(cfg.policy), venv, device="cpu", **model_kwargs(cfg, venv))
    except Exception as exc:  # SB3 raises many kinds (TypeError, AssertionError, ...)
        raise ValueError(f"invalid hyperparameters for {cfg.algo.upper()}: {exc!r}") from exc
    finally:
        venv.close()


def _check_action_space(cfg: TrainConfig, space: Any) -> None:
    """DQN needs a ``Discrete`` action space: ``ValueError`` saying how to get one otherwise
    (before SB3's own assertion, which would read as a bad hyperparameter)."""
    from gymnasium import spaces

    if cfg.algo == "dqn" and not isinstance(space, spaces.Discrete):
        raise ValueError(
            f"DQN needs a Discrete action space; {cfg.env_id} with {cfg.env_kwargs or 'no'} "
            f"environment kwargs has {space} (for the on-off machine pass --env-kwargs "
            "action_type='\"on-off-discrete\"')"
        )


#: Hyperparameters that must be at least 1 (SB3 fails only later, while training).
_AT_LEAST_ONE = {"batch_size", "n_steps", "n_epochs", "buffer_size"}


def _check_type(key: str, value: Any, default: Any) -> None:
    """A hyperparameter must have the kind of value its SB3 default has (numbers finite)."""
    if callable(value) or default is inspect.Parameter.empty:
        return
    what = f"hyperparameter {key}"
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ValueError(f"{what} must be true or false, got {value!r}")
    elif isinstance(default, int) and not isinstance(value, (list, tuple)):
        whole = isinstance(value, int) or (isinstance(value, float) and value.is_integer())
        if isinstance(value, bool) or not whole:
            raise ValueError(f"{what} must be an integer, got {value!r}")
        if key in _AT_LEAST_ONE and value < 1:
            raise ValueError(f"{what} must be at least 1, got {value!r}")
    elif isinstance(default, float):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValueError(f"{what} must be a number, got {value!r}")
    if isinstance(value, float) and not np.isfinite(value):
        raise ValueError(f"{what} must be finite, got {value!r}")


def model_kwargs(cfg: TrainConfig, venv: Any) -> dict[str, Any]:
    """The keyword arguments a model of ``cfg`` is built with on ``venv``: the config's
    hyperparameters, its policy's resolved arguments and its action noise."""
    from stable_baselines3.common.noise import NormalActionNoise

    kwargs = dict(cfg.algo_kwargs)
    # A policy class may resolve its arguments first (e.g. weights named by their file).
    resolve = getattr(policy_class(cfg.policy), "resolve_policy_kwargs", None)
    if resolve is not None and "policy_kwargs" in kwargs:
        kwargs["policy_kwargs"] = resolve(kwargs["policy_kwargs"])
    if cfg.noise_type == "normal":
        n = venv.action_space.shape[0]
        kwargs["action_noise"] = NormalActionNoise(np.zeros(n), cfg.noise_std * np.ones(n))
    return kwargs


def plan_run(
    algo: str,
    env_id: str = "Planar3P-v0",
    seed: int = 0,
    *,
    run_dir: str | Path,
    timesteps: float | None = None,
    n_envs: int | None = None,
    env_kwargs: list[str] | dict[str, Any] | None = None,
    hyperparams: str | Path | None = None,
    params: list[str] | dict[str, Any] | None = None,
    resume: bool = False,
    options: RunOptions | None = None,
    command: str = "",
) -> RunPlan:
    """Validate a run and return its plan; ``ValueError`` on any bad input, nothing written.

    ``env_kwargs`` / ``params`` are ``key=JSON`` / ``key=YAML`` strings (as on the command
    line) or mappings.  With ``resume`` the settings come from the run's ``config.json`` and
    only ``timesteps`` (the new total) and ``options`` apply.
    """
    options = options or RunOptions()
    options.validate()
    algo = str(algo).lower()
    if algo not in ALGORITHMS:
        raise ValueError(f"unknown algorithm {algo!r}; choose one of {', '.join(ALGORITHMS)}")
    if options.kickstart is not None:
        if algo != "ppo":
            raise ValueError("--kickstart is implemented for PPO only")
        if resume:
            raise ValueError("--kickstart applies to a new run, not to --resume")
        from planar3p_agents.policies.factory import PolicyError, parse_policy_spec

        try:
            parse_policy_spec(options.kickstart)
        except PolicyError as exc:
            raise ValueError(f"--kickstart: {exc}") from exc
    run_dir = Path(run_dir)
    resume_from = None
    if resume:
        cfg_path = run_dir / "config.json"
        try:
            saved = json.loads(cfg_path.read_text())
            entry = dict(saved["entry"])
            kwargs_env = dict(saved["config"]["env_kwargs"])
            seed, n_envs = saved["config"]["seed"], saved["config"]["n_envs"]
            env_id = saved["config"]["env_id"]
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise ValueError(f"--resume: cannot read {cfg_path}: {exc}") from exc
        resume_from = latest_checkpoint(run_dir)
    else:
        if run_dir.exists() and (not run_dir.is_dir() or any(run_dir.iterdir())):
            raise ValueError(f"run directory {run_dir} exists; pass --resume or another --run-dir")
        hp_path = Path(hyperparams) if hyperparams else HYPERPARAMS_DIR / f"{algo}.yml"
        _check_env(env_id, {})
        entry = load_hyperparams(hp_path, env_id, algo)
        entry.update(params if isinstance(params, dict) else parse_overrides(params))
        kwargs_env = (
            dict(env_kwargs) if isinstance(env_kwargs, dict) else parse_env_kwargs(env_kwargs)
        )
    cfg = resolve(
        algo, env_id, seed, entry, n_timesteps=timesteps, n_envs=n_envs, env_kwargs=kwargs_env
    )
    _check_env(cfg.env_id, cfg.env_kwargs)
    schedule = _task_schedule(cfg)
    vec_env = vec_env_kind(cfg, options.vec_env)
    model = _check_model(cfg)
    done = resume_from[1] if resume_from else 0
    if cfg.n_timesteps <= done:
        raise ValueError(
            f"nothing to train: the run already has {done} steps and --timesteps is "
            f"{cfg.n_timesteps} (give a larger total)"
        )
    starts = getattr(model, "learning_starts", 0)
    if cfg.algo != "ppo" and cfg.n_timesteps <= starts:
        raise ValueError(
            f"--timesteps {cfg.n_timesteps} would train nothing: {cfg.algo.upper()} starts "
            f"learning after learning_starts = {starts} steps"
        )
    return RunPlan(
        cfg, run_dir, options, resume_from, command, task_schedule=schedule, vec_env=vec_env
    )


def _record_resume(path: Path, total: int, done: int, command: str) -> None:
    """Record a resume in the run's ``config.json``: the new total of timesteps becomes the
    run's ``n_timesteps`` (what the shipped model's rl-zoo3 files give), and ``resumes`` lists
    each resume's starting step, total and command."""
    record = json.loads(path.read_text())
    record["config"]["n_timesteps"] = int(total)
    resume = {"from_step": int(done), "n_timesteps": int(total), "command": command}
    record["resumes"] = [*record.get("resumes", []), resume]
    write_atomic(path, json.dumps(record, indent=2))


def _command_memory(cfg: TrainConfig, venv: Any) -> Any:
    """``venv`` with the command in flight appended to its observation where the policy class
    observes it (:mod:`planar3p_agents.policies.command_memory`), else ``venv``."""
    from planar3p_agents.policies.command_memory import VecCommandMemory, observed_commands

    return VecCommandMemory(venv) if observed_commands(policy_class(cfg.policy)) else venv


def make_envs(cfg: TrainConfig, vec_env: str, stats: Path | None) -> tuple[Any, Any]:
    """The training and the evaluation environments; ``vec_env`` is resolved
    (:func:`vec_env_kind`)."""
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecNormalize

    subproc = vec_env == "subproc"
    factory = EnvFactory(cfg.env_id, cfg.env_kwargs)
    if vec_env == "native":  # episode statistics come from the adapter (no Monitor)
        from planar3p_agents.training.vec_adapter import make_native_vec_env

        venv = make_native_vec_env(cfg.env_id, cfg.n_envs, seed=cfg.seed, env_kwargs=cfg.env_kwargs)
    else:
        venv = make_vec_env(
            factory,
            n_envs=cfg.n_envs,
            seed=cfg.seed,
            vec_env_cls=SubprocVecEnv if subproc else DummyVecEnv,
            monitor_kwargs={"info_keywords": ("is_success",)},
        )
    eval_env = _command_memory(cfg, make_vec_env(factory, n_envs=1, seed=cfg.seed + 10_000))
    venv = _command_memory(cfg, venv)
    if cfg.normalize is not None:
        gamma = cfg.algo_kwargs.get("gamma", 0.99)
        if stats is not None:
            venv = VecNormalize.load(str(stats), venv)
            venv.training = True
        else:
            venv = VecNormalize(venv, gamma=gamma, **cfg.normalize)
        # The evaluation env normalises observations exactly when the training env does.
        norm_obs = bool(cfg.normalize.get("norm_obs", True))
        eval_env = VecNormalize(
            eval_env,
            training=False,
            norm_obs=norm_obs,
            norm_obs_keys=cfg.normalize.get("norm_obs_keys"),  # Dict observations: same keys
            norm_reward=False,
            gamma=gamma,
        )
    return venv, eval_env


def evaluate(
    model: Any, eval_env: Any, episodes: int, progress: str | None = None
) -> dict[str, Any]:
    """Deterministic evaluation with SB3's ``evaluate_policy``: success rate, returns, final
    position error (mm) and orientation error (deg), episode lengths and how episodes ended
    (read from the env's ``info`` at each episode's end). With ``progress`` (its label), a
    progress bar over the episodes on stderr (tqdm)."""
    from stable_baselines3.common.evaluation import evaluate_policy
    from tqdm import tqdm

    ends: list[dict[str, Any]] = []
    bar = tqdm(total=episodes, desc=progress, unit="episode", disable=progress is None)

    def record_end(local: dict[str, Any], _globals: dict[str, Any]) -> None:
        if local["done"]:
            ends.append(local["info"])
            bar.update(1)

    try:
        returns, lengths = evaluate_policy(
            model,
            eval_env,
            n_eval_episodes=episodes,
            deterministic=True,
            return_episode_rewards=True,
            callback=record_end,
            warn=False,
        )
    finally:
        bar.close()
    reasons: dict[str, int] = {}
    for info in ends:
        reason = info.get("termination_reason") or "time_limit"
        reasons[reason] = reasons.get(reason, 0) + 1
    pos = [float(i.get("position_error", np.nan)) for i in ends]
    ang = [float(i.get("orientation_error", np.nan)) for i in ends]
    return {
        "episodes": episodes,
        "success_rate": float(np.mean([bool(i.get("is_success", False)) for i in ends])),
        "mean_return": float(np.mean(returns)),
        "std_return": float(np.std(returns)),
        "median_position_error_mm": float(np.median(pos) * 1000),
        "median_orientation_error_deg": float(np.degrees(np.median(np.abs(ang)))),
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


def _kickstart(plan: RunPlan, model: Any, venv: Any, eval_env: Any) -> dict[str, Any]:
    """Clone the teacher into ``model`` (:mod:`planar3p_agents.training.kickstart`), save and
    evaluate the clone."""
    from stable_baselines3.common.vec_env import VecNormalize, sync_envs_normalization

    from planar3p_agents.policies.factory import load_policy
    from planar3p_agents.training.kickstart import kickstart_ppo

    cfg, opt = plan.cfg, plan.options
    teacher_env = EnvFactory(cfg.env_id, cfg.env_kwargs)()
    teacher = load_policy(opt.kickstart, env=teacher_env, seed=cfg.seed)
    teacher_env.close()
    report = kickstart_ppo(
        model,
        teacher,
        opt.kickstart,
        opt.kickstart_steps,
        epochs=opt.kickstart_epochs,
        log_std=opt.kickstart_log_std,
        seed=cfg.seed,
    )
    # The kick-started policy before any RL, saved and evaluated like the final one.
    model.save(str(plan.run_dir / "kickstart_model.zip"))
    if isinstance(venv, VecNormalize):
        venv.save(str(plan.run_dir / "kickstart_vecnormalize.pkl"))
        sync_envs_normalization(venv, eval_env)
    return {**asdict(report), "evaluation": evaluate(model, eval_env, opt.eval_episodes)}


def execute(plan: RunPlan, status: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Train as planned and write the run directory; returns the metrics (``metrics.json``).
    ``status`` (e.g. ``print``) receives a line at each stage: the environments made, the
    training started, the final evaluation, the end."""
    say = status or (lambda text: None)
    import torch
    from stable_baselines3.common.callbacks import CallbackList, CheckpointCallback, EvalCallback
    from stable_baselines3.common.vec_env import VecNormalize, sync_envs_normalization

    import_rl_zoo3()
    from rl_zoo3.callbacks import SaveVecNormalizeCallback

    cfg, opt, run_dir = plan.cfg, plan.options, plan.run_dir
    torch.set_num_threads(opt.threads)
    algo_cls = algo_class(cfg.algo)
    off_policy = cfg.algo in OFF_POLICY
    checkpoint, done_steps = plan.resume_from or (None, 0)
    stats = None
    if checkpoint is not None:
        candidate = run_dir / checkpoint_path(done_steps, "vecnormalize")
        stats = candidate if candidate.exists() else None
    run_dir.mkdir(parents=True, exist_ok=True)
    kinds = {"native": "native vector env", "subproc": "SubprocVecEnv", "dummy": "DummyVecEnv"}
    say(f"making {cfg.n_envs} training environment(s) ({kinds[plan.vec_env]}) ...")
    venv, eval_env = make_envs(cfg, plan.vec_env, stats)
    if checkpoint is not None:
        model = algo_cls.load(str(checkpoint), env=venv, tensorboard_log=str(run_dir / "tb"))
        buffer = run_dir / checkpoint_path(done_steps, "replay_buffer")
        if off_policy and buffer.exists():
            model.load_replay_buffer(str(buffer))
        _record_resume(run_dir / "config.json", cfg.n_timesteps, done_steps, plan.command)
    else:
        model = algo_cls(
            policy_class(cfg.policy),
            venv,
            seed=cfg.seed,
            verbose=opt.verbose,
            tensorboard_log=str(run_dir / "tb"),
            **model_kwargs(cfg, venv),
        )
        kick = _kickstart(plan, model, venv, eval_env) if opt.kickstart is not None else None
        record = {
            "config": to_jsonable(cfg.to_json()),
            "kickstart": to_jsonable(kick),
            "entry": to_jsonable(cfg.entry),
            "command": plan.command,
            **to_jsonable(plan.extra),
        }
        (run_dir / "config.json").write_text(json.dumps(record, indent=2))
        (run_dir / "versions.json").write_text(json.dumps(versions(), indent=2))

    per_env = max(1, cfg.n_envs)
    evaluator = EvalCallback(
        eval_env,
        callback_on_new_best=SaveVecNormalizeCallback(save_freq=1, save_path=str(run_dir / "best")),
        n_eval_episodes=opt.eval_episodes,
        eval_freq=max(1, opt.eval_freq // per_env),
        log_path=str(run_dir),
        best_model_save_path=str(run_dir / "best"),
        deterministic=True,
        verbose=opt.verbose,
    )
    if checkpoint is not None:
        _restore_learning_curve(evaluator, run_dir / "evaluations.npz", done_steps)
    callback_list = [
        evaluator,
        _checkpoint_callback(CheckpointCallback)(
            save_freq=max(1, opt.checkpoint_freq // per_env),
            save_path=str(run_dir / CHECKPOINT_DIR),
            save_replay_buffer=off_policy,
            save_vecnormalize=True,
        ),
    ]
    if plan.task_schedule is not None:
        from planar3p_agents.training.task_schedule import TaskScheduleCallback

        callback_list.append(TaskScheduleCallback(plan.task_schedule, verbose=opt.verbose))
    callbacks = CallbackList(callback_list)
    say(
        f"training {cfg.n_timesteps - done_steps} steps; an evaluation of {opt.eval_episodes} "
        f"episodes every {opt.eval_freq} steps; run directory {run_dir}"
    )
    start = time.perf_counter()
    with warnings.catch_warnings():
        # SB3's progress bar is tqdm's rich one, which warns "rich is experimental/alpha"
        # on every run: not the user's to act on.
        warnings.filterwarnings("ignore", message="rich is experimental")
        model.learn(
            total_timesteps=cfg.n_timesteps - done_steps,
            callback=callbacks,
            progress_bar=opt.progress_bar,
            reset_num_timesteps=checkpoint is None,
            tb_log_name=cfg.algo.upper(),
        )
    wall = time.perf_counter() - start
    model.save(str(run_dir / "model.zip"))
    if isinstance(venv, VecNormalize):
        venv.save(str(run_dir / "vecnormalize.pkl"))
        sync_envs_normalization(venv, eval_env)  # (no obs_rms with norm_obs=False: skipped)
    say(f"final evaluation: {opt.final_eval_episodes} episodes ...")
    label = "final evaluation" if opt.progress_bar else None
    metrics = {
        "final_evaluation": evaluate(model, eval_env, opt.final_eval_episodes, progress=label),
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
