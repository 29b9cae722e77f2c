"""``FixedwingBaseEnv``: the reference's fixed-wing base env, for tasks users write (see :mod:`.._aviary_base`)."""

from __future__ import annotations

from typing import Literal

import numpy as np
from gymnasium import spaces

from pyflyt_engine.compat.gym_envs._aviary_base import AviaryTaskEnv

# the names the reference's module holds through its own imports, for code that takes them from here
from pyflyt_engine.compat.core.aviary import Aviary
from pyflyt_engine.compat.core.utils.compile_helpers import check_numpy

__all__ = ["Aviary", "FixedwingBaseEnv", "check_numpy"]


class FixedwingBaseEnv(AviaryTaskEnv):
    """A fixed-wing task over the compat Aviary, filled in by a subclass.

    PyFlyt 0.29.0 FixedwingBaseEnv: ``start_pos`` [[0, 0, 10]], ``start_orn`` [[0, 0, 0]],
    ``flight_mode`` 0, ``flight_dome_size`` inf, ``max_duration_seconds`` 10,
    ``angle_representation`` "quaternion", ``agent_hz`` 30; action [roll, pitch, yaw,
    thrust] in [-1, 1]^4, the thrust entry reaching the aircraft as ``T / 2 + 0.5``;
    auxiliary state 6 entries; a crash is any contact.
    """

    drone_type = "fixedwing"
    aux_size = 6

    def __init__(
        self,
        start_pos: np.ndarray = np.array([[0.0, 0.0, 10.0]]),  # noqa: B008 - the reference's signature
        start_orn: np.ndarray = np.array([[0.0, 0.0, 0.0]]),  # noqa: B008
        flight_mode: int = 0,
        flight_dome_size: float = np.inf,
        max_duration_seconds: float = 10.0,
        angle_representation: Literal["euler", "quaternion"] = "quaternion",
        agent_hz: int = 30,
        render_mode: None | Literal["human", "rgb_array"] = None,
        render_resolution: tuple[int, int] = (480, 480),
    ) -> None:
        super().__init__(
            start_pos,
            start_orn,
            flight_mode,
            flight_dome_size,
            max_duration_seconds,
            angle_representation,
            agent_hz,
            render_mode,
            render_resolution,
        )

    def _make_action_space(self, flight_mode: int) -> spaces.Box:
        return spaces.Box(-np.ones(4), np.ones(4), dtype=np.float64)

    def _crashed(self) -> bool:
        return bool(np.any(self.env.contact_array))

    def _to_setpoint(self, action: np.ndarray) -> np.ndarray:
        action[..., -1] = action[..., -1] / 2.0 + 0.5
        return action
