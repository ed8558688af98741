"""The machine as built: how an action reaches the sliders and how the state reaches the policy.

:class:`BuiltMachine` is the component a :class:`planar3p_gym.envs.core.Planar3PEnv` is handed
between the policy and the physics.  The nominal machine's component is the identity (an action
clipped to ``[-1, 1]``, the true state observed); the built machine's features, each off unless
asked for:

- the action type: slider velocities, or the prototype's on-off motors (:func:`on_off_action`);
- the action and observation delays (:class:`planar3p_gym.envs.latency.LatencyConfig`, drawn
  per episode);
- the encoders (:class:`planar3p_gym.sim.sensors.Encoders`): the policy observes their reading
  through the nominal model;
- the per-episode machine (:class:`planar3p_gym.sim.randomization.DynamicsRandomization`): the
  simulation runs a machine drawn at each reset, and the true measures are that machine's.
"""

from __future__ import annotations

import copy
import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces

from planar3p_gym import checks
from planar3p_gym.checks import config_from, parse_action
from planar3p_gym.envs.latency import DelayLine, LatencyConfig
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design
from planar3p_gym.machine.scalar_kinematics import ConfigurationMeasures, ScalarKinematics
from planar3p_gym.sim.dynamics import MachineDynamics
from planar3p_gym.sim.physics import Planar3PSim, SimState
from planar3p_gym.sim.randomization import DynamicsRandomization, SampledMachine
from planar3p_gym.sim.sensors import Encoders, SensorConfig

__all__ = [
    "ACTION_TYPES",
    "KEYBOARD_KEYS",
    "KEYBOARD_SPEED",
    "MACHINE_DRAWS",
    "ON_OFF_ACTION_TYPES",
    "ON_OFF_COMMANDS",
    "ON_OFF_SPEED",
    "BuiltMachine",
    "MachineEpisode",
    "discrete_digits",
    "keys_to_action",
    "on_off_action",
    "on_off_actions",
]

#: The action types of :class:`BuiltMachine`: slider velocities, or the prototype's on-off
#: motors (each stopped, forward or backward at their rated speed, :data:`ON_OFF_SPEED`) as
#: ``MultiDiscrete([3, 3, 3])`` or as one ``Discrete(27)`` index (for DQN).
ACTION_TYPES: tuple[str, ...] = ("continuous", "on-off", "on-off-discrete")
#: Action types that command the same motors and differ only in how an action is written (three
#: commands or one index): a model trained with one can be played on an environment made with
#: the other by making that environment with the model's action type.
ON_OFF_ACTION_TYPES: tuple[str, ...] = ("on-off", "on-off-discrete")
#: The motor command of each value of an on-off action: 0 stop, 1 forward (+x), 2 backward
#: (times the rated speed).
ON_OFF_COMMANDS: tuple[float, float, float] = (0.0, 1.0, -1.0)
#: Default rated speed of the on-off motors, as a fraction of ``max_speed``: one control step
#: at it moves a slider 0.4 mm on the default design at 50 Hz.  The travels an on-off machine
#: can stop at are that coarse, and where the gripper moves several millimetres per
#: millimetre of slider travel (towards a parallel singularity) a coarser step leaves no stop
#: within the reach task's 2 mm tolerance (the throughput and on-off controller pages give the
#: measurements behind the choice).
ON_OFF_SPEED = 0.1
#: Draws of a randomised machine at a reset before falling back to the nominal one, if the
#: start pose is out of the drawn machine's reach (never happens with millimetre errors).
MACHINE_DRAWS = 20
#: Keys of :func:`keys_to_action`: (+x, -x) for sliders 1, 2, 3.
KEYBOARD_KEYS = (("q", "a"), ("w", "s"), ("e", "d"))
#: Speed commanded by a pressed key, as a fraction of ``max_speed``.
KEYBOARD_SPEED = 0.5


def discrete_digits(n: Any) -> tuple[Any, Any, Any]:
    """The three motor commands' values (``{0, 1, 2}``, slider 1 first) of a ``Discrete(27)``
    index ``n`` (its base-3 digits): of an integer, or elementwise of an integer array."""
    return n // 9, (n // 3) % 3, n % 3


def on_off_actions(actions: np.ndarray, action_type: str, speed: float) -> np.ndarray:
    """The chosen slider velocities (fractions of ``max_speed``, ``(n, 3)`` float64) of a batch
    of on-off ``actions`` (the motor values ``(n, 3)``, or ``(n,)`` ``Discrete(27)`` indices),
    each the command :func:`on_off_action` gives times the motors' ``speed``; ``ValueError``
    (the single env's message for the first bad action) unless every action is one
    :func:`on_off_action` accepts."""
    arr = np.asarray(actions)
    if action_type == "on-off-discrete":
        ok = arr.ndim == 1 and np.isin(arr, np.arange(27)).all()
        digits = np.stack(discrete_digits(arr.astype(np.int64)), axis=1) if ok else None
    else:
        ok = arr.ndim == 2 and arr.shape[1] == 3 and np.isin(arr, (0, 1, 2)).all()
        digits = arr.astype(np.int64) if ok else None
    if digits is None:
        for row in arr if arr.ndim >= 1 else [arr]:
            on_off_action(row, action_type)  # (the single env's message for the first bad one)
        raise ValueError(f"actions must be a batch of {action_type} actions, got shape {arr.shape}")
    return np.asarray(ON_OFF_COMMANDS)[digits] * speed


def on_off_action(action: Any, action_type: str) -> tuple[float, float, float]:
    """The motor commands (-1, 0 or 1, :data:`ON_OFF_COMMANDS`) of an on-off action: three
    integers in ``{0, 1, 2}`` for ``"on-off"``, one integer in ``[0, 27)`` for
    ``"on-off-discrete"`` (its base-3 digits, slider 1 first); integral floats are accepted
    too; ``ValueError`` otherwise."""
    if action_type == "on-off-discrete":
        if isinstance(action, np.ndarray) and action.shape == (1,):
            action = action[0]  # (a batch of one, as some agents return it)
        value = action if np.ndim(action) == 0 else None
        n = checks.as_int(value)
        if n is None and (f := checks.as_finite_float(value)) is not None and f.is_integer():
            n = int(f)  # an integral float, as for the three commands
        if n is None or not 0 <= n < 27:
            raise ValueError(f"action must be an integer in [0, 27), got {checks.short(action)}")
        digits = discrete_digits(n)
    else:
        arr = checks.real_array(action)
        if arr is None or arr.shape != (3,) or not all(v in (0, 1, 2) for v in arr.tolist()):
            raise ValueError(
                f"action must be 3 integers in {{0, 1, 2}} (stop, forward, backward), got "
                f"{checks.short(action)}"
            )
        digits = tuple(int(v) for v in arr.tolist())
    c = ON_OFF_COMMANDS
    return c[digits[0]], c[digits[1]], c[digits[2]]


def keys_to_action() -> dict[tuple[str, ...], np.ndarray]:
    """Keyboard mapping for :func:`gymnasium.utils.play.play`: ``q``/``a`` drive slider 1
    towards +x/-x, ``w``/``s`` slider 2, ``e``/``d`` slider 3, at :data:`KEYBOARD_SPEED` of
    ``max_speed``; keys of different sliders combine."""
    mapping: dict[tuple[str, ...], np.ndarray] = {}
    for signs in itertools.product((0, 1, -1), repeat=3):
        keys = tuple(
            sorted(
                up if sg > 0 else down
                for (up, down), sg in zip(KEYBOARD_KEYS, signs, strict=True)
                if sg
            )
        )
        if keys:
            mapping[keys] = KEYBOARD_SPEED * np.array(signs, dtype=np.float32)
    return mapping


@dataclass
class MachineEpisode:
    """The built machine's per-episode record (plain, deep-copyable data).

    Attributes:
        machine: the episode's machine (the nominal one unless drawn).
        true_kin: the kinematics of that machine (the true measures).
        delays: the episode's (action, observation) delays (control steps).
        action_line, obs_line: the delay lines (``None`` on the nominal machine).
        encoders: the encoders' state (:meth:`Encoders.get_state`), ``None`` without encoders.
    """

    machine: SampledMachine
    true_kin: ScalarKinematics
    delays: tuple[int, int] = (0, 0)
    action_line: DelayLine | None = None
    obs_line: DelayLine | None = None
    encoders: Any = None


class BuiltMachine:
    """The actuation and sensing of the machine as built (module docstring).

    Args:
        design: the nominal machine.
        dt: control period (s).
        substeps: physics steps per control step.  With viscous friction in
            ``randomization``, a physics step too long to integrate every machine drawn is
            refused, naming the lowest control rate accepted
            (:meth:`~planar3p_gym.sim.randomization.DynamicsRandomization.check_step`).
        randomization, sensors, latency: the built machine's features (or dicts of their
            fields); ``None`` or zero ranges turn them off.
        action_type: one of :data:`ACTION_TYPES`.
        on_off_speed: rated speed of the on-off motors, a fraction of ``max_speed`` in (0, 1].
    """

    def __init__(
        self,
        design: Design,
        dt: float,
        *,
        substeps: int = 1,
        randomization: DynamicsRandomization | dict | None = None,
        sensors: SensorConfig | dict | None = None,
        latency: LatencyConfig | dict | None = None,
        action_type: str = "continuous",
        on_off_speed: float = ON_OFF_SPEED,
    ) -> None:
        randomization = config_from(randomization, DynamicsRandomization, "randomization")
        sensors = None if sensors is None else config_from(sensors, SensorConfig, "sensors")
        latency = config_from(latency, LatencyConfig, "latency")
        # Every machine drawn must be one the step integrates (a reset never fails on it).
        randomization.check_step(design, 1.0 / dt, substeps)
        self.action_type = checks.choice(action_type, "action_type", ACTION_TYPES)
        #: Rated speed of the on-off motors as a fraction of ``max_speed``.
        self.on_off_speed = checks.number(
            on_off_speed, "on_off_speed", low=0.0, high=1.0, low_open=True
        )
        #: Ranges of the per-episode machine (``None``: the nominal machine).
        self.randomization = None if randomization.is_zero else randomization
        #: The encoders' noise and resolution (``None``: the policy observes the true state).
        self.sensors = sensors
        #: Ranges of the per-episode delays (``None``: none).
        self.latency = None if latency.is_zero else latency
        self.design = design
        #: The nominal model (the encoders' readings are measured through it).
        self.kin = ScalarKinematics(design)
        #: The encoders (``None``: the policy observes the true state).
        self.encoders = None if sensors is None else Encoders(design, sensors, dt)
        #: Whether every feature is off (the identity: the nominal machine).
        self.nominal = (
            self.randomization is None
            and sensors is None
            and self.latency is None
            and self.action_type == "continuous"
        )
        self.episode = MachineEpisode(SampledMachine(design, MachineDynamics()), self.kin)
        if self.action_type == "on-off":
            self.action_space: spaces.Space = spaces.MultiDiscrete([3, 3, 3])
        elif self.action_type == "on-off-discrete":
            self.action_space = spaces.Discrete(27)
        else:
            self.action_space = spaces.Box(-1.0, 1.0, shape=(3,), dtype=np.float32)

    # ------------------------------------------------------------------ reset
    def draw(
        self, rng: np.random.Generator, start: Any, mode: tuple[int, int, int]
    ) -> SampledMachine:
        """The next episode's machine: drawn from ``rng`` with :attr:`randomization`, redrawn
        while the start pose is out of its reach (at most :data:`MACHINE_DRAWS` draws, then the
        nominal one); the nominal one without.  Changes nothing but ``rng`` (the reset hands
        the machine to :meth:`simulation`, once nothing can reject the reset any more)."""
        if self.randomization is None:
            return self.episode.machine
        for _ in range(MACHINE_DRAWS):
            drawn = self.randomization.sample(self.design, rng)
            if bool(kinematics.inverse(drawn.design, np.asarray(start), mode).reachable):
                return drawn
        return SampledMachine(self.design, MachineDynamics())

    def begin(self, rng: np.random.Generator) -> None:
        """The per-episode state of the delays (drawn from ``rng``) and the encoders."""
        if self.nominal:
            return
        ep = self.episode
        if self.latency is not None:
            ep.delays = self.latency.sample(rng)
        ep.action_line = DelayLine(ep.delays[0], (0.0, 0.0, 0.0))
        ep.obs_line = DelayLine(ep.delays[1], None)
        if self.encoders is not None:
            self.encoders.reset()

    def first_observation(self, obs: np.ndarray) -> None:
        """Fill the observation delay line with the reset's observation."""
        ep = self.episode
        if ep.obs_line is not None:
            ep.obs_line = DelayLine(ep.delays[1], obs.copy())

    def reset_info(self) -> dict[str, Any]:
        """The reset's ``info`` entries of the built machine: ``machine``, ``delays``."""
        out: dict[str, Any] = {}
        if self.randomization is not None:
            out["machine"] = self.episode.machine.to_dict()
        if self.latency is not None:
            out["delays"] = self.episode.delays
        return out

    def simulation(
        self,
        machine: SampledMachine,
        previous: Planar3PSim | None,
        start: Any,
        mode: tuple[int, int, int],
        s: Any,
    ) -> Planar3PSim:
        """The episode's simulation of ``machine`` (:meth:`draw`; now the episode's) at rest at
        ``start`` in working ``mode``, with the settings ``s``
        (:class:`planar3p_gym.envs.settings.EnvSettings`): the ``previous`` model moved (and,
        for a drawn machine, given its numbers), bit for bit the model a new build would give
        (:meth:`Planar3PSim.reset`), or a new one."""
        ep, drawn = self.episode, self.randomization is not None
        if machine is not ep.machine:
            ep.machine = machine
            ep.true_kin = (
                self.kin if machine.design == self.design else ScalarKinematics(machine.design)
            )
        if previous is not None and not previous.closed:
            if drawn:
                previous.reset(start, mode, design=machine.design, dynamics=machine.dynamics)
            else:
                previous.reset(start, mode)
            return previous
        sim = Planar3PSim(
            machine.design, start, mode, dt=s.dt, substeps=s.substeps,
            iterations=s.solver_iterations, projection=s.projection,
            dynamics=machine.dynamics if drawn else None,
        )  # fmt: skip
        if previous is not None:  # freed now, not left to the garbage collector
            previous.close()
        return sim

    # ------------------------------------------------------------------ per step
    def command(self, action: Any) -> tuple[float, float, float]:
        """The executed action (fractions of ``max_speed``) of the policy's ``action``: parsed
        (``ValueError`` before anything changes), decoded and delayed."""
        if self.nominal:
            return parse_action(action)
        if self.action_type == "continuous":
            chosen = parse_action(action)
        else:
            c0, c1, c2 = on_off_action(action, self.action_type)
            v = self.on_off_speed
            chosen = (c0 * v, c1 * v, c2 * v)
        line = self.episode.action_line
        assert line is not None
        return line.push(chosen)

    def measures(self, state: SimState) -> ConfigurationMeasures:
        """The true measures of ``state`` (the episode's machine)."""
        return self.episode.true_kin.measures(state.pose, state.rho)

    def sense(
        self, state: SimState, measures: ConfigurationMeasures, rng: np.random.Generator
    ) -> tuple[SimState, ConfigurationMeasures]:
        """What the policy observes of the true ``state`` (with its true ``measures``): the
        encoders' reading (noise from ``rng``) and the nominal model's measures at it; the
        true state itself without encoders."""
        if self.encoders is None:
            return state, measures
        seen = self.encoders.measure(state, rng)
        return seen, self.kin.measures(seen.pose, seen.rho)

    def delay(self, obs: np.ndarray) -> np.ndarray:
        """The observation the policy gets now (the observation delay)."""
        line = self.episode.obs_line
        return obs if line is None else line.push(obs)

    # ------------------------------------------------------------------ records
    def config(self) -> dict[str, Any]:
        """The features that are on, as plain data (only those: earlier records stay valid)."""
        return {
            **({"randomization": self.randomization.to_dict()} if self.randomization else {}),
            **({"sensors": self.sensors.to_dict()} if self.sensors is not None else {}),
            **({"latency": self.latency.to_dict()} if self.latency else {}),
            **(
                {"action_type": self.action_type, "on_off_speed": self.on_off_speed}
                if self.action_type != "continuous"
                else {}
            ),
        }

    def get_state(self) -> MachineEpisode:
        """A deep copy of the per-episode record (the encoders' state in it)."""
        ep = copy.deepcopy(self.episode)
        ep.encoders = None if self.encoders is None else self.encoders.get_state()
        return ep

    def set_state(self, state: MachineEpisode) -> None:
        """Restore a :meth:`get_state` record."""
        self.episode = copy.deepcopy(state)
        if self.encoders is not None:
            self.encoders.set_state(state.encoders)
