"""Residual policies on the on-off motors: PPO's motor commands biased towards an on-off law.

:class:`ResidualOnOffPolicy` is the on-off counterpart of
:mod:`planar3p_agents.controllers.residual`: a Stable-Baselines3 actor-critic policy for the
``MultiDiscrete([3, 3, 3])`` motor commands of ``Planar3PRealOnOff-v0`` whose logits are

    ``logits = base_logit * onehot(base command) + action_net(latent)``

* the base command is the ``analytic-on-off`` baseline's
  (:class:`~planar3p_agents.controllers.on_off.OnOffController` on the simultaneous simple
  motions); :class:`PredictiveResidualOnOffPolicy`'s is ``analytic-on-off-predictive``'s
  (:mod:`~planar3p_agents.controllers.predictive_on_off`), which needs the command in flight:
  that policy observes it (:mod:`planar3p_agents.policies.command_memory`);
* ``action_net`` starts at zero, so the untrained policy's most likely command *is* the
  baseline's, sampled with probability ``e^b / (e^b + 2)`` per motor (``b`` = ``base_logit``:
  0.91 for 3); PPO learns where to depart from it.

The observation reaches the network scaled by fixed physical scales
(:func:`~planar3p_agents.controllers.residual.feature_scaling`), then the base command's
one-hot, so train with ``normalize: "dict(norm_obs=False, norm_reward=True)"``; the one-hot is
handed past the hidden layers to the output (:class:`BasePassingExtractor`).  A trained model
is an ordinary SB3 ``PPO`` model of the id: the benchmark plays it like any other.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import torch as th
from stable_baselines3.common.distributions import Distribution
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor, MlpExtractor
from torch import nn

from planar3p_agents.controllers.analytic import AnalyticController
from planar3p_agents.controllers.base_policy import BaseControllerPolicy
from planar3p_agents.controllers.on_off import OnOffController
from planar3p_agents.controllers.pose_correction import (
    PoseCorrection,
    correction_weights,
    weights_in_kwargs,
)
from planar3p_agents.controllers.predictive_on_off import (
    PredictiveOnOffController,
    digits_of,
    signs_of,
)
from planar3p_agents.controllers.residual import FEATURE_CLIP, REACH_ERROR_SCALE, feature_scaling
from planar3p_agents.policies.command_memory import (
    COMMAND_ENTRIES,
    command_one_hot,
    with_command_memory,
)
from planar3p_gym.checks import design_from
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks.observation import OBS_SIZE

__all__ = [
    "BASE_LOGIT",
    "BasePassingExtractor",
    "OnOffFeatures",
    "PredictiveOnOffFeatures",
    "PredictiveResidualOnOffPolicy",
    "ResidualOnOffPolicy",
]

#: Default logit bias of the base command (per motor: probability ``e^3 / (e^3 + 2)`` = 0.91).
BASE_LOGIT = 3.0
#: Motors and commands per motor of the on-off action (stop, forward, backward).
_MOTORS, _COMMANDS = 3, 3
_ONE_HOT = _MOTORS * _COMMANDS


class OnOffFeatures(BaseFeaturesExtractor):
    """The reach observation scaled by :func:`feature_scaling` (position errors per
    :data:`REACH_ERROR_SCALE`, clipped to :data:`FEATURE_CLIP`), the entries the observation
    has after it (none here), then the one-hot of the base command (motor ``i``'s command ``c``
    at ``3 i + c``; here ``analytic-on-off``'s): 40 features.

    Args:
        observation_space: ``Box((31,))`` of ``Planar3PRealOnOff-v0``.
        design: the machine (a :class:`Design`, its dict, or ``None`` for ``Design.fig8()``).
    """

    #: Commands in flight the observation carries after its 31 entries.
    observed_commands = 0

    def __init__(
        self, observation_space: gym.spaces.Box, design: Design | dict[str, Any] | None = None
    ) -> None:
        size = OBS_SIZE + self.observed_commands * COMMAND_ENTRIES
        if observation_space.shape != (size,):
            raise ValueError(
                f"{type(self).__name__} needs an observation of shape ({size},), got "
                f"{observation_space.shape}"
            )
        super().__init__(observation_space, size + _ONE_HOT)
        machine = design_from(design)
        self.base = self._base(machine)
        offset, scale = feature_scaling(machine, OBS_SIZE, REACH_ERROR_SCALE)
        self.register_buffer("offset", th.as_tensor(offset, dtype=th.float32))
        self.register_buffer("scale", th.as_tensor(scale, dtype=th.float32))

    def _base(self, machine: Design) -> Any:
        return OnOffController(AnalyticController(machine))

    def base_digits(self, raw: np.ndarray) -> np.ndarray:
        """The base's motor commands ``(n, 3)`` for raw observations ``(n, d)``."""
        return np.atleast_2d(self.base.predict(raw)[0])

    def base_one_hot(self, obs: th.Tensor) -> th.Tensor:
        """One-hot ``(n, 9)`` of the base commands for raw observations (a fixed function of
        the observation: no gradient)."""
        raw = np.atleast_2d(obs.detach().cpu().numpy().astype(np.float64))
        return th.as_tensor(command_one_hot(self.base_digits(raw)), device=obs.device)

    def forward(self, observations: th.Tensor) -> th.Tensor:
        head = observations[:, :OBS_SIZE]
        scaled = th.clamp((head - self.offset) * self.scale, -FEATURE_CLIP, FEATURE_CLIP)
        tail = observations[:, OBS_SIZE:]
        return th.cat([scaled, tail, self.base_one_hot(observations)], dim=1)


class PredictiveOnOffFeatures(OnOffFeatures):
    """:class:`OnOffFeatures` of the observation followed by the one-hot of the command in
    flight (:mod:`planar3p_agents.policies.command_memory`), with the base command
    ``analytic-on-off-predictive``'s (one step of delay), on the errors corrected by a learned
    :class:`PoseCorrection` if one is given: 49 features.

    Args:
        observation_space: ``Box((40,))``.
        design: as for :class:`OnOffFeatures`.
        correction: the correction's weights (nested lists), or ``None``.
    """

    observed_commands = 1

    def __init__(
        self,
        observation_space: gym.spaces.Box,
        design: Design | dict[str, Any] | None = None,
        correction: list[list[float]] | None = None,
    ) -> None:
        self.correction = None if correction is None else PoseCorrection(correction)
        super().__init__(observation_space, design)

    def _base(self, machine: Design) -> Any:
        return PredictiveOnOffController(machine, delay=1, correction=self.correction)

    def base_digits(self, raw: np.ndarray) -> np.ndarray:
        sent = raw[:, OBS_SIZE : OBS_SIZE + COMMAND_ENTRIES].reshape(-1, _MOTORS, _COMMANDS)
        in_flight = signs_of(sent.argmax(axis=2))
        return digits_of(self.base.signed_commands(raw[:, :OBS_SIZE], in_flight))


class BasePassingExtractor(nn.Module):
    """SB3's :class:`MlpExtractor` whose actor latent also carries the features' last 9
    entries (the base command's one-hot), so the action head can add the logit bias."""

    def __init__(self, inner: MlpExtractor) -> None:
        super().__init__()
        self.inner = inner
        self.latent_dim_pi = inner.latent_dim_pi + _ONE_HOT
        self.latent_dim_vf = inner.latent_dim_vf

    def forward(self, features: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        return self.forward_actor(features), self.forward_critic(features)

    def forward_actor(self, features: th.Tensor) -> th.Tensor:
        return th.cat([self.inner.forward_actor(features), features[:, -_ONE_HOT:]], dim=1)

    def forward_critic(self, features: th.Tensor) -> th.Tensor:
        return self.inner.forward_critic(features)


class ResidualOnOffPolicy(BaseControllerPolicy):
    """PPO policy of the on-off motors biased towards the ``analytic-on-off`` command (module
    docstring).

    Args:
        observation_space, action_space, lr_schedule: as for SB3's ``ActorCriticPolicy``
            (``Box((31,))`` and ``MultiDiscrete([3, 3, 3])``).
        base_logit: logit added to the base command of each motor, > 0.
        design: the machine of the environment (:class:`Design` dict or ``None`` for
            ``Design.fig8()``).
        **kwargs: the other arguments of ``ActorCriticPolicy`` (``net_arch``, ...); the
            features extractor is :class:`OnOffFeatures`.
    """

    #: The features extractor (it computes the base command).
    features_class: type[OnOffFeatures] = OnOffFeatures
    #: Commands in flight the observation carries (:mod:`planar3p_agents.policies.command_memory`).
    observed_commands = 0

    def __init__(
        self,
        observation_space: gym.spaces.Space,
        action_space: gym.spaces.Space,
        lr_schedule: Any,
        *,
        base_logit: float = BASE_LOGIT,
        design: dict[str, Any] | None = None,
        **kwargs: Any,
    ) -> None:
        expected = gym.spaces.MultiDiscrete([_COMMANDS] * _MOTORS)
        if action_space != expected:
            raise ValueError(f"ResidualOnOffPolicy needs {expected}, got {action_space}")
        if not (
            isinstance(base_logit, (int, float)) and np.isfinite(base_logit) and base_logit > 0
        ):
            raise ValueError(f"base_logit must be a finite number > 0, got {base_logit!r}")
        self.base_logit = float(base_logit)
        self.design_dict = design_from(design).to_dict()
        # The untrained departure is exactly zero: the policy starts as the baseline.
        self._build_on_base(observation_space, action_space, lr_schedule, kwargs)

    def _features_kwargs(self) -> dict[str, Any]:
        return {"design": self.design_dict}

    def _own_parameters(self) -> dict[str, Any]:
        return {"base_logit": self.base_logit, "design": self.design_dict}

    def _build_mlp_extractor(self) -> None:
        super()._build_mlp_extractor()
        self.mlp_extractor = BasePassingExtractor(self.mlp_extractor)

    def _get_action_dist_from_latent(self, latent_pi: th.Tensor) -> Distribution:
        """Categorical per motor with logits ``base_logit * one-hot + action_net(latent)``
        (the one-hot is the latent's last 9 entries)."""
        logits = self.action_net(latent_pi) + self.base_logit * latent_pi[:, -_ONE_HOT:]
        return self.action_dist.proba_distribution(action_logits=logits)


class PredictiveResidualOnOffPolicy(ResidualOnOffPolicy):
    """:class:`ResidualOnOffPolicy` on ``analytic-on-off-predictive``, which needs the command
    in flight: the observation is followed by its one-hot (:class:`PredictiveOnOffFeatures`).

    Trained on :class:`~planar3p_agents.policies.command_memory.VecCommandMemory` environments
    (``planar3p train`` adds it for this class); played on the environment's own observation,
    :meth:`predict` appends the command it returned as ``state`` at the previous step.

    Args:
        correction: a learned :class:`PoseCorrection` for the base (its JSON file or
            weights), or ``None``; the other arguments are :class:`ResidualOnOffPolicy`'s.
    """

    features_class = PredictiveOnOffFeatures
    observed_commands = 1

    def __init__(
        self,
        observation_space: gym.spaces.Space,
        action_space: gym.spaces.Space,
        lr_schedule: Any,
        *,
        correction: str | list[list[float]] | None = None,
        **kwargs: Any,
    ) -> None:
        self.correction = correction_weights(correction)
        super().__init__(observation_space, action_space, lr_schedule, **kwargs)

    resolve_policy_kwargs = staticmethod(weights_in_kwargs)

    def _features_kwargs(self) -> dict[str, Any]:
        return {**super()._features_kwargs(), "correction": self.correction}

    def _own_parameters(self) -> dict[str, Any]:
        return {**super()._own_parameters(), "correction": self.correction}

    @property
    def played_observation_space(self) -> gym.spaces.Box:
        """The environment's observation, without the command in flight."""
        space = self.observation_space
        return gym.spaces.Box(space.low[:OBS_SIZE], space.high[:OBS_SIZE], dtype=space.dtype)

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = False,
    ) -> tuple[np.ndarray, Any]:
        """SB3's ``predict``; on an observation of the environment's own 31 entries the command
        in flight is appended from ``state`` and the new command is returned as the state."""
        if np.shape(observation)[-1] != OBS_SIZE:
            return super().predict(observation, state, episode_start, deterministic)
        full, single = with_command_memory(observation, state, episode_start)
        actions, _ = super().predict(full, None, None, deterministic)
        actions = np.asarray(actions).reshape(full.shape[0], _MOTORS)
        return (actions[0] if single else actions), actions.copy()
