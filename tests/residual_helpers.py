"""Helpers shared by the residual-policy tests (tests/agents/controllers/test_residual_*.py): a
tiny PPO model of a residual policy, the checks every residual policy must pass whatever its
base controller, and a complete tiny training run of a shipped recipe."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch as th
from script_loader import command
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import DummyVecEnv

from planar3p_gym.tasks.observation import SLICES


def residual_model(
    policy: type, env_id: str, scale: float, log_std: float, **policy_kwargs: Any
) -> PPO:
    """An untrained PPO model of the residual ``policy`` class on ``env_id`` (seed 0, CPU)."""
    venv = DummyVecEnv([lambda: gym.make(env_id)])
    return PPO(
        policy,
        venv,
        n_steps=64,
        batch_size=64,
        seed=0,
        device="cpu",
        policy_kwargs={"residual_scale": scale, "log_std_init": log_std, **policy_kwargs},
    )


def assert_correction_bounded(model: PPO, base: Any, obs: np.ndarray, scale: float) -> None:
    """Whatever the head outputs, the deterministic action stays within ``scale`` of the base
    controller's (tanh), and a large head reaches that bound."""
    with th.no_grad():
        model.policy.action_net.weight.normal_(0.0, 50.0)
        model.policy.action_net.bias.fill_(3.0)
    diff = np.abs(model.predict(obs, deterministic=True)[0] - base.predict(obs)[0])
    assert diff.max() <= scale + 1e-6
    assert diff.max() > 0.9 * scale


def assert_round_trip(model: PPO, policy: type, obs: np.ndarray, path: Path) -> PPO:
    """Saved and loaded, the model is the same residual policy and acts the same; returns the
    loaded model."""
    with th.no_grad():
        model.policy.action_net.weight.normal_(0.0, 1.0)
    model.save(path)
    loaded = PPO.load(path, device="cpu")
    assert isinstance(loaded.policy, policy)
    assert loaded.policy.residual_scale == model.policy.residual_scale
    np.testing.assert_array_equal(
        loaded.predict(obs, deterministic=True)[0], model.predict(obs, deterministic=True)[0]
    )
    return loaded


def observation_with_errors(
    env: gym.Env, dx: float, dy: float, arc: float
) -> tuple[np.ndarray, th.Tensor]:
    """The seed-0 observation of ``env`` (float64) with its position error set to ``(dx, dy)``
    (m) and its orientation error to ``arc / L_ref`` (rad), and the same as a ``(1, n)``
    float32 tensor for a features extractor."""
    obs, _ = env.reset(seed=0)
    x = np.asarray(obs, dtype=np.float64).copy()
    x[SLICES["position_error"]] = (dx, dy)
    x[SLICES["orientation_error"]] = arc / env.unwrapped.design.characteristic_length
    return x, th.as_tensor(x[None], dtype=th.float32)


#: ``scripts/train.py`` flags of a tiny complete run (128 steps, one evaluation and checkpoint).
TINY_RUN_ARGS = (
    "--n-envs", "2", "--timesteps", "128",
    "--eval-freq", "128", "--eval-episodes", "1", "--final-eval-episodes", "1",
    "--checkpoint-freq", "128", "--no-progress-bar",
    "--params", "n_steps=64", "batch_size=64", "n_epochs=1",
)  # fmt: skip


def assert_trains_shipped_entry(run: Path, env_id: str, hyperparams: Path, policy: type) -> None:
    """``scripts/train.py`` with ``env_id``'s entry of ``hyperparams`` (native vector env,
    :data:`TINY_RUN_ARGS`) into ``run``: the run completes, records ``policy`` and saves a model
    of it whose statistics normalise rewards only."""
    from planar3p_agents.policies.factory import load_policy

    argv = [
        "--algo", "ppo", "--env", env_id, "--hyperparams", str(hyperparams),
        "--vec-env", "native", "--run-dir", str(run), *TINY_RUN_ARGS,
    ]  # fmt: skip
    assert command("train").main(argv) == 0
    config = json.loads((run / "config.json").read_text())["config"]
    assert config["policy"] == policy.__name__
    model = PPO.load(run / "model.zip", device="cpu")
    assert isinstance(model.policy, policy)
    stats = f"{run / 'model.zip'}:stats={run / 'vecnormalize.pkl'}"
    assert not load_policy(stats, env=gym.make(env_id)).vecnormalize.norm_obs


def saved_with_correction(
    policy: type, env_id: str, scale: float, path: Path, bias: tuple[float, float, float]
) -> tuple[PPO, np.ndarray]:
    """An untrained :func:`residual_model` of ``policy`` with a correction of the constant
    ``bias`` of the pose reading (m, m, rad) named by its JSON file, saved under ``path`` and
    loaded back after the file is deleted; returns the loaded model and the weights, which it
    must hold itself."""
    from planar3p_agents.controllers.pose_correction import PoseCorrection

    weights = np.zeros((14, 3))
    weights[-1] = bias
    PoseCorrection(weights).save(path / "c.json")
    kwargs = policy.resolve_policy_kwargs({"correction": str(path / "c.json")})
    residual_model(policy, env_id, scale, -2.5, **kwargs).save(path / "m.zip")
    (path / "c.json").unlink()
    loaded = PPO.load(path / "m.zip", device="cpu")
    np.testing.assert_array_equal(loaded.policy.correction, weights)
    return loaded, weights
