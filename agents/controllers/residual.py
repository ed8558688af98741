"""Residual policy learning on top of the analytic controllers.

A residual policy (Silver et al. 2018, Johannink et al. 2019) learns a correction to a fixed
controller: its Gaussian mean is ``base(obs) + residual_scale * tanh(net(features))``, the head
starting at zero so that the untrained policy *is* the base controller.  A trained model is an
ordinary SB3 ``PPO`` model of its id; train without ``VecNormalize``'s observation
normalisation (the base needs the raw observation).  Details: docs/controllers.md, "How the
controller modules work".

* :class:`ResidualTrackPolicy` (``Planar3PTrack-v0``): on the feed-forward tracking controller;
* :class:`ResidualReachPolicy` (``Planar3P-v0``, ``Planar3PReal-v0``): on
  ``analytic-simultaneous``, as built optionally through a learned pose correction;
* :class:`ResidualLinePolicy` (``Planar3P-v0``): on ``certified-line``;
* :class:`ResidualAssemblyPolicy` (``Planar3PAssemblyChange-v0``, exact or as built): on
  ``analytic-simultaneous``, as built optionally through a learned pose correction
  (``crossing`` follows its plan by a clock the observation does not hold, so it cannot be a
  policy's mean);
* :class:`ResidualPlannerPolicy` (``Planar3PModeChange-v0``, exact or as built): on
  ``planner``, whose plan and clock :class:`PlannerFeatures` keeps per environment, as built
  optionally through a learned pose correction (:class:`CorrectedBasePolicy`);
* :class:`TrackFeatures`, :class:`ReachFeatures`, :class:`LineFeatures`,
  :func:`feature_scaling`: their features (fixed physical scales, the base action appended).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import torch as th
from stable_baselines3.common.distributions import DiagGaussianDistribution, Distribution
from stable_baselines3.common.policies import ActorCriticPolicy
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

from planar3p_agents.controllers.analytic import AnalyticController
from planar3p_agents.controllers.base import BatchPolicy
from planar3p_agents.controllers.base_policy import BaseControllerPolicy
from planar3p_agents.controllers.certified_line import CertifiedLineController
from planar3p_agents.controllers.layout import extra_slice, task_observation_size
from planar3p_agents.controllers.planner import JointPathPlanner
from planar3p_agents.controllers.pose_correction import (
    PoseCorrection,
    correction_weights,
    weights_in_kwargs,
)
from planar3p_agents.controllers.tracking import TRACK_OBS_SIZE, TrackingController
from planar3p_gym.checks import design_from
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks.observation import OBS_SIZE, SLICES

__all__ = [
    "ASSEMBLY_OBS_SIZE",
    "BASE_CACHE_ROWS",
    "ERROR_SCALE",
    "FEATURE_CLIP",
    "MODE_CHANGE_OBS_SIZE",
    "REACH_ERROR_SCALE",
    "RESIDUAL_SCALE",
    "AssemblyFeatures",
    "CorrectedBasePolicy",
    "LineFeatures",
    "PlannerFeatures",
    "ReachFeatures",
    "ResidualAssemblyPolicy",
    "ResidualLinePolicy",
    "ResidualPlannerPolicy",
    "ResidualReachPolicy",
    "ResidualTrackPolicy",
    "TrackFeatures",
    "feature_scaling",
]

#: Pose error (m) that maps to a feature of 1 in tracking (errors of a few tenths of a
#: millimetre are what the residual has to remove).
ERROR_SCALE = 1e-3
#: Pose error (m) that maps to a feature of 1 in reaching: the centimetres over which the
#: analytic controller's proportional tail is slow stay below the clip, a millimetre is 0.1.
REACH_ERROR_SCALE = 1e-2
#: Scaled features are clipped to ``[-FEATURE_CLIP, FEATURE_CLIP]``.
FEATURE_CLIP = 10.0
#: Default largest correction per slider, as a fraction of ``max_speed``.
RESIDUAL_SCALE = 0.1
#: Observations whose base action :class:`LineFeatures` keeps (a few PPO rollouts' worth).
BASE_CACHE_ROWS = 1 << 16
#: Length of the assembly change's flat observation (the 31 entries, the target's travels,
#: its assembly mode and the signed parallel margin).
ASSEMBLY_OBS_SIZE = task_observation_size("assembly_change")
#: Length of the mode change's flat observation (the 31 entries, the target's travels and its
#: working mode).
MODE_CHANGE_OBS_SIZE = task_observation_size("mode_change")
#: The task whose appended entries each task observation size has (both start with the
#: target's travels).
_TASK_OF_SIZE = {ASSEMBLY_OBS_SIZE: "assembly_change", MODE_CHANGE_OBS_SIZE: "mode_change"}


def feature_scaling(
    design: Design, size: int = TRACK_OBS_SIZE, error_scale: float = ERROR_SCALE
) -> tuple[np.ndarray, np.ndarray]:
    """``(offset, scale)`` of the ``size`` observation entries (``OBS_SIZE`` = 31 of the reach
    ids, ``TRACK_OBS_SIZE`` = 34 of the tracking id, ``ASSEMBLY_OBS_SIZE`` = 36 of the
    assembly change or ``MODE_CHANGE_OBS_SIZE`` = 37 of the mode change): feature ``(obs -
    offset) * scale``.  Travels (the target's too) are centred on mid-stroke over half the
    stroke; slider, gripper and reference speeds are over ``max_speed`` (angular rates times
    ``L_ref``); positions over ``L_ref``; position errors over ``error_scale`` (m) and the
    orientation error times ``L_ref / error_scale``; dimensionless entries (cos/sin, margins,
    fine errors, assembly and working modes) as they are."""
    sizes = (OBS_SIZE, TRACK_OBS_SIZE, ASSEMBLY_OBS_SIZE, MODE_CHANGE_OBS_SIZE)
    if size not in sizes:
        raise ValueError(f"size must be one of {sizes}, got {size!r}")
    length, vmax = design.characteristic_length, design.max_speed
    offset = np.zeros(size)
    scale = np.ones(size)
    offset[SLICES["rho"]] = design.stroke / 2.0
    scale[SLICES["rho"]] = 2.0 / design.stroke
    scale[SLICES["rho_dot"]] = 1.0 / vmax
    scale[SLICES["position"]] = 1.0 / length
    scale[SLICES["velocity"]] = 1.0 / vmax
    scale[SLICES["angular_velocity"]] = length / vmax
    scale[SLICES["target_position"]] = 1.0 / length
    scale[SLICES["position_error"]] = 1.0 / error_scale
    scale[SLICES["orientation_error"]] = length / error_scale
    if size == TRACK_OBS_SIZE:
        ref = slice(TRACK_OBS_SIZE - 3, TRACK_OBS_SIZE)
        scale[ref] = np.array([1.0 / vmax, 1.0 / vmax, length / vmax])
    if size in _TASK_OF_SIZE:
        target_rho = extra_slice(_TASK_OF_SIZE[size], "target_rho")
        offset[target_rho] = design.stroke / 2.0
        scale[target_rho] = 2.0 / design.stroke
    return offset, scale


class ControllerFeatures(BaseFeaturesExtractor):
    """The observation scaled by :func:`feature_scaling` (clipped to :data:`FEATURE_CLIP`),
    followed by the base controller's action: ``obs_size + 3`` features.

    Args:
        observation_space: ``Box((controller.obs_size,))``.
        controller: the base controller (a :class:`BatchPolicy` with a ``design``, which sets
            the feature scales, and an ``obs_size``).
        error_scale: pose error (m) that maps to a feature of 1.
        correction: the weights of a learned :class:`PoseCorrection` of the pose reading the
            base acts on (nested lists; the features keep the observation as read), or
            ``None``.
    """

    def __init__(
        self,
        observation_space: gym.spaces.Box,
        controller: BatchPolicy,
        error_scale: float,
        correction: list[list[float]] | None = None,
    ) -> None:
        size = int(controller.obs_size or 0)
        if observation_space.shape != (size,):
            raise ValueError(
                f"{type(self).__name__} needs an observation of shape ({size},), got "
                f"{observation_space.shape}"
            )
        super().__init__(observation_space, size + 3)
        self.base = controller
        self.correction = None if correction is None else PoseCorrection(correction)
        offset, scale = feature_scaling(controller.design, size, error_scale)
        self.register_buffer("offset", th.as_tensor(offset, dtype=th.float32))
        self.register_buffer("scale", th.as_tensor(scale, dtype=th.float32))

    def base_action(self, obs: th.Tensor) -> th.Tensor:
        """The base controller's actions ``(n, 3)`` for raw observations ``(n, obs_size)`` (no
        gradient flows through it: it is a fixed function of the observation)."""
        raw = obs.detach().cpu().numpy().astype(np.float64)
        if self.correction is not None:
            raw = self.correction.corrected(raw)
        action = self.base.predict(raw)[0]
        return th.as_tensor(action, dtype=obs.dtype, device=obs.device)

    def forward(self, observations: th.Tensor) -> th.Tensor:
        scaled = th.clamp((observations - self.offset) * self.scale, -FEATURE_CLIP, FEATURE_CLIP)
        return th.cat([scaled, self.base_action(observations)], dim=1)


class TrackFeatures(ControllerFeatures):
    """:class:`ControllerFeatures` of the tracking observation (34 entries, errors per
    :data:`ERROR_SCALE`) with the feed-forward controller as base: ``37`` features.

    Args:
        observation_space: ``Box((34,))`` of ``Planar3PTrack-v0``.
        design: the machine (a :class:`Design`, its dict, or ``None`` for ``Design.fig8()``).
        feedforward: the base controller's feed-forward scale (1 = full).
    """

    def __init__(
        self,
        observation_space: gym.spaces.Box,
        design: Design | dict[str, Any] | None = None,
        feedforward: float = 1.0,
    ) -> None:
        controller = TrackingController(design_from(design), feedforward=feedforward)
        super().__init__(observation_space, controller, ERROR_SCALE)


class ReachFeatures(ControllerFeatures):
    """:class:`ControllerFeatures` of the reach observation (31 entries, errors per
    :data:`REACH_ERROR_SCALE`) with the benchmark's ``analytic-simultaneous`` controller as
    base: ``34`` features.

    Args:
        observation_space: ``Box((31,))`` of ``Planar3P-v0``/``-v1`` or ``Planar3PReal-v0``.
        design: the machine (a :class:`Design`, its dict, or ``None`` for ``Design.fig8()``).
        correction: the weights of a learned :class:`PoseCorrection` the base acts through
            (nested lists), or ``None``.
    """

    def __init__(
        self,
        observation_space: gym.spaces.Box,
        design: Design | dict[str, Any] | None = None,
        correction: list[list[float]] | None = None,
    ) -> None:
        controller = AnalyticController(design_from(design), "simultaneous")
        super().__init__(observation_space, controller, REACH_ERROR_SCALE, correction)


class AssemblyFeatures(ControllerFeatures):
    """:class:`ControllerFeatures` of the assembly change's observation (36 entries, errors
    per :data:`REACH_ERROR_SCALE`) with the benchmark's ``analytic-simultaneous`` controller
    (reading the first 31 entries) as base: ``39`` features.

    Args:
        observation_space: ``Box((36,))`` of ``Planar3PAssemblyChange-v0``.
        design: the machine (a :class:`Design`, its dict, or ``None`` for
            ``Design.fig8(gravity=0.0)``, the task's default).
        correction: the weights of a learned :class:`PoseCorrection` the base acts through
            (nested lists), or ``None``.
    """

    def __init__(
        self,
        observation_space: gym.spaces.Box,
        design: Design | dict[str, Any] | None = None,
        correction: list[list[float]] | None = None,
    ) -> None:
        machine = Design.fig8(gravity=0.0) if design is None else design_from(design)
        controller = AnalyticController(machine, "simultaneous", observation_size=ASSEMBLY_OBS_SIZE)
        super().__init__(observation_space, controller, REACH_ERROR_SCALE, correction)


class LineFeatures(ControllerFeatures):
    """:class:`ControllerFeatures` of the reach observation (31 entries, errors per
    :data:`REACH_ERROR_SCALE`) with the ``certified-line`` baseline as base: ``34`` features.

    The base certifies a slider line per observation (about 0.2 ms each), and PPO evaluates
    the features of every rollout observation once per epoch: the base actions of the last
    :data:`BASE_CACHE_ROWS` distinct observations are kept, keyed by their float32 bytes.  The
    base is a fixed function of the observation, so a kept action is the one it would compute.

    Args:
        observation_space: ``Box((31,))`` of ``Planar3P-v0``/``-v1``.
        design: the machine (a :class:`Design`, its dict, or ``None`` for ``Design.fig8()``).
        gain: the base's slider-line gain (1/s); ``None``: its default, deadbeat.
    """

    def __init__(
        self,
        observation_space: gym.spaces.Box,
        design: Design | dict[str, Any] | None = None,
        gain: float | None = None,
    ) -> None:
        controller = CertifiedLineController(design_from(design), gain=gain)
        super().__init__(observation_space, controller, REACH_ERROR_SCALE)
        self._cache: dict[bytes, np.ndarray] = {}

    def base_action(self, obs: th.Tensor) -> th.Tensor:
        raw = obs.detach().cpu().numpy().astype(np.float32)
        keys = [row.tobytes() for row in raw]
        missing = [i for i, key in enumerate(keys) if key not in self._cache]
        if missing:
            if len(self._cache) + len(missing) > BASE_CACHE_ROWS:
                self._cache.clear()
            computed = self.base.predict(raw[missing].astype(np.float64))[0]
            self._cache.update(zip([keys[i] for i in missing], computed, strict=True))
        action = np.stack([self._cache[key] for key in keys]) if keys else np.zeros((0, 3))
        return th.as_tensor(action, dtype=obs.dtype, device=obs.device)


class PlannerFeatures(ControllerFeatures):
    """:class:`ControllerFeatures` of the mode change's observation (37 entries, errors per
    :data:`REACH_ERROR_SCALE`) with the ``planner`` baseline as base: ``40`` features.

    The planner plans at an episode's first step and follows its plan by a clock, so its
    action is not a function of the observation alone.  In evaluation mode (SB3's rollouts,
    its evaluations and ``predict``) this extractor keeps a planner per batch size, whose row
    ``i`` follows environment ``i``, and starts a row's plan afresh when the row's target (its
    pose, travels and working mode in the observation, constant within an episode) changes.
    The action of each observation is kept, keyed by its float32 bytes (the last
    :data:`BASE_CACHE_ROWS`): an observation met again is given the action it had, without
    moving the clock (SB3 asks for the values of a rollout's last observations, then acts on
    them), and in training mode (PPO's updates) the rollout's observations are all found
    there, so the updates see the base actions the rollout played.  An observation not met
    before in training mode is given the first action of a plan made from it.

    Args:
        observation_space: ``Box((37,))`` of ``Planar3PModeChange-v0``.
        design: the machine (a :class:`Design`, its dict, or ``None`` for ``Design.fig8()``).
        dt: control period (s) of the environment.
        correction: the weights of a learned :class:`PoseCorrection` the planner acts
            through (nested lists), or ``None``.
    """

    #: Observation entries that hold the target (constant within an episode).
    TARGET = np.r_[
        SLICES["target_position"],
        SLICES["target_orientation"],
        OBS_SIZE:MODE_CHANGE_OBS_SIZE,
    ]

    def __init__(
        self,
        observation_space: gym.spaces.Box,
        design: Design | dict[str, Any] | None = None,
        dt: float = 0.02,
        correction: list[list[float]] | None = None,
    ) -> None:
        controller = JointPathPlanner(design_from(design), dt=dt)
        super().__init__(observation_space, controller, REACH_ERROR_SCALE, correction)
        self._cache: dict[bytes, np.ndarray] = {}
        #: Per batch size: the planner that follows it and the targets of its last batch.
        self._followers: dict[int, tuple[JointPathPlanner, np.ndarray | None]] = {}

    def _plan_actions(self, raw: np.ndarray, fresh: bool) -> np.ndarray:
        """The planner's actions for the batch ``raw``; ``fresh``: the first action of a new
        plan from each row (no state kept)."""
        n = len(raw)
        planner, last = self._followers.get(n, (None, None))
        if planner is None or fresh:
            planner = JointPathPlanner(self.base.design, dt=self.base.dt)
        targets = raw[:, self.TARGET]
        starts = (
            np.ones(n, dtype=bool) if last is None or fresh else np.any(targets != last, axis=1)
        )
        if not fresh:
            self._followers[n] = (planner, targets)
        x = raw.astype(np.float64)
        if self.correction is not None:  # (the target entries stay as read)
            x = self.correction.corrected(x)
        return planner.predict(x, None, starts)[0]

    def _remember(self, keys: list[bytes], actions: np.ndarray) -> None:
        self._cache.update(zip(keys, actions, strict=True))
        while len(self._cache) > BASE_CACHE_ROWS:  # the oldest first (dicts keep insertion order)
            del self._cache[next(iter(self._cache))]

    def base_action(self, obs: th.Tensor) -> th.Tensor:
        raw = obs.detach().cpu().numpy().astype(np.float32)
        keys = [row.tobytes() for row in raw]
        if not keys:
            return th.zeros((0, 3), dtype=obs.dtype, device=obs.device)
        missing = [i for i, key in enumerate(keys) if key not in self._cache]
        if missing and self.training:
            fresh = self._plan_actions(raw[missing], fresh=True)
            self._remember([keys[i] for i in missing], fresh)
        elif missing:
            self._remember(keys, self._plan_actions(raw, fresh=False))
        action = np.stack([self._cache[key] for key in keys])
        return th.as_tensor(action, dtype=obs.dtype, device=obs.device)


class ResidualPolicy(BaseControllerPolicy):
    """PPO/A2C policy whose action mean is a base controller plus a bounded learned
    correction (module docstring).  Subclasses name the features extractor that holds the
    base controller (:attr:`features_class`).

    Args:
        observation_space, action_space, lr_schedule: as for SB3's ``ActorCriticPolicy``.
        residual_scale: largest correction per slider, as a fraction of ``max_speed``, in
            ``(0, 1]``.
        design: the machine of the environment (:class:`Design` dict or ``None`` for
            ``Design.fig8()``); the base controller and the feature scales use it.
        **kwargs: the other arguments of ``ActorCriticPolicy`` (``net_arch``,
            ``log_std_init``, ...); the features extractor is :attr:`features_class`.
    """

    features_class: type[ControllerFeatures] = ControllerFeatures

    def __init__(
        self,
        observation_space: gym.spaces.Space,
        action_space: gym.spaces.Space,
        lr_schedule: Any,
        *,
        residual_scale: float = RESIDUAL_SCALE,
        design: dict[str, Any] | None = None,
        **kwargs: Any,
    ) -> None:
        name = type(self).__name__
        if not (np.isfinite(residual_scale) and 0.0 < residual_scale <= 1.0):
            raise ValueError(f"residual_scale must be in (0, 1], got {residual_scale!r}")
        if not isinstance(action_space, gym.spaces.Box) or action_space.shape != (3,):
            raise ValueError(f"{name} needs a Box((3,)) action space, got {action_space}")
        if kwargs.get("use_sde"):
            raise ValueError(f"{name} supports the diagonal Gaussian only (no gSDE)")
        self.residual_scale = float(residual_scale)
        self.design_dict = design_from(design).to_dict()
        # The untrained correction is exactly zero: the policy starts as the base controller.
        self._build_on_base(observation_space, action_space, lr_schedule, kwargs)

    def _base_kwargs(self) -> dict[str, Any]:
        """Arguments of the base controller besides the design (stored with the model)."""
        return {}

    def _features_kwargs(self) -> dict[str, Any]:
        return {"design": self.design_dict, **self._base_kwargs()}

    def _own_parameters(self) -> dict[str, Any]:
        return {
            "residual_scale": self.residual_scale,
            "design": self.design_dict,
            **self._base_kwargs(),
        }

    # ------------------------------------------------------------------ the residual mean
    def _distribution(self, features: th.Tensor, latent_pi: th.Tensor) -> Distribution:
        """Gaussian around ``base + residual_scale * tanh(action_net(latent_pi))``; the base
        action is the last three features."""
        correction = self.residual_scale * th.tanh(self.action_net(latent_pi))
        mean = features[:, -3:] + correction
        assert isinstance(self.action_dist, DiagGaussianDistribution)
        return self.action_dist.proba_distribution(mean, self.log_std)

    def forward(
        self, obs: th.Tensor, deterministic: bool = False
    ) -> tuple[th.Tensor, th.Tensor, th.Tensor]:
        features = self.extract_features(obs)
        latent_pi, latent_vf = self._latents(features)
        values = self.value_net(latent_vf)
        distribution = self._distribution(self._pi_features(features), latent_pi)
        actions = distribution.get_actions(deterministic=deterministic)
        log_prob = distribution.log_prob(actions)
        return actions.reshape((-1, *self.action_space.shape)), values, log_prob

    def evaluate_actions(
        self, obs: th.Tensor, actions: th.Tensor
    ) -> tuple[th.Tensor, th.Tensor, th.Tensor | None]:
        features = self.extract_features(obs)
        latent_pi, latent_vf = self._latents(features)
        distribution = self._distribution(self._pi_features(features), latent_pi)
        return self.value_net(latent_vf), distribution.log_prob(actions), distribution.entropy()

    def get_distribution(self, obs: th.Tensor) -> Distribution:
        features = super(ActorCriticPolicy, self).extract_features(obs, self.pi_features_extractor)
        return self._distribution(features, self.mlp_extractor.forward_actor(features))

    def _latents(self, features: Any) -> tuple[th.Tensor, th.Tensor]:
        if self.share_features_extractor:
            return self.mlp_extractor(features)
        pi_features, vf_features = features
        return (
            self.mlp_extractor.forward_actor(pi_features),
            self.mlp_extractor.forward_critic(vf_features),
        )

    def _pi_features(self, features: Any) -> th.Tensor:
        return features if self.share_features_extractor else features[0]


class CorrectedBasePolicy(ResidualPolicy):
    """:class:`ResidualPolicy` whose base may act through a learned :class:`PoseCorrection`
    of the machine as built's pose reading: ``correction`` (its JSON file or weights, kept in
    the model as weights; ``None``: the reading as it is), handed to the features extractor.
    The other arguments are :class:`ResidualPolicy`'s."""

    resolve_policy_kwargs = staticmethod(weights_in_kwargs)

    def __init__(
        self, *args: Any, correction: str | list[list[float]] | None = None, **kwargs: Any
    ) -> None:
        self.correction = correction_weights(correction)
        super().__init__(*args, **kwargs)

    def _base_kwargs(self) -> dict[str, Any]:
        return {"correction": self.correction}


class ResidualTrackPolicy(ResidualPolicy):
    """:class:`ResidualPolicy` on the feed-forward tracking controller (``Planar3PTrack-v0``).

    Args:
        observation_space, action_space, lr_schedule, residual_scale, design, **kwargs: as
            for :class:`ResidualPolicy`.
        feedforward: the base controller's feed-forward scale (1 = full).
    """

    features_class = TrackFeatures

    def __init__(self, *args: Any, feedforward: float = 1.0, **kwargs: Any) -> None:
        self.feedforward = float(feedforward)
        super().__init__(*args, **kwargs)

    def _base_kwargs(self) -> dict[str, Any]:
        return {"feedforward": self.feedforward}


class ResidualReachPolicy(CorrectedBasePolicy):
    """:class:`CorrectedBasePolicy` on the benchmark's ``analytic-simultaneous`` controller
    (``Planar3P-v0``/``-v1``, ``Planar3PReal-v0``)."""

    features_class = ReachFeatures


class ResidualLinePolicy(ResidualPolicy):
    """:class:`ResidualPolicy` on the ``certified-line`` baseline (``Planar3P-v0``/``-v1``).

    Args:
        observation_space, action_space, lr_schedule, residual_scale, design, **kwargs: as
            for :class:`ResidualPolicy`.
        gain: the base's slider-line gain (1/s); ``None``: its default, deadbeat.
    """

    features_class = LineFeatures

    def __init__(self, *args: Any, gain: float | None = None, **kwargs: Any) -> None:
        self.gain = None if gain is None else float(gain)
        super().__init__(*args, **kwargs)

    def _base_kwargs(self) -> dict[str, Any]:
        return {"gain": self.gain}


class ResidualAssemblyPolicy(CorrectedBasePolicy):
    """:class:`CorrectedBasePolicy` on the benchmark's ``analytic-simultaneous`` controller for
    the assembly change (``Planar3PAssemblyChange-v0``, 36-entry observation; ``design``:
    ``None`` is ``Design.fig8(gravity=0.0)``, the task's default machine)."""

    features_class = AssemblyFeatures

    def __init__(self, *args: Any, design: dict[str, Any] | None = None, **kwargs: Any) -> None:
        machine = Design.fig8(gravity=0.0) if design is None else design_from(design)
        super().__init__(*args, design=machine.to_dict(), **kwargs)


class ResidualPlannerPolicy(CorrectedBasePolicy):
    """:class:`CorrectedBasePolicy` on the ``planner`` baseline for the mode change
    (``Planar3PModeChange-v0``, 37-entry observation; :class:`PlannerFeatures` keeps the
    planner's state).

    Args:
        *args, **kwargs: as for :class:`CorrectedBasePolicy` (``correction`` included).
        dt: control period (s) of the environment (default 0.02, the ids' 50 Hz).
    """

    features_class = PlannerFeatures

    def __init__(self, *args: Any, dt: float = 0.02, **kwargs: Any) -> None:
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be finite and > 0, got {dt!r}")
        self.dt = float(dt)
        super().__init__(*args, **kwargs)

    def _base_kwargs(self) -> dict[str, Any]:
        return {**super()._base_kwargs(), "dt": self.dt}
