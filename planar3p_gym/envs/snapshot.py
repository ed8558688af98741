"""Checks of a snapshot's contents before the environment's ``set_state`` uses them (``env``
below is a :class:`~planar3p_gym.envs.core.Planar3PEnv`, not imported here: the environment
imports this module).

:meth:`~planar3p_gym.envs.core.Planar3PEnv.get_state` returns plain data; a snapshot that was
edited, truncated or assembled from two snapshots must be refused before anything of the
environment changes, not fail on the next step.

- :func:`check_snapshot`: the keys, the settings, the type and shape of every episode field,
  and that the simulation belongs to the episode (same working mode, machine and step count);
- :func:`checked_generator`: the random generator a snapshot's ``np_random`` state gives.
"""

from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np

from planar3p_gym import checks
from planar3p_gym.envs.latency import DelayLine
from planar3p_gym.machine.scalar_kinematics import ConfigurationMeasures, ScalarKinematics
from planar3p_gym.sim.physics import SimSnapshot
from planar3p_gym.sim.randomization import SampledMachine
from planar3p_gym.sim.sensors import Encoders

__all__ = ["SNAPSHOT_KEYS", "check_snapshot", "checked_generator"]

#: The keys of a snapshot (:meth:`~planar3p_gym.envs.core.Planar3PEnv.get_state`).
SNAPSHOT_KEYS = frozenset({"config", "sim", "np_random", "np_random_seed", "task", "episode"})


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


def _check_episode(env: Any, episode: Any) -> None:
    """``ValueError`` unless ``episode`` holds every per-episode field of ``env``, each of its
    type and shape."""
    fields = env._EPISODE_FIELDS
    if not isinstance(episode, dict) or set(episode) != set(fields):
        keys = sorted(episode) if isinstance(episode, dict) else episode
        raise ValueError(
            f"not a Planar3PEnv snapshot: its episode must hold exactly the fields "
            f"{', '.join(fields)}; got {checks.short(keys, 200)}"
        )
    e = episode
    if not isinstance(e["_spec"], dict):
        _fail("_spec", "a dict (the episode spec)", e["_spec"])
    if checks.as_int(e["_steps"]) is None or e["_steps"] < 0:
        _fail("_steps", "an integer >= 0", e["_steps"])
    if not (isinstance(e["_mode"], tuple) and e["_mode"] in env._modes):
        _fail("_mode", f"one of the working modes {env._modes}", e["_mode"])
    if not _reals(e["_target"], 3):
        _fail("_target", "3 finite numbers (x, y, theta)", e["_target"])
    if not _reals(e["_target_cs"], 2):
        _fail("_target_cs", "2 finite numbers (cos, sin)", e["_target_cs"])
    if e["_assembly"] not in (-1, 0, 1) or isinstance(e["_assembly"], bool):
        _fail("_assembly", "-1, 0 or 1", e["_assembly"])
    obs = e["_obs"]
    shape = env._obs.shape  # (the flat observation, also under the goal env's dict)
    if not (isinstance(obs, np.ndarray) and obs.dtype == np.float32 and obs.shape == shape):
        _fail("_obs", f"a float32 array of shape {shape}", obs)
    if not (e["_measures"] is None or isinstance(e["_measures"], ConfigurationMeasures)):
        _fail("_measures", "ConfigurationMeasures or None", e["_measures"])
    if not isinstance(e["_last_info"], dict):
        _fail("_last_info", "a dict", e["_last_info"])
    if not isinstance(e["_true_kin"], ScalarKinematics):
        _fail("_true_kin", "ScalarKinematics", e["_true_kin"])
    if not isinstance(e["_machine"], SampledMachine):
        _fail("_machine", "SampledMachine", e["_machine"])
    delays = e["_delays"]
    if not (
        isinstance(delays, tuple) and len(delays) == 2 and all(checks.is_int(d) for d in delays)
    ):
        _fail("_delays", "2 integers (action, observation delay)", delays)
    for name in ("_action_line", "_obs_line"):
        if not (e[name] is None or isinstance(e[name], DelayLine)):
            _fail(name, "a DelayLine or None", e[name])
    want_encoders = env.sensors is not None
    if not (isinstance(e["_encoders"], Encoders) if want_encoders else e["_encoders"] is None):
        _fail("_encoders", "Encoders" if want_encoders else "None (no sensors)", e["_encoders"])


def check_snapshot(env: Any, state: Any) -> None:
    """``ValueError`` unless ``state`` is a snapshot that ``env.set_state`` can restore: the
    keys of :data:`SNAPSHOT_KEYS`, ``env``'s settings, a complete episode
    (:func:`_check_episode`), and a simulation of that episode (``None`` only before the first
    reset; otherwise of the episode's working mode and machine, as many steps in).  Changes
    nothing."""
    if not isinstance(state, dict) or set(state) != SNAPSHOT_KEYS:
        raise ValueError("state must be a snapshot from Planar3PEnv.get_state()")
    if state["config"] != env.config():
        raise ValueError(
            "the snapshot was taken from an environment with other settings: "
            f"{state['config']} != {env.config()}"
        )
    episode = state["episode"]
    _check_episode(env, episode)
    sim = state["sim"]
    if sim is None:
        if episode["_steps"] != 0:
            raise ValueError("not a Planar3PEnv snapshot: steps taken, but no simulation")
        return
    if not isinstance(sim, SimSnapshot):
        raise ValueError(f"not a Planar3PEnv snapshot: sim is {checks.short(sim)}")
    if (
        tuple(sim.working_mode) != episode["_mode"]
        or sim.design != episode["_machine"].design.to_dict()
        or sim.steps != episode["_steps"]
    ):
        raise ValueError(
            "not a Planar3PEnv snapshot: its simulation is not of its episode (working mode "
            f"{tuple(sim.working_mode)} vs {episode['_mode']}, {sim.steps} vs "
            f"{episode['_steps']} steps, or another machine)"
        )


def checked_generator(env: Any, state: dict[str, Any]) -> np.random.Generator:
    """A generator of ``env``'s bit generator in the snapshot's ``np_random`` state;
    ``ValueError`` if that is not such a state (nothing of ``env`` is touched)."""
    rng = np.random.Generator(type(env.np_random.bit_generator)())
    try:
        rng.bit_generator.state = copy.deepcopy(state["np_random"])
    except (TypeError, ValueError, KeyError) as exc:
        raise ValueError(f"not a Planar3PEnv snapshot: np_random is not a state ({exc})") from None
    seed = state["np_random_seed"]
    if not (seed is None or checks.is_int(seed)):
        raise ValueError(f"not a Planar3PEnv snapshot: np_random_seed is {checks.short(seed)}")
    return rng
