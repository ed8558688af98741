"""An environment's snapshot (``Planar3PEnv.get_state``): its random and task parts, and the
checks of its contents before ``set_state`` uses any of them (``env`` below is a
:class:`~planar3p_gym.envs.core.Planar3PEnv`, not imported here: the environment imports this
module).  A snapshot that was edited, truncated or assembled from two snapshots is refused
before anything of the environment changes, rather than failing on the next step.

- :func:`random_state`: the generator's state, its seed and the task's state (the task's
  ``get_state()`` if it defines one, else a deep copy of its attributes but ``env``);
- :func:`restored_random`: the generator of such a record (the task's state put back);
- :func:`check_snapshot`: ``ValueError`` unless a value is a snapshot ``env.set_state`` can
  restore: the keys, the settings, the type and shape of every episode field, a simulation of
  that episode (same working mode, machine and step count) and a random state;
- :func:`checked_generator`: the generator and seed of a snapshot's random state.
"""

from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np

from planar3p_gym import checks
from planar3p_gym.envs.actuation import MachineEpisode
from planar3p_gym.envs.latency import DelayLine
from planar3p_gym.machine.scalar_kinematics import ConfigurationMeasures, ScalarKinematics
from planar3p_gym.sim.physics import SimSnapshot
from planar3p_gym.sim.randomization import SampledMachine
from planar3p_gym.tasks.base import Task
from planar3p_gym.tasks.kernel import Episode

__all__ = [
    "SNAPSHOT_KEYS",
    "check_snapshot",
    "checked_generator",
    "random_state",
    "restored_random",
]

#: The keys of a snapshot.
SNAPSHOT_KEYS = frozenset({"config", "sim", "np_random", "np_random_seed", "task", "episode"})
#: The keys of a snapshot's ``episode``: the environment's record and the built machine's.
EPISODE_KEYS = frozenset({"record", "machine"})


def random_state(rng: np.random.Generator, seed: int | None, task: Task) -> dict[str, Any]:
    """``rng``'s state, its ``seed`` and ``task``'s state (sampler pools included)."""
    return {
        "np_random": copy.deepcopy(rng.bit_generator.state),
        "np_random_seed": seed,
        "task": _task_state(task),
    }


def _task_state(task: Task) -> Any:
    if hasattr(task, "get_state"):
        return task.get_state()
    return copy.deepcopy({k: v for k, v in vars(task).items() if k != "env"})


def _set_task_state(task: Task, state: Any) -> None:
    if hasattr(task, "set_state"):
        task.set_state(copy.deepcopy(state))
    else:
        vars(task).update(copy.deepcopy(state))


def checked_generator(state: dict[str, Any]) -> tuple[np.random.Generator, int | None]:
    """The generator of the bit generator and state a snapshot's ``np_random`` records, and
    its ``np_random_seed``; ``ValueError`` if they are not such a state and seed."""
    record = state["np_random"]
    name = record.get("bit_generator") if isinstance(record, dict) else None
    kind = getattr(np.random, name, None) if isinstance(name, str) else None
    if not (isinstance(kind, type) and issubclass(kind, np.random.BitGenerator)):
        raise ValueError(f"not a Planar3PEnv snapshot: np_random is {checks.short(record)}")
    rng = np.random.Generator(kind())
    try:
        rng.bit_generator.state = copy.deepcopy(record)
    except (TypeError, ValueError, KeyError) as exc:
        raise ValueError(f"not a Planar3PEnv snapshot: np_random is not a state ({exc})") from None
    seed = state["np_random_seed"]
    if not (seed is None or checks.is_int(seed)):
        raise ValueError(f"not a Planar3PEnv snapshot: np_random_seed is {checks.short(seed)}")
    return rng, seed


def restored_random(state: dict[str, Any], task: Task) -> tuple[np.random.Generator, int | None]:
    """The generator and seed :func:`random_state` recorded (:func:`checked_generator`); puts
    ``task``'s state back.  ``ValueError``, ``task`` as it was, if that state does not fit."""
    rng, seed = checked_generator(state)
    undo = _task_state(task)
    try:
        _set_task_state(task, state["task"])
    except (TypeError, ValueError, KeyError, AttributeError) as exc:
        _set_task_state(task, undo)
        raise ValueError(
            f"not a Planar3PEnv snapshot: its task state does not fit ({exc})"
        ) from None
    return rng, seed


def _fail(field: str, want: str, value: Any) -> None:
    raise ValueError(
        f"not a Planar3PEnv snapshot: episode field {field} must be {want}, got "
        f"{checks.short(value)}"
    )


def _reals(value: Any, n: int) -> bool:
    """``n`` finite real numbers in a tuple."""
    return (
        isinstance(value, tuple)
        and len(value) == n
        and all(checks.is_real(v) and math.isfinite(v) for v in value)
    )


def _check_record(env: Any, e: Any) -> None:
    """``ValueError`` unless ``e`` is an :class:`~planar3p_gym.tasks.kernel.Episode` of
    ``env``, each field of its type and shape."""
    if not isinstance(e, Episode):
        _fail("record", "an Episode", e)
    if not isinstance(e.spec, dict):
        _fail("spec", "a dict (the episode spec)", e.spec)
    if checks.as_int(e.steps) is None or e.steps < 0:
        _fail("steps", "an integer >= 0", e.steps)
    if not (isinstance(e.mode, tuple) and e.mode in env.modes):
        _fail("mode", f"one of the working modes {env.modes}", e.mode)
    if not _reals(e.target, 3):
        _fail("target", "3 finite numbers (x, y, theta)", e.target)
    if not _reals(e.target_cs, 2):
        _fail("target_cs", "2 finite numbers (cos, sin)", e.target_cs)
    rho = e.target_rho
    if not (isinstance(rho, np.ndarray) and rho.shape == (3,) and np.isfinite(rho).all()):
        _fail("target_rho", "3 finite slider travels", rho)
    if e.assembly not in (-1, 0, 1) or isinstance(e.assembly, bool):
        _fail("assembly", "-1, 0 or 1", e.assembly)
    shape = env.episode.obs.shape  # (the flat observation, also under the goal env's dict)
    obs = e.obs
    if not (isinstance(obs, np.ndarray) and obs.dtype == np.float32 and obs.shape == shape):
        _fail("obs", f"a float32 array of shape {shape}", obs)
    if not (e.measures is None or isinstance(e.measures, ConfigurationMeasures)):
        _fail("measures", "ConfigurationMeasures or None", e.measures)
    if not isinstance(e.info, dict):
        _fail("info", "a dict", e.info)


def _check_machine(env: Any, m: Any) -> None:
    """``ValueError`` unless ``m`` is a :class:`~planar3p_gym.envs.actuation.MachineEpisode`
    of ``env``'s built machine, each field of its type."""
    if not isinstance(m, MachineEpisode):
        _fail("machine", "a MachineEpisode", m)
    if not isinstance(m.machine, SampledMachine):
        _fail("machine.machine", "SampledMachine", m.machine)
    if not isinstance(m.true_kin, ScalarKinematics):
        _fail("machine.true_kin", "ScalarKinematics", m.true_kin)
    d = m.delays
    if not (isinstance(d, tuple) and len(d) == 2 and all(checks.as_int(v) is not None for v in d)):
        _fail("machine.delays", "2 integers (action, observation delay)", d)
    for name in ("action_line", "obs_line"):
        if not (getattr(m, name) is None or isinstance(getattr(m, name), DelayLine)):
            _fail(f"machine.{name}", "a DelayLine or None", getattr(m, name))
    if env.sensors is None and m.encoders is not None:
        _fail("machine.encoders", "None (no sensors)", m.encoders)
    if env.sensors is not None and not (m.encoders is None or isinstance(m.encoders, tuple)):
        _fail("machine.encoders", "the encoders' last reading (a tuple) or None", m.encoders)


def check_snapshot(env: Any, state: Any) -> None:
    """``ValueError`` unless ``state`` is a snapshot that ``env.set_state`` can restore: the
    keys of :data:`SNAPSHOT_KEYS`, ``env``'s settings, a complete episode (the environment's
    record and the built machine's), a simulation of that episode (``None`` only before the
    first reset; otherwise of the episode's working mode and machine, as many steps in) and a
    random state (:func:`checked_generator`).  Changes nothing."""
    if not isinstance(state, dict) or set(state) != SNAPSHOT_KEYS:
        raise ValueError("state must be a snapshot from Planar3PEnv.get_state()")
    if state["config"] != env.config():
        raise ValueError(
            "the snapshot was taken from an environment with other settings: "
            f"{state['config']} != {env.config()}"
        )
    episode = state["episode"]
    if not isinstance(episode, dict) or set(episode) != EPISODE_KEYS:
        keys = sorted(episode) if isinstance(episode, dict) else episode
        raise ValueError(
            "not a Planar3PEnv snapshot: its episode must hold exactly 'record' and 'machine'; "
            f"got {checks.short(keys, 200)}"
        )
    record, machine = episode["record"], episode["machine"]
    _check_record(env, record)
    _check_machine(env, machine)
    checked_generator(state)
    sim = state["sim"]
    if sim is None:
        if record.steps != 0:
            raise ValueError("not a Planar3PEnv snapshot: steps taken, but no simulation")
        return
    if not isinstance(sim, SimSnapshot):
        raise ValueError(f"not a Planar3PEnv snapshot: sim is {checks.short(sim)}")
    if (
        tuple(sim.working_mode) != record.mode
        or sim.design != machine.machine.design.to_dict()
        or sim.steps != record.steps
    ):
        raise ValueError(
            "not a Planar3PEnv snapshot: its simulation is not of its episode (working mode "
            f"{tuple(sim.working_mode)} vs {record.mode}, {sim.steps} vs {record.steps} steps, "
            "or another machine)"
        )
