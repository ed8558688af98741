"""Kick-starting a PPO agent from a teacher policy (behaviour cloning before RL).

``scripts/train.py --kickstart analytic-simultaneous`` uses this: the teacher drives the
training environments (through their ``VecNormalize`` wrapper, so observation and reward
statistics are those PPO will see) for a number of steps; the student's action mean is then
fitted to the teacher's actions and its value function to the discounted returns of those
steps; PPO trains on from there.  The teacher sees the raw observations, so any policy with
SB3's ``predict`` (e.g. :class:`planar3p_agents.controllers.analytic.AnalyticController`) can teach.

Why this is hand-written: neither SB3 nor rl-zoo3 has behaviour cloning, and the ``imitation``
library's BC/DAgger train a policy of their own on its own rollout types; here the PPO model that
will train on is fitted in place (action mean *and* value function), through the very
``VecNormalize`` statistics PPO then uses, so RL starts from the clone without any conversion.

A kick-started policy is *not* a policy learned from scratch; runs record the teacher and
the number of teacher steps in ``config.json``, and the README reports such runs separately.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["KickstartReport", "collect_teacher_data", "kickstart_ppo"]


@dataclass
class KickstartReport:
    """What kick-starting did.

    Attributes:
        teacher: the teacher's specification.
        steps: environment steps labelled by the teacher, all rounds (summed over the envs).
        episodes: episodes the teacher finished.
        teacher_success_rate: fraction of those episodes that succeeded.
        action_mse: final loss of the student's actions: the mean squared error of its action
            mean (normalised units) for continuous actions, the mean negative log-likelihood of
            the teacher's actions (nats) for discrete ones.
        value_mse: final mean squared error of the value function (normalised returns).
    """

    teacher: str
    steps: int
    episodes: int
    teacher_success_rate: float
    action_mse: float
    value_mse: float


def collect_teacher_data(
    venv: Any, teacher: Any, steps: int, gamma: float, driver: Any = None
) -> dict[str, np.ndarray]:
    """Drive ``venv`` (a VecEnv, possibly VecNormalize-wrapped) for ``steps`` vectorised steps
    with ``driver`` (default: the teacher; a student gets the normalised observations), label
    every visited state with the teacher's action; returns normalised observations, teacher
    actions, discounted returns of the driven episodes, and their outcomes."""
    n = venv.num_envs
    obs = venv.reset()
    raw = venv.get_original_obs() if hasattr(venv, "get_original_obs") else obs
    state, starts = None, np.ones(n, dtype=bool)
    observations, actions, rewards, dones = [], [], [], []
    successes: list[bool] = []
    for _ in range(steps):
        action, state = teacher.predict(raw, state=state, episode_start=starts, deterministic=True)
        action = np.clip(np.asarray(action, dtype=np.float32).reshape(n, -1), -1.0, 1.0)
        observations.append(np.asarray(obs, dtype=np.float32))
        actions.append(action)
        if driver is not None:
            action, _ = driver.predict(obs, deterministic=True)
        obs, reward, done, infos = venv.step(action)
        raw = venv.get_original_obs() if hasattr(venv, "get_original_obs") else obs
        rewards.append(np.asarray(reward, dtype=np.float32))
        dones.append(np.asarray(done, dtype=bool))
        starts = np.asarray(done, dtype=bool)
        successes.extend(
            bool(i.get("is_success", False)) for i, d in zip(infos, done, strict=True) if d
        )
    rew = np.array(rewards)
    done_arr = np.array(dones)
    returns = np.zeros_like(rew)
    running = np.zeros(n, dtype=np.float32)
    for t in range(len(rew) - 1, -1, -1):
        running = rew[t] + gamma * running * (~done_arr[t])
        returns[t] = running
    return {
        "obs": np.concatenate(observations),
        "actions": np.concatenate(actions),
        "returns": returns.reshape(-1),
        "successes": np.array(successes, dtype=bool),
    }


def kickstart_ppo(
    model: Any,
    teacher: Any,
    teacher_name: str,
    steps: int,
    epochs: int = 40,
    batch_size: int = 256,
    learning_rate: float = 1e-3,
    log_std: float | None = -1.5,
    seed: int = 0,
    dagger_rounds: int = 2,
) -> KickstartReport:
    """Fit a PPO model's actions and value function to ``steps`` teacher-labelled steps per
    round: one round driven by the teacher, then ``dagger_rounds`` driven by the student.
    Continuous actions fit the action mean (squared error), discrete ones (the on-off motors)
    the teacher's action's probability (cross-entropy)."""
    import torch as th
    from stable_baselines3 import PPO

    if not isinstance(model, PPO):
        raise ValueError("kick-starting is implemented for PPO only")
    from gymnasium import spaces

    per_env = max(1, steps // model.env.num_envs)
    policy = model.policy
    continuous = isinstance(model.action_space, spaces.Box)
    device = policy.device
    params = [p for name, p in policy.named_parameters() if name != "log_std"]
    optimizer = th.optim.Adam(params, lr=learning_rate)
    generator = th.Generator().manual_seed(seed)
    pools: dict[str, list[np.ndarray]] = {"obs": [], "actions": [], "returns": []}
    teacher_successes = np.zeros(0, dtype=bool)
    action_mse = value_mse = float("nan")
    # Round 0: the teacher drives.  Later rounds (DAgger): the student drives and the teacher
    # labels the states the student actually visits, so the student learns to recover.
    for round_ in range(1 + dagger_rounds):
        data = collect_teacher_data(
            model.env, teacher, per_env, model.gamma, driver=None if round_ == 0 else model
        )
        if round_ == 0:
            teacher_successes = data["successes"]
        for key in pools:
            pools[key].append(data[key])
        obs = th.as_tensor(np.concatenate(pools["obs"]), device=device)
        act = th.as_tensor(np.concatenate(pools["actions"]), device=device)
        ret = th.as_tensor(np.concatenate(pools["returns"]), device=device)
        n = len(obs)
        for _ in range(epochs):
            order = th.randperm(n, generator=generator)
            a_sum = v_sum = 0.0
            for start in range(0, n, batch_size):
                idx = order[start : start + batch_size].to(device)
                if continuous:  # the action mean onto the teacher's actions
                    mean = policy.get_distribution(obs[idx]).distribution.mean
                    values = policy.predict_values(obs[idx]).flatten()
                    a_loss = th.mean((mean - act[idx]) ** 2)
                else:  # discrete actions: the teacher's action made likely (cross-entropy)
                    values, log_prob, _ = policy.evaluate_actions(obs[idx], act[idx])
                    values = values.flatten()
                    a_loss = -th.mean(log_prob)
                v_loss = th.mean((values - ret[idx]) ** 2)
                optimizer.zero_grad()
                (a_loss + 0.5 * v_loss).backward()
                optimizer.step()
                a_sum += float(a_loss.detach()) * len(idx)
                v_sum += float(v_loss.detach()) * len(idx)
            action_mse, value_mse = a_sum / n, v_sum / n
    if log_std is not None and hasattr(policy, "log_std"):
        with th.no_grad():
            policy.log_std.fill_(log_std)
    successes = teacher_successes
    return KickstartReport(
        teacher=teacher_name,
        steps=int(per_env * model.env.num_envs * (1 + dagger_rounds)),
        episodes=int(len(successes)),
        teacher_success_rate=float(successes.mean()) if len(successes) else float("nan"),
        action_mse=action_mse,
        value_mse=value_mse,
    )
