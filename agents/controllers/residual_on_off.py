"""Residual policy on the on-off motors: PPO's motor commands biased towards the bang-bang law.

:class:`ResidualOnOffPolicy` is the on-off counterpart of
:mod:`planar3p_agents.controllers.residual`: a Stable-Baselines3 actor-critic policy for the
``MultiDiscrete([3, 3, 3])`` motor commands of ``Planar3PRealOnOff-v0`` whose logits are

    ``logits = base_logit * onehot(analytic-on-off command) + action_net(latent)``

* the base command is the ``analytic-on-off`` baseline's
  (:class:`~planar3p_agents.controllers.on_off.OnOffController` on the simultaneous simple
  motions, default gains), evaluated on the raw observation;
* ``action_net`` starts at zero, so the untrained policy's most likely command *is* the
  baseline's, and it samples it with probability ``e^b / (e^b + 2)`` per motor (``b`` =
  ``base_logit``: 0.91 for 3); PPO learns where to depart from it.

The observation reaches the network scaled by fixed physical scales (as in the residual reach
policy: :func:`~planar3p_agents.controllers.residual.feature_scaling`), followed by the base
command's one-hot, so train with ``normalize: "dict(norm_obs=False, norm_reward=True)"``.  The
one-hot is handed past the hidden layers to the output (:class:`BasePassingExtractor`), so the
logit bias needs no change to SB3's distributions.  A trained model is an ordinary SB3 ``PPO``
model of the id: the benchmark plays it like any other.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import torch as th
from stable_baselines3.common.distributions import Distribution
from stable_baselines3.common.policies import ActorCriticPolicy
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor, MlpExtractor
from torch import nn

from planar3p_agents.controllers.analytic import AnalyticController
from planar3p_agents.controllers.on_off import OnOffController
from planar3p_agents.controllers.residual import FEATURE_CLIP, REACH_ERROR_SCALE, feature_scaling
from planar3p_gym.checks import design_from
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks.observation import OBS_SIZE

__all__ = ["BASE_LOGIT", "BasePassingExtractor", "OnOffFeatures", "ResidualOnOffPolicy"]

#: Default logit bias of the base command (per motor: probability ``e^3 / (e^3 + 2)`` = 0.91).
BASE_LOGIT = 3.0
#: Motors and commands per motor of the on-off action (stop, forward, backward).
_MOTORS, _COMMANDS = 3, 3
_ONE_HOT = _MOTORS * _COMMANDS


class OnOffFeatures(BaseFeaturesExtractor):
    """The reach observation scaled by :func:`feature_scaling` (position errors per
    :data:`REACH_ERROR_SCALE`, clipped to :data:`FEATURE_CLIP`), followed by the one-hot of
    the ``analytic-on-off`` command (motor ``i``'s command ``c`` at ``3 i + c``): 40 features.

    Args:
        observation_space: ``Box((31,))`` of ``Planar3PRealOnOff-v0``.
        design: the machine (a :class:`Design`, its dict, or ``None`` for ``Design.fig8()``).
    """

    def __init__(
        self, observation_space: gym.spaces.Box, design: Design | dict[str, Any] | None = None
    ) -> None:
        if observation_space.shape != (OBS_SIZE,):
            raise ValueError(
                f"OnOffFeatures needs an observation of shape ({OBS_SIZE},), got "
                f"{observation_space.shape}"
            )
        super().__init__(observation_space, OBS_SIZE + _ONE_HOT)
        machine = design_from(design)
        self.base = OnOffController(AnalyticController(machine))
        offset, scale = feature_scaling(machine, OBS_SIZE, REACH_ERROR_SCALE)
        self.register_buffer("offset", th.as_tensor(offset, dtype=th.float32))
        self.register_buffer("scale", th.as_tensor(scale, dtype=th.float32))

    def base_one_hot(self, obs: th.Tensor) -> th.Tensor:
        """One-hot ``(n, 9)`` of the base commands for raw observations ``(n, 31)`` (a fixed
        function of the observation: no gradient)."""
        raw = np.atleast_2d(obs.detach().cpu().numpy().astype(np.float64))
        digits = np.atleast_2d(self.base.predict(raw)[0])
        one_hot = np.zeros((raw.shape[0], _ONE_HOT), dtype=np.float32)
        rows = np.arange(raw.shape[0])[:, None]
        one_hot[rows, _COMMANDS * np.arange(_MOTORS) + digits] = 1.0
        return th.as_tensor(one_hot, device=obs.device)

    def forward(self, observations: th.Tensor) -> th.Tensor:
        scaled = th.clamp((observations - self.offset) * self.scale, -FEATURE_CLIP, FEATURE_CLIP)
        return th.cat([scaled, self.base_one_hot(observations)], dim=1)


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


class ResidualOnOffPolicy(ActorCriticPolicy):
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
        for key in ("features_extractor_class", "features_extractor_kwargs"):
            if key in kwargs:
                raise ValueError(f"ResidualOnOffPolicy sets its own {key}")
        self.base_logit = float(base_logit)
        self.design_dict = design_from(design).to_dict()
        super().__init__(
            observation_space,
            action_space,
            lr_schedule,
            features_extractor_class=OnOffFeatures,
            features_extractor_kwargs={"design": self.design_dict},
            **kwargs,
        )
        # The untrained departure is exactly zero: the policy starts as the baseline.
        nn.init.zeros_(self.action_net.weight)
        nn.init.zeros_(self.action_net.bias)

    def _build_mlp_extractor(self) -> None:
        super()._build_mlp_extractor()
        self.mlp_extractor = BasePassingExtractor(self.mlp_extractor)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        data = super()._get_constructor_parameters()
        data.pop("features_extractor_class", None)
        data.pop("features_extractor_kwargs", None)
        data.update(base_logit=self.base_logit, design=self.design_dict)
        return data

    def _get_action_dist_from_latent(self, latent_pi: th.Tensor) -> Distribution:
        """Categorical per motor with logits ``base_logit * one-hot + action_net(latent)``
        (the one-hot is the latent's last 9 entries)."""
        logits = self.action_net(latent_pi) + self.base_logit * latent_pi[:, -_ONE_HOT:]
        return self.action_dist.proba_distribution(action_logits=logits)
