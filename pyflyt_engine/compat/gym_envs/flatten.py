"""``FlattenWaypointEnv`` with the reference's observation layout."""

from __future__ import annotations

from typing import Any, cast

import gymnasium
import numpy as np
from gymnasium import spaces


class FlattenWaypointEnv(gymnasium.ObservationWrapper):
    """A waypoint env's ``Dict(attitude, target_deltas)`` observation as one Box, as the reference's.

    PyFlyt 0.29.0 FlattenWaypointEnv: ``[attitude (A), next K target deltas (K x D,
    zero-padded)]``, shape ``(A + K * D,)``, space dtype float32 (Gymnasium's default);
    ``context_length`` K defaults to 2.  The observation is cast to float32 so that it
    lies in that space.  The native wrapper (:class:`pyflyt_engine.envs.FlattenWaypointEnv`)
    adds a K-entry mask telling padding from a real target at the origin, in float64.
    """

    def __init__(self, env: gymnasium.Env, context_length: int = 2) -> None:
        super().__init__(env)
        space = env.observation_space
        if not (
            isinstance(space, spaces.Dict)
            and isinstance(space.spaces.get("attitude"), spaces.Box)
            and isinstance(space.spaces.get("target_deltas"), spaces.Sequence)
        ):
            raise AttributeError("Only a waypoints environment can be used with the `FlattenWaypointEnv` wrapper.")
        self.context_length = int(context_length)
        self.attitude_shape = int(cast(spaces.Box, space["attitude"]).shape[0])
        self.target_shape = int(cast(spaces.Box, cast(spaces.Sequence, space["target_deltas"]).feature_space).shape[0])
        self.observation_space = spaces.Box(
            low=-np.inf, high=np.inf, shape=(self.attitude_shape + self.target_shape * self.context_length,)
        )

    def observation(self, observation: dict[str, Any]) -> np.ndarray:
        deltas = np.asarray(observation["target_deltas"])
        n = min(self.context_length, deltas.shape[0])
        out = np.zeros(self.attitude_shape + self.target_shape * self.context_length, dtype=np.float32)
        out[: self.attitude_shape] = observation["attitude"]
        if n:
            out[self.attitude_shape : self.attitude_shape + n * self.target_shape] = deltas[:n].reshape(-1)
        return out
