"""scripts/train.py: smoke trainings, run directories, reload, resume and bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from bench_helpers import assert_plays_one_episode
from script_loader import command

from planar3p_agents.training import config as training
from planar3p_agents.training.checkpoints import prune_replay_buffers

train_script = command("train")

SMOKE = {
    "ppo": ["n_steps=64", "batch_size=64", "n_epochs=1"],
    "sac": ["learning_starts=64", "batch_size=32", "buffer_size=1000"],
    "td3": ["learning_starts=64", "batch_size=32", "buffer_size=1000"],
}


def _smoke_args(algo: str, run_dir: Path, steps: int = 256, extra: list[str] | None = None):
    return [
        "--algo",
        algo,
        "--timesteps",
        str(steps),
        "--run-dir",
        str(run_dir),
        "--n-envs",
        "1",
        "--eval-freq",
        "128",
        "--eval-episodes",
        "1",
        "--final-eval-episodes",
        "2",
        "--checkpoint-freq",
        "128",
        "--no-progress-bar",
        "--params",
        *SMOKE[algo],
        *(extra or []),
    ]


@pytest.mark.parametrize("algo", ["ppo", "sac", "td3"])
def test_smoke_training_writes_complete_loadable_run(algo: str, tmp_path: Path) -> None:
    from stable_baselines3 import PPO, SAC, TD3
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    run = tmp_path / algo
    assert train_script.main(_smoke_args(algo, run)) == 0
    for name in ("model.zip", "config.json", "versions.json", "metrics.json", "evaluations.npz"):
        assert (run / name).is_file(), name
    assert (run / "vecnormalize.pkl").is_file()  # every shipped config normalises
    # the best model and its statistics (rl-zoo3's SaveVecNormalizeCallback) side by side
    assert (run / "best" / "best_model.zip").is_file()
    assert (run / "best" / "vecnormalize.pkl").is_file()
    assert any((run / "checkpoints").glob("rl_model_*_steps.zip"))
    assert any((run / "tb").iterdir())
    config = json.loads((run / "config.json").read_text())
    assert config["config"]["algo"] == algo and config["config"]["seed"] == 0
    assert "train.py" in config["command"] or config["command"]
    metrics = json.loads((run / "metrics.json").read_text())
    assert metrics["timesteps"] >= 256
    assert 0.0 <= metrics["final_evaluation"]["success_rate"] <= 1.0
    assert metrics["steps_per_s"] > 0

    # The saved model reloads and acts exactly as the trained one did.
    cls = {"ppo": PPO, "sac": SAC, "td3": TD3}[algo]
    model = cls.load(str(run / "model.zip"), device="cpu")
    venv = DummyVecEnv([training.EnvFactory("Planar3P-v0")])
    stats = VecNormalize.load(str(run / "vecnormalize.pkl"), venv)
    stats.training = False
    obs = stats.normalize_obs(venv.reset())
    a1, _ = model.predict(obs, deterministic=True)
    again = cls.load(str(run / "model.zip"), device="cpu")
    a2, _ = again.predict(obs, deterministic=True)
    np.testing.assert_array_equal(a1, a2)
    assert a1.shape == (1, 3) and np.all(np.abs(a1) <= 1.0)


def test_dqn_trains_on_the_on_off_machine_and_the_benchmark_plays_it(tmp_path: Path, bench) -> None:
    """DQN on the Discrete(27) on-off machine, end to end: a complete run,
    and the benchmark plays the model on the real-on-off suite (MultiDiscrete) in the suite's
    environment made with the model's action encoding."""
    run = tmp_path / "dqn"
    argv = _smoke_args("ppo", run, steps=256)
    argv[argv.index("ppo")] = "dqn"
    argv = argv[: argv.index("--params")] + [
        "--env",
        "Planar3PRealOnOff-v0",
        "--env-kwargs",
        'action_type="on-off-discrete"',
        "--params",
        "learning_starts=64",
        "batch_size=32",
        "buffer_size=1000",
    ]
    assert train_script.main(argv) == 0
    config = json.loads((run / "config.json").read_text())
    assert config["config"]["algo"] == "dqn"
    assert config["config"]["env_kwargs"] == {"action_type": "on-off-discrete"}
    assert_plays_one_episode(bench, run, tmp_path / "bench", algo="dqn:")


def test_resume_continues_from_last_checkpoint(tmp_path: Path) -> None:
    run = tmp_path / "ppo"
    assert train_script.main(_smoke_args("ppo", run, steps=256)) == 0
    first = np.load(run / "evaluations.npz")["timesteps"].tolist()
    args = _smoke_args("ppo", run, steps=512) + ["--resume"]
    assert train_script.main(args) == 0
    curve = np.load(run / "evaluations.npz")["timesteps"].tolist()
    assert curve[: len(first)] == first and curve[-1] > first[-1]  # the curve continues
    metrics = json.loads((run / "metrics.json").read_text())
    assert metrics["resumed_from"] == 256
    assert metrics["timesteps"] >= 512
    assert metrics["previous_sessions"]["timesteps"] >= 256
    record = json.loads((run / "config.json").read_text())  # the run's total is the new one
    assert record["config"]["n_timesteps"] == 512
    (resume,) = record["resumes"]
    assert resume["from_step"] == 256 and resume["n_timesteps"] == 512
    assert "--resume" in resume["command"] and "--timesteps 256" in record["command"]


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--algo", "a2c"], "unknown algorithm"),
        (["--algo", "dqn"], "has no entry for 'Planar3P-v0'"),
        (["--algo", "dqn", "--env", "Planar3PRealOnOff-v0"], "DQN needs a Discrete action space"),
        (["--algo", "sac", "--env", "NoSuchEnv-v9"], "unknown environment id"),
        (["--algo", "sac", "--hyperparams", "/nonexistent.yml"], "does not exist"),
        (["--algo", "sac", "--env-kwargs", "substeps=0"], "invalid environment kwargs"),
        (["--algo", "sac", "--params", "noise_type=ou"], "noise_type"),
    ],
)
def test_bad_input_fails_before_training(argv, message, tmp_path: Path, capsys) -> None:
    run = tmp_path / "run"
    assert train_script.main([*argv, "--run-dir", str(run)]) == 2
    assert message in capsys.readouterr().err
    assert not run.exists()


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--algo", "ppo", "--params", "nosuch=1"], "no hyperparameter nosuch"),
        (["--algo", "ppo", "--params", "learning_rate=abc"], "learning_rate must be a number"),
        (["--algo", "td3", "--params", "policy_kwargs=[1,2]"], "policy_kwargs must be a mapping"),
        (["--algo", "sac", "--params", "batch_size=abc"], "batch_size must be an integer"),
        (["--algo", "sac", "--params", "buffer_size=0"], "buffer_size must be at least 1"),
        (["--algo", "ppo", "--timesteps", "1e400"], "n_timesteps must be a whole number"),
        (["--algo", "ppo", "--timesteps", "0"], "n_timesteps must be a whole number"),
        (["--algo", "ppo", "--eval-freq", "0"], "--eval-freq must be a positive integer"),
        (["--algo", "ppo", "--checkpoint-freq", "-1"], "--checkpoint-freq must be a positive"),
        (["--algo", "ppo", "--eval-episodes", "-1"], "--eval-episodes must be a positive"),
        (["--algo", "ppo", "--final-eval-episodes", "0"], "--final-eval-episodes must be"),
        (["--algo", "ppo", "--threads", "0"], "--threads must be a positive integer"),
        (["--algo", "ppo", "--seed", "-1"], "seed must be between 0"),
        (["--algo", "ppo", "--n-envs", "0"], "n_envs must be a whole number"),
        (["--algo", "td3", "--timesteps", "5000"], "would train nothing"),
        (["--algo", "sac", "--timesteps", "300", "--params", "learning_starts=300"], "nothing"),
    ],
)
def test_crash_paths_exit_2_with_one_line_and_write_nothing(
    argv, message, tmp_path: Path, capsys
) -> None:
    """Each of these used to raise a traceback, leave an empty run directory
    behind, or be accepted (512 checkpoints for --checkpoint-freq -1)."""
    run = tmp_path / "run"
    assert train_script.main([*argv, "--run-dir", str(run)]) == 2
    err = capsys.readouterr().err
    assert message in err and (": error: " in err) and err.count("\n") == 1, err
    assert not run.exists()


def test_native_vector_env_trains(tmp_path: Path) -> None:
    """--vec-env native (H1's adapter over the native vector env): a complete run."""
    run = tmp_path / "native"
    args = _smoke_args("ppo", run, steps=128) + ["--vec-env", "native"]
    args[args.index("--n-envs") + 1] = "2"
    assert train_script.main(args) == 0
    metrics = json.loads((run / "metrics.json").read_text())
    assert metrics["timesteps"] == 128 and (run / "vecnormalize.pkl").is_file()


def test_native_vector_env_serves_every_id() -> None:
    """``--vec-env native`` takes every registered id (the goal ids' ``Dict`` observations
    included): the SB3 adapter is made, reset and stepped."""
    from planar3p_agents.training.vec_adapter import make_native_vec_env
    from planar3p_gym.envs.registry import ENV_SPECS

    for row in ENV_SPECS:
        venv = make_native_vec_env(row.id, n_envs=2, seed=0)
        venv.reset()
        venv.step(np.array([venv.action_space.sample() for _ in range(2)]))
        venv.close()


def test_an_empty_run_directory_does_not_block_a_run(tmp_path: Path) -> None:
    from planar3p_agents.training.run import plan_run

    run = tmp_path / "run"
    run.mkdir()
    plan = plan_run("ppo", run_dir=run, timesteps=64, params=SMOKE["ppo"], n_envs=1)
    assert plan.cfg.n_timesteps == 64 and plan.run_dir == run and not any(run.iterdir())


def test_resume_refuses_a_total_already_reached(tmp_path: Path, capsys) -> None:
    run = tmp_path / "ppo"
    assert train_script.main(_smoke_args("ppo", run, steps=128)) == 0
    before = sorted(p.name for p in run.iterdir())
    args = _smoke_args("ppo", run, steps=128) + ["--resume"]
    assert train_script.main(args) == 2
    assert "nothing to train" in capsys.readouterr().err
    assert sorted(p.name for p in run.iterdir()) == before


def test_rl_zoo3_import_keeps_gymnasiums_time_limit() -> None:
    """rl-zoo3 replaces gymnasium's TimeLimit on import; training must not change episodes."""
    import gymnasium as gym

    original = gym.wrappers.TimeLimit
    training.import_rl_zoo3()
    assert gym.wrappers.TimeLimit is original
    env = gym.make("Planar3P-v0")
    assert type(env).__name__ == "TimeLimit" and type(env) is original
    env.close()


def test_existing_run_dir_without_resume_is_refused(tmp_path: Path, capsys) -> None:
    run = tmp_path / "run"
    run.mkdir()
    (run / "keep.txt").write_text("precious")
    assert train_script.main(["--algo", "sac", "--run-dir", str(run)]) == 2
    assert "exists" in capsys.readouterr().err
    assert (run / "keep.txt").read_text() == "precious"


def test_unreadable_config_is_a_clear_error(tmp_path: Path, capsys) -> None:
    bad = tmp_path / "bad.yml"
    bad.write_text("Planar3P-v0: [unclosed\n")
    assert (
        train_script.main(
            ["--algo", "sac", "--hyperparams", str(bad), "--run-dir", str(tmp_path / "r")]
        )
        == 2
    )
    assert "cannot read" in capsys.readouterr().err


def test_shipped_hyperparameters_resolve() -> None:
    """Every entry of every shipped file, for a registered id."""
    import gymnasium as gym
    import yaml

    for path in sorted(training.HYPERPARAMS_DIR.glob("*.yml")):
        algo = path.stem.split("_")[0]
        assert algo in training.ALGORITHMS, path.name
        for env_id in yaml.safe_load(path.read_text()):
            assert env_id in gym.registry, (path.name, env_id)
            entry = training.load_hyperparams(path, env_id, algo)
            cfg = training.resolve(algo, env_id, 0, entry)
            assert cfg.n_timesteps > 0 and cfg.n_envs >= 1, (path.name, env_id)
            assert isinstance(cfg.algo_kwargs.get("policy_kwargs"), dict), (path.name, env_id)


def test_her_and_tqc_entries_resolve_to_sb3_classes() -> None:
    from stable_baselines3 import HerReplayBuffer

    from planar3p_agents.training.her import CompactHerReplayBuffer

    for algo in ("sac", "tqc"):
        entry = training.load_hyperparams(
            training.HYPERPARAMS_DIR / f"{algo}.yml", "Planar3PGoal-v0", algo
        )
        cfg = training.resolve(algo, "Planar3PGoal-v0", 0, entry)
        assert cfg.algo_kwargs["replay_buffer_class"] is CompactHerReplayBuffer
        assert issubclass(CompactHerReplayBuffer, HerReplayBuffer)
        assert cfg.algo_kwargs["replay_buffer_kwargs"]["goal_selection_strategy"] == "future"
        assert cfg.policy == "MultiInputPolicy"
    # SB3's own buffer by its name, as rl-zoo3's files write it
    cfg = training.resolve("sac", "Planar3PGoal-v0", 0, {"replay_buffer_class": "HerReplayBuffer"})
    assert cfg.algo_kwargs["replay_buffer_class"] is HerReplayBuffer
    entry = {"replay_buffer_class": "HerReplayBuffer"}
    with pytest.raises(ValueError, match="off-policy"):
        training.resolve("ppo", "Planar3PGoal-v0", 0, entry)
    with pytest.raises(ValueError, match="replay_buffer_class must be one of"):
        training.resolve("sac", "Planar3PGoal-v0", 0, {"replay_buffer_class": "os.system"})
    with pytest.raises(ValueError, match="replay_buffer_class must be one of"):
        training.resolve("sac", "Planar3PGoal-v0", 0, {"replay_buffer_class": ["HerReplayBuffer"]})
    with pytest.raises(ValueError, match="replay_buffer_kwargs must be a mapping"):
        training.resolve("sac", "Planar3PGoal-v0", 0, {"replay_buffer_kwargs": "[1, 2]"})


def test_an_entry_names_the_environment_arguments_of_its_recipe() -> None:
    """``env_kwargs`` in a YAML entry (a dict string or a mapping) become the run's environment
    arguments, the command line's override them entry by entry, and anything but a mapping of
    names is refused before a run starts."""
    entry = {"env_kwargs": "dict(observe_working_mode=True, max_speed=0.2)"}
    cfg = training.resolve("sac", "Planar3PGoal-v0", 0, entry)
    assert cfg.env_kwargs == {"observe_working_mode": True, "max_speed": 0.2}
    cfg = training.resolve("sac", "Planar3PGoal-v0", 0, entry, env_kwargs={"max_speed": 0.25})
    assert cfg.env_kwargs == {"observe_working_mode": True, "max_speed": 0.25}
    assert "env_kwargs" not in cfg.algo_kwargs  # not an SB3 argument
    for bad in ("[1, 2]", {1: 2}, 3):
        with pytest.raises(ValueError, match="env_kwargs must be a mapping"):
            training.resolve("sac", "Planar3PGoal-v0", 0, {"env_kwargs": bad})


def test_her_training_on_the_goal_env_runs_and_resumes(tmp_path: Path) -> None:
    """SAC + HER through scripts/train.py on Planar3PGoal-v0, then --resume with its buffer."""
    run = tmp_path / "her"
    small = [
        "learning_starts=100",
        "batch_size=32",
        "buffer_size=2000",
        "policy_kwargs={net_arch: [32]}",
    ]

    def args(steps: int) -> list[str]:
        return [
            "--algo", "sac", "--env", "Planar3PGoal-v0", "--timesteps", str(steps),
            "--run-dir", str(run), "--eval-freq", "150", "--eval-episodes", "1",
            "--final-eval-episodes", "1", "--checkpoint-freq", "150", "--no-progress-bar",
            "--n-envs", "1",  # HER samples after one whole episode: 100 steps, not 4 x 100
            "--params", *small,
        ]  # fmt: skip

    assert train_script.main(args(300)) == 0
    config = json.loads((run / "config.json").read_text())
    assert "HerReplayBuffer" in json.dumps(config["config"]["algo_kwargs"])
    checkpoints = run / "checkpoints"
    # every checkpoint's model, only the newest replay buffer (what a resume loads)
    assert {p.name for p in checkpoints.glob("rl_model_replay_buffer_*")} == {
        "rl_model_replay_buffer_300_steps.pkl"
    }
    assert (checkpoints / "rl_model_150_steps.zip").is_file()
    assert train_script.main([*args(450), "--resume"]) == 0
    metrics = json.loads((run / "metrics.json").read_text())
    assert metrics["resumed_from"] == 300 and metrics["timesteps"] >= 450
    assert {p.name for p in checkpoints.glob("rl_model_replay_buffer_*")} == {
        "rl_model_replay_buffer_450_steps.pkl"
    }


def test_pruning_keeps_the_newest_replay_buffer_and_every_model(tmp_path: Path) -> None:
    """Buffers are ordered by step count (not by name: 1000 after 150), other files stay."""
    folder = tmp_path / "checkpoints"
    folder.mkdir()
    names = [
        "rl_model_replay_buffer_150_steps.pkl",
        "rl_model_replay_buffer_1000_steps.pkl",
        "rl_model_replay_buffer_300_steps.pkl",
        "rl_model_150_steps.zip",
        "rl_model_vecnormalize_150_steps.pkl",
        "rl_model_replay_buffer_old.pkl",  # not a checkpoint's: left alone
    ]
    for name in names:
        (folder / name).write_bytes(b"x")
    deleted = prune_replay_buffers(tmp_path)
    assert sorted(p.name for p in deleted) == [names[0], names[2]]
    assert sorted(p.name for p in folder.iterdir()) == sorted(names[1:2] + names[3:])
    assert prune_replay_buffers(tmp_path) == []  # nothing left to prune
    assert prune_replay_buffers(tmp_path / "no-run") == []


def test_zoo_strings_are_parsed_safely() -> None:
    import torch.nn as nn

    kwargs = training._literal(
        "dict(net_arch=dict(pi=[64, 64]), activation_fn=nn.Tanh, x=-1.5)", "t"
    )
    assert kwargs == {"net_arch": {"pi": [64, 64]}, "activation_fn": nn.Tanh, "x": -1.5}
    with pytest.raises(ValueError, match="unsupported"):
        training._literal("__import__('os').system('true')", "t")
    schedule = training._schedule("lin_3e-4", "learning_rate")
    assert schedule(1.0) == pytest.approx(3e-4) and schedule(0.5) == pytest.approx(1.5e-4)
    assert type(schedule).__module__ == "rl_zoo3.utils"  # rl-zoo3's own schedule
    for bad in ("abc", "lin_x", "lin_nan", float("inf"), True, [1]):
        with pytest.raises(ValueError):
            training._schedule(bad, "learning_rate")


def test_kickstart_clones_the_teacher_before_rl(tmp_path: Path) -> None:
    """A tiny kick-start: the run records the teacher and its evaluation, saves the cloned
    policy, and the clone imitates the teacher far better than the untrained network."""
    from stable_baselines3 import PPO

    from planar3p_agents.policies.factory import load_policy
    from planar3p_agents.training.kickstart import collect_teacher_data

    run = tmp_path / "ks"
    args = _smoke_args("ppo", run, steps=128)
    args += ["--kickstart", "analytic-simultaneous", "--kickstart-steps", "1500"]
    args += ["--kickstart-epochs", "20"]
    assert train_script.main(args) == 0
    record = json.loads((run / "config.json").read_text())["kickstart"]
    assert record["teacher"] == "analytic-simultaneous"
    assert record["steps"] >= 1500 and record["teacher_success_rate"] > 0.9
    assert 0.0 <= record["evaluation"]["success_rate"] <= 1.0
    assert (run / "kickstart_model.zip").is_file() and (
        run / "kickstart_vecnormalize.pkl"
    ).is_file()

    # Imitation error of the cloned policy vs a fresh network, on teacher-visited states.
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    venv = VecNormalize.load(
        str(run / "kickstart_vecnormalize.pkl"), DummyVecEnv([training.EnvFactory("Planar3P-v0")])
    )
    venv.training = False
    venv.seed(123)  # the imitation check's episodes are fixed (the test is deterministic)
    teacher = load_policy("analytic-simultaneous", env=venv.envs[0], seed=123)
    data = collect_teacher_data(venv, teacher, 200, gamma=0.99)
    clone = PPO.load(str(run / "kickstart_model.zip"), device="cpu")
    fresh = PPO("MlpPolicy", venv, seed=0, device="cpu")
    err_clone = np.mean((clone.predict(data["obs"], deterministic=True)[0] - data["actions"]) ** 2)
    err_fresh = np.mean((fresh.predict(data["obs"], deterministic=True)[0] - data["actions"]) ** 2)
    assert err_clone < 0.5 * err_fresh


def test_kickstart_clones_an_on_off_teacher(tmp_path: Path) -> None:
    """Discrete actions (the on-off motors, MultiDiscrete): the clone is fitted by
    cross-entropy to the on-off controller's commands and then picks the teacher's command
    for most motors, where the untrained network agrees about as often as chance (1/3)."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from planar3p_agents.policies.factory import load_policy
    from planar3p_agents.training.kickstart import collect_teacher_data

    env_id = "Planar3PRealOnOff-v0"
    run = tmp_path / "ks-on-off"
    args = _smoke_args("ppo", run, steps=128) + ["--env", env_id]
    args += ["--kickstart", "analytic-on-off", "--kickstart-steps", "1500"]
    args += ["--kickstart-epochs", "20"]
    assert train_script.main(args) == 0
    record = json.loads((run / "config.json").read_text())["kickstart"]
    assert record["teacher"] == "analytic-on-off" and record["steps"] >= 1500
    venv = VecNormalize.load(
        str(run / "kickstart_vecnormalize.pkl"), DummyVecEnv([training.EnvFactory(env_id)])
    )
    venv.training = False
    venv.seed(123)
    teacher = load_policy("analytic-on-off", env=venv.envs[0], seed=123)
    data = collect_teacher_data(venv, teacher, 300, gamma=0.99)
    clone = PPO.load(str(run / "kickstart_model.zip"), device="cpu")
    fresh = PPO("MlpPolicy", venv, seed=0, device="cpu")
    agree_clone = np.mean(clone.predict(data["obs"], deterministic=True)[0] == data["actions"])
    agree_fresh = np.mean(fresh.predict(data["obs"], deterministic=True)[0] == data["actions"])
    assert agree_clone > 0.5 and agree_clone > agree_fresh + 0.25  # measured: 0.64 and 0.27


def test_kickstart_with_reward_normalisation_only(tmp_path: Path) -> None:
    """Statistics without observation normalisation (``norm_obs=False``, as the residual
    tracking recipe uses) have no ``obs_rms``: the kick-start's evaluation and the final one
    still run (they used to fail on the missing attribute)."""
    run = tmp_path / "ks-reward-only"
    args = _smoke_args("ppo", run, steps=128)
    args += ["--params", 'normalize="dict(norm_obs=False, norm_reward=True)"']
    args += ["--kickstart", "analytic-simultaneous", "--kickstart-steps", "300"]
    args += ["--kickstart-epochs", "2"]
    assert train_script.main(args) == 0
    record = json.loads((run / "config.json").read_text())["kickstart"]
    assert 0.0 <= record["evaluation"]["success_rate"] <= 1.0
    metrics = json.loads((run / "metrics.json").read_text())
    assert metrics["final_evaluation"]["episodes"] >= 1
    assert (run / "kickstart_vecnormalize.pkl").is_file() and (run / "vecnormalize.pkl").is_file()


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--algo", "sac", "--kickstart", "analytic-simultaneous"], "PPO only"),
        (["--algo", "ppo", "--kickstart", "no-such-teacher"], "--kickstart"),
    ],
)
def test_kickstart_bad_input(extra, message, tmp_path: Path, capsys) -> None:
    assert train_script.main([*extra, "--run-dir", str(tmp_path / "r")]) == 2
    assert message in capsys.readouterr().err


def test_overrides_read_exponent_floats() -> None:
    out = training.parse_overrides(["learning_rate=2e-5", "n_epochs=5", "ent_coef=auto"])
    assert out == {"learning_rate": 2e-5, "n_epochs": 5, "ent_coef": "auto"}
    with pytest.raises(ValueError, match="key=value"):
        training.parse_overrides(["no_equals_sign"])


def test_final_evaluation_matches_a_plain_rollout() -> None:
    """planar3p_agents.training.run.evaluate (SB3's evaluate_policy + the env's info at each
    episode's end) reports what a plain deterministic rollout of the same seeded episodes
    measures."""
    from stable_baselines3.common.env_util import make_vec_env

    from planar3p_agents.policies.factory import load_policy
    from planar3p_agents.training.run import evaluate

    factory = training.EnvFactory("Planar3P-v0")
    policy = load_policy("analytic-simultaneous", env=factory())
    got = evaluate(policy, make_vec_env(factory, n_envs=1, seed=5), episodes=4)

    env = make_vec_env(factory, n_envs=1, seed=5)
    obs = env.reset()
    returns, lengths, success, pos = [], [], [], []
    ret, length = 0.0, 0
    while len(returns) < 4:
        obs, reward, done, infos = env.step(policy.predict(obs, deterministic=True)[0])
        ret, length = ret + float(reward[0]), length + 1
        if done[0]:
            returns.append(ret)
            lengths.append(length)
            success.append(bool(infos[0]["is_success"]))
            pos.append(infos[0]["position_error"])
            ret, length = 0.0, 0
    assert got["episodes"] == 4
    assert got["success_rate"] == np.mean(success)
    # Monitor rounds episode returns to 6 digits
    assert got["mean_return"] == pytest.approx(np.mean(returns), abs=1e-5)
    assert got["mean_episode_length"] == np.mean(lengths)
    assert got["median_position_error_mm"] == pytest.approx(np.median(pos) * 1000, rel=1e-12)
    assert sum(got["end_reasons"].values()) == 4


@pytest.mark.parametrize(
    ("env_id", "n_envs", "choice", "kind"),
    [
        ("Planar3P-v0", 4, "auto", "native"),  # the id has a native vector env
        ("Planar3PModeChange-v0", 1, "auto", "native"),
        ("Planar3PGoal-v0", 4, "auto", "native"),  # Dict observations too
        ("Planar3PGoal-v0", 1, "auto", "native"),
        ("Planar3PRealOnOff-v0", 4, "auto", "native"),  # MultiDiscrete: the same spaces
        ("Planar3PRealOnOff-v0", 4, "auto-discrete", "native"),  # one Discrete index per env
        ("Planar3P-v0", 4, "subproc", "subproc"),  # an explicit choice stands
        ("Planar3P-v0", 4, "dummy", "dummy"),
    ],
)
def test_auto_picks_the_native_vector_env_where_the_id_has_one(env_id, n_envs, choice, kind):
    from types import SimpleNamespace

    from planar3p_agents.training.run import vec_env_kind

    kwargs = {"action_type": "on-off-discrete"} if choice == "auto-discrete" else {}
    cfg = SimpleNamespace(env_id=env_id, env_kwargs=kwargs, n_envs=n_envs)
    assert vec_env_kind(cfg, choice.split("-")[0]) == kind


def test_a_run_says_what_it_does_from_the_start(tmp_path: Path, capsys, monkeypatch) -> None:
    """The first status line comes before the run is planned (the checks build environments
    and a model, seconds of silence); then a line per stage, and the final evaluation shows a
    progress bar over its episodes."""
    from planar3p_agents.training import run as run_module

    def refuse(*args, **kwargs):
        raise ValueError("stopped for the test")

    with monkeypatch.context() as m:
        m.setattr(run_module, "plan_run", refuse)
        assert train_script.main(_smoke_args("ppo", tmp_path / "a", steps=64)) == 2
    out, err = capsys.readouterr()
    assert out.startswith("planar3p train: PPO on Planar3P-v0, seed 0: checking"), out
    assert err.count("\n") == 1  # bad input: one line on stderr, as ever

    args = [a for a in _smoke_args("ppo", tmp_path / "b", steps=64) if a != "--no-progress-bar"]
    assert train_script.main(args) == 0
    out, err = capsys.readouterr()
    stages = ["checking", "training environment(s) (native vector env)", "training 64 steps"]
    stages += ["final evaluation: 2 episodes"]
    at = [out.find(s) for s in stages]
    assert -1 not in at and at == sorted(at), out
    assert "2/2" in err  # the final evaluation's bar
