"""Fixed benchmark suites for the task ids (goal-conditioned reach, tracking, mode change,
assembly change, the built machine), and the baseline policies of each.

Episode ``i`` of a task suite is the environment's own draw after ``reset(seed=s_i)``, ``s_i``
derived from the suite's seed, name and ``i`` alone, saved as its episode spec and replayed
(the task contract); the built machine's suites also draw each episode's machine at the
benchmark's reset.  The suites in detail: docs/benchmark.md, "How the suite and score modules
work".

* :data:`TASK_SUITES`, :class:`TaskSuiteDef`: the suites (id, arguments, default baselines of
  :data:`planar3p_agents.controllers.registry.BASELINES`);
* :func:`make_task_suite`, :func:`make_task_env`, :func:`task_episode_seed`: building them.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

from planar3p_agents.controllers.registry import STRONGEST_REACH_BASELINES
from planar3p_agents.evaluation.reach_suites import EpisodeSpec, Suite, triple
from planar3p_gym.envs.latency import REALISTIC_LATENCY
from planar3p_gym.sim.randomization import REALISTIC_RANDOMIZATION
from planar3p_gym.sim.sensors import REALISTIC_SENSORS

__all__ = [
    "TASK_SUITES",
    "TaskSuiteDef",
    "make_task_env",
    "make_task_suite",
    "task_episode_seed",
]


@dataclass(frozen=True)
class TaskSuiteDef:
    """A task suite: the environment it plays in and the baselines run on it by default.

    Attributes:
        env_id: registered Gymnasium id.
        env_kwargs: keyword arguments of ``gymnasium.make``.
        baselines: names of :data:`planar3p_agents.controllers.registry.BASELINES` played by
            default (the benchmark's ``baselines``), in report order.
        description: one line for the report.
        index: a small integer naming the suite in seed sequences (never reused).
    """

    env_id: str
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    baselines: tuple[str, ...] = ("analytic-simultaneous",)
    description: str = ""
    index: int = 0


#: The goal-conditioned suites' baselines: the analytic controller as shipped, the strongest
#: baselines of the reach (tuned gain, slider line, certified planner, certified
#: line) and the random policy (the 0 of the normalized scores), through the goal adapter.
GOAL_BASELINES = ("analytic-simultaneous", *STRONGEST_REACH_BASELINES, "random")
#: The task suites, in report order.
TASK_SUITES: dict[str, TaskSuiteDef] = {
    "goal": TaskSuiteDef(
        "Planar3PGoal-v0",
        {},
        GOAL_BASELINES,
        "goal-conditioned reach (sparse reward): start/goal pairs as the environment draws them",
        1,
    ),
    "goal-dense": TaskSuiteDef(
        "Planar3PGoalDense-v0",
        {},
        GOAL_BASELINES,
        "goal-conditioned reach (dense reward): start/goal pairs as the environment draws them",
        6,
    ),
    "track-segments": TaskSuiteDef(
        "Planar3PTrack-v0",
        {"reference": "segments"},
        (
            "analytic-simultaneous",
            "analytic-feedforward",
            "analytic-feedforward-tuned",
            "random",
            "zero",
        ),
        "tracking a reference of smooth random minimum-jerk segments",
        2,
    ),
    "track-figure-eight": TaskSuiteDef(
        "Planar3PTrack-v0",
        {"reference": "figure_eight"},
        (
            "analytic-simultaneous",
            "analytic-feedforward",
            "analytic-feedforward-tuned",
            "random",
            "zero",
        ),
        "tracking a figure-eight reference",
        3,
    ),
    "mode-change": TaskSuiteDef(
        "Planar3PModeChange-v0",
        {},
        ("analytic-simultaneous", "planner", "random", "zero"),
        "start and target in different working modes (a leg must pass its rail's perpendicular)",
        4,
    ),
    "assembly-change": TaskSuiteDef(
        "Planar3PAssemblyChange-v0",
        {},
        ("analytic-simultaneous", "crossing", "random", "zero"),
        "start and target in opposite assembly modes (crossing a parallel singularity)",
        5,
    ),
    "real-reach": TaskSuiteDef(
        "Planar3PReal-v0",
        {},
        ("analytic-simultaneous", *STRONGEST_REACH_BASELINES, "random", "zero"),
        "reach on the machine as built (randomised machine per episode, encoder readings through "
        "the nominal model, one step of action delay)",
        7,
    ),
    "real-reach-true-state": TaskSuiteDef(
        "Planar3PReal-v0",
        {"sensors": None},
        ("analytic-simultaneous", *STRONGEST_REACH_BASELINES),
        "the same machines, observed without sensors (the true state): is the task solvable on "
        "the randomised machine?",
        8,
    ),
    "real-reach-nominal": TaskSuiteDef(
        "Planar3PReal-v0",
        {"randomization": {}, "sensors": None, "latency": {}},
        ("analytic-simultaneous", *STRONGEST_REACH_BASELINES),
        "the same episodes on the nominal machine (no randomisation, true state, no delay): the "
        "reference the built machine is compared with",
        10,
    ),
    "real-on-off": TaskSuiteDef(
        "Planar3PRealOnOff-v0",
        {},
        ("analytic-on-off-predictive", "analytic-on-off", "random", "zero"),
        "reach on the machine as built with the prototype's on-off motors",
        9,
    ),
    "real-mode-change": TaskSuiteDef(
        "Planar3PModeChange-v0",
        {
            "randomization": REALISTIC_RANDOMIZATION.to_dict(),
            "sensors": REALISTIC_SENSORS.to_dict(),
            "latency": REALISTIC_LATENCY.to_dict(),
        },
        ("analytic-simultaneous", "planner", "random", "zero"),
        "working-mode change on the machine as built (the randomisation, sensors and delay of "
        "Planar3PReal-v0)",
        11,
    ),
    "real-assembly-change": TaskSuiteDef(
        "Planar3PAssemblyChange-v0",
        {
            "randomization": REALISTIC_RANDOMIZATION.to_dict(),
            "sensors": REALISTIC_SENSORS.to_dict(),
            "latency": REALISTIC_LATENCY.to_dict(),
        },
        ("analytic-simultaneous", "crossing", "random", "zero"),
        "assembly-mode change on the machine as built (the randomisation, sensors and delay of "
        "Planar3PReal-v0)",
        12,
    ),
}


def _definition(name: str) -> TaskSuiteDef:
    if name not in TASK_SUITES:
        raise ValueError(f"unknown task suite {name!r}; known: {', '.join(TASK_SUITES)}")
    d = TASK_SUITES[name]
    if d.env_id not in gym.registry:
        raise ValueError(f"task suite {name!r} needs {d.env_id}, which is not registered")
    return d


def make_task_env(name: str) -> Any:
    """``gymnasium.make`` of the environment of task suite ``name``."""
    d = _definition(name)
    return gym.make(d.env_id, **d.env_kwargs)


def task_episode_seed(name: str, seed: int, index: int) -> int:
    """The ``reset`` seed that draws episode ``index`` of task suite ``name``."""
    ss = np.random.SeedSequence([int(seed), 0x7A5C, TASK_SUITES[name].index, int(index)])
    return int(ss.generate_state(1)[0])


def make_task_suite(name: str, n_episodes: int, seed: int, env: Any = None) -> Suite:
    """Task suite ``name`` of ``n_episodes`` from ``seed``: each episode is the environment's
    ``info["episode_spec"]`` after ``reset(seed=task_episode_seed(name, seed, i))``.
    ``env``: the suite's environment (made if not given)."""
    d = _definition(name)
    if not (isinstance(n_episodes, (int, np.integer)) and n_episodes >= 1):
        raise ValueError(f"n_episodes must be a positive integer, got {n_episodes!r}")
    env = env if env is not None else make_task_env(name)
    episodes = []
    for i in range(int(n_episodes)):
        _, info = env.reset(seed=task_episode_seed(name, seed, i))
        spec = copy.deepcopy(info["episode_spec"])
        target = spec.get("target")
        episodes.append(
            EpisodeSpec(
                suite=name,
                index=i,
                start=triple(spec["start"]),
                target=triple(target) if target is not None else None,
                working_mode=tuple(int(m) for m in spec["working_mode"]),  # type: ignore[arg-type]
                options=spec,
            )
        )
    params = {
        "env_id": d.env_id,
        "env_kwargs": dict(d.env_kwargs),
        "task": episodes[0].options["task"] if episodes[0].options else None,
        "design": env.unwrapped.design.to_dict(),
        "max_episode_steps": env.spec.max_episode_steps if env.spec is not None else None,
        "description": d.description,
    }
    return Suite(name, int(seed), episodes, params)
