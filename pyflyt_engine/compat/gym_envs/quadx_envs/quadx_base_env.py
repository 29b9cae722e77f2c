"""``QuadXBaseEnv``: the reference's QuadX base env, for tasks users write (see :mod:`.._aviary_base`)."""

from __future__ import annotations

from typing import Literal

import numpy as np
from gymnasium import spaces

from pyflyt_engine.compat.gym_envs._aviary_base import AviaryTaskEnv
from pyflyt_engine.compat.gym_envs._base import QUADX_RATE_LIMIT, QUADX_THRUST_LIMIT

# the names the reference's module holds through its own imports, for code that takes them from here
from pyflyt_engine.compat.core.aviary import Aviary
from pyflyt_engine.compat.core.utils.compile_helpers import check_numpy

__all__ = ["Aviary", "QuadXBaseEnv", "check_numpy"]


class QuadXBaseEnv(AviaryTaskEnv):
    """A QuadX task over the compat Aviary, filled in by a subclass.

    PyFlyt 0.29.0 QuadXBaseEnv: ``start_pos`` [[0, 0, 1]], ``start_orn`` [[0, 0, 0]],
    ``flight_mode`` 0, ``flight_dome_size`` inf, ``max_duration_seconds`` 10,
    ``angle_representation`` "quaternion", ``agent_hz`` 30; action mode -1: four motor
    commands in [0, 0.8], else [p, q, r, T] in [-pi, pi]^3 x [0, 0.8]; auxiliary state 4
    entries; a crash is contact with the ground plane.
    """

    drone_type = "quadx"
    aux_size = 4

    def __init__(
        self,
        start_pos: np.ndarray = np.array([[0.0, 0.0, 1.0]]),  # noqa: B008 - the reference's signature
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
        if flight_mode == -1:
            return spaces.Box(np.zeros(4), np.full(4, QUADX_THRUST_LIMIT), dtype=np.float64)
        r = QUADX_RATE_LIMIT
        return spaces.Box(np.array([-r, -r, -r, 0.0]), np.array([r, r, r, QUADX_THRUST_LIMIT]), dtype=np.float64)
