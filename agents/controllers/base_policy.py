"""The SB3 policy on a base controller, written once for the residual policies.

A residual policy's features extractor holds its base controller, and its output layer starts
at zero so that the untrained policy is the base.  :class:`BaseControllerPolicy` is that part
of SB3's ``ActorCriticPolicy``, shared by the continuous residuals
(:mod:`planar3p_agents.controllers.residual`) and the on-off ones
(:mod:`planar3p_agents.controllers.residual_on_off`):

* the features extractor is the class's :attr:`BaseControllerPolicy.features_class`, built
  with :meth:`BaseControllerPolicy._features_kwargs` (a caller may not set either);
* the action head is zeroed after SB3 built it;
* the saved constructor parameters name the policy's own arguments
  (:meth:`BaseControllerPolicy._own_parameters`), not the features extractor.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
from stable_baselines3.common.policies import ActorCriticPolicy
from torch import nn

__all__ = ["BaseControllerPolicy"]


class BaseControllerPolicy(ActorCriticPolicy):
    """``ActorCriticPolicy`` whose features extractor holds a base controller (module
    docstring).  Subclasses check their own arguments, then call
    :meth:`_build_on_base` in place of ``ActorCriticPolicy.__init__``."""

    #: The features extractor (it computes the base's action).
    features_class: type[nn.Module]

    def _build_on_base(
        self,
        observation_space: gym.spaces.Space,
        action_space: gym.spaces.Space,
        lr_schedule: Any,
        kwargs: dict[str, Any],
    ) -> None:
        """``ActorCriticPolicy.__init__`` with :attr:`features_class` and its arguments, then
        the action head zeroed: the untrained policy is the base.  ``ValueError`` where
        ``kwargs`` sets the features extractor."""
        for key in ("features_extractor_class", "features_extractor_kwargs"):
            if key in kwargs:
                raise ValueError(f"{type(self).__name__} sets its own {key}")
        super().__init__(
            observation_space,
            action_space,
            lr_schedule,
            features_extractor_class=self.features_class,
            features_extractor_kwargs=self._features_kwargs(),
            **kwargs,
        )
        nn.init.zeros_(self.action_net.weight)
        nn.init.zeros_(self.action_net.bias)

    def _features_kwargs(self) -> dict[str, Any]:
        """Arguments of :attr:`features_class` besides the observation space."""
        raise NotImplementedError

    def _own_parameters(self) -> dict[str, Any]:
        """The policy's own constructor arguments, saved with the model."""
        raise NotImplementedError

    def _get_constructor_parameters(self) -> dict[str, Any]:
        data = super()._get_constructor_parameters()
        data.pop("features_extractor_class", None)
        data.pop("features_extractor_kwargs", None)
        data.update(self._own_parameters())
        return data
