"""Wrappers for the environments (cross-cutting concerns live here, not in subclasses)."""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces


class FlattenWaypointEnv(gymnasium.ObservationWrapper):
    """A waypoint env's ``Dict(attitude, target_deltas)`` observation as one fixed-size Box.

    Stable-Baselines3 (and most algorithms) need a fixed-size vector; the waypoint envs
    observe a variable-length sequence of targets.  This wrapper keeps the next
    ``context_length`` = K targets::

        [attitude (A), deltas of the next K waypoints (K x D, zero-padded), mask (K)]

    where ``D`` is the size of one delta (3: body-frame x, y, z [m]) and ``mask[i]`` is
    1.0 when slot ``i`` holds a real waypoint, 0.0 when it is padding.  Shape
    ``(A + K * D + K,)``, float64.

    Any other entry of the ``Dict`` (a camera ``image``) is kept: the observation is then a
    ``Dict`` of that vector under ``attitude`` and the other entries unchanged (what SB3's
    ``MultiInputPolicy`` takes).

    Args:
        env: an env whose observation space is ``Dict(attitude=Box, target_deltas=Sequence(Box))``.
        context_length: K, the number of upcoming waypoints kept (default 2, as the
            reference PyFlyt's wrapper).
    """

    def __init__(self, env: gymnasium.Env, context_length: int = 2) -> None:
        super().__init__(env)
        space = env.observation_space
        attitude = space.spaces.get("attitude") if isinstance(space, spaces.Dict) else None
        deltas = space.spaces.get("target_deltas") if isinstance(space, spaces.Dict) else None
        if not (
            isinstance(space, spaces.Dict)
            and isinstance(attitude, spaces.Box)
            and isinstance(deltas, spaces.Sequence)
            and isinstance(deltas.feature_space, spaces.Box)
        ):
            raise TypeError(
                f"FlattenWaypointEnv needs a Dict(attitude=Box, target_deltas=Sequence(Box)) observation space, got {space}"
            )
        if context_length < 1:
            raise ValueError(f"context_length must be >= 1, got {context_length}")
        self.context_length = int(context_length)
        self._attitude_size = int(np.prod(attitude.shape))
        self._delta_size = int(np.prod(deltas.feature_space.shape))
        size = self._attitude_size + self.context_length * (self._delta_size + 1)
        flat = spaces.Box(-np.inf, np.inf, shape=(size,), dtype=np.float64)
        self._others = [k for k in space.spaces if k not in ("attitude", "target_deltas")]
        self.observation_space = (
            spaces.Dict({"attitude": flat, **{k: space[k] for k in self._others}}) if self._others else flat
        )

    def observation(self, observation: dict[str, Any]) -> np.ndarray | dict[str, Any]:
        k, a, d = self.context_length, self._attitude_size, self._delta_size
        out = np.zeros(a + k * (d + 1), dtype=np.float64)
        out[:a] = observation["attitude"]
        deltas = np.asarray(observation["target_deltas"], dtype=np.float64).reshape(-1, d)[:k]
        n = len(deltas)
        out[a : a + n * d] = deltas.ravel()
        out[a + k * d : a + k * d + n] = 1.0
        if self._others:
            return {"attitude": out, **{key: observation[key] for key in self._others}}
        return out
