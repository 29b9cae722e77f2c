"""What the QuadX oracles share: a velocity-to-body-rates law and the reading of a ``Dict`` observation.

The oracles themselves live with the task they fly (``quadx_forest_navigator`` in
:mod:`pyflyt_engine.envs.tasks.goal`, ``quadx_gate_racer`` in
:mod:`pyflyt_engine.envs.tasks.gates`); :mod:`pyflyt_engine.envs.oracles` builds them by name.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from pyflyt_engine import exact
from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.frames import quaternion_to_rows


def dict_observation(env: Any) -> Callable[[Any], dict[str, np.ndarray]]:
    """The env's ``Dict`` observation from what an oracle is handed: the dict itself (the
    env as made) or the flat vector an agent sees (Gymnasium's ``FlattenObservation``)."""
    from gymnasium import spaces

    space = env.unwrapped.observation_space

    def unpack(obs: Any) -> dict[str, np.ndarray]:
        if isinstance(obs, dict):
            return obs
        return spaces.unflatten(space, np.asarray(obs, dtype=np.float64))

    return unpack


class QuadXVelocityPilot:
    """Body rates and thrust (``rates_thrust``) that fly a QuadX at a ground-frame velocity.

    From the attitude vector of the QuadX envs (quaternion layout: body rates, attitude,
    body velocity, position, ...) alone, with no state of its own:

    * the wanted acceleration ``a = k_v (v_want - v)``, its horizontal part capped at
      ``max_tilt`` worth (``g tan(max_tilt)``) and its vertical part at +-``max_climb_acc``;
    * the specific force ``f = a + g z``: its component along the body's z axis, over the
      full collective (``mass / max_collective`` of the airframe), is the thrust fraction;
    * body rates turning the body's z axis toward ``f``: ``k_att`` times the axis of the
      rotation that carries one to the other (in the body frame), and a yaw rate
      ``k_yaw`` times the heading error to ``heading`` (none when ``heading`` is None).
    """

    def __init__(
        self,
        env: Any,
        k_v: float = 3.0,
        k_att: float = 6.0,
        k_yaw: float = 2.0,
        max_tilt: float = 0.35,
        max_climb_acc: float = 4.0,
    ) -> None:
        base = env.unwrapped
        if base.config.angle_representation != "quaternion":
            raise ConfigError(
                "the QuadX oracles read the attitude as a quaternion: set env.angle_representation=quaternion"
            )
        controller = base.vehicle.controller
        if controller is None or base.config.action.mode != "rates_thrust":
            raise ConfigError("the QuadX oracles fly a multirotor in flight mode rates_thrust (env.action.mode)")
        self.per_newton = 1.0 / controller.mixer.max_collective  # thrust fraction per newton
        self.mass = controller.mass
        self.rate_limit = float(base.action_space.high[0])
        self.k_v, self.k_att, self.k_yaw = k_v, k_att, k_yaw
        self.max_horizontal = GRAVITY * math.tan(max_tilt)
        self.max_climb_acc = max_climb_acc

    @staticmethod
    def state(attitude: np.ndarray) -> tuple[tuple[tuple[float, float, float], ...], list[float], list[float]]:
        """(body-to-ground rows, ground-frame velocity, position) from the attitude vector."""
        rows = quaternion_to_rows(attitude[3:7].tolist())
        return rows, list(exact.rotate(rows, attitude[7:10].tolist())), attitude[10:13].tolist()

    def __call__(self, attitude: np.ndarray, velocity: Sequence[float], heading: float | None = None) -> np.ndarray:
        rows, v, _ = self.state(attitude)
        ax, ay, az = (self.k_v * (w - u) for w, u in zip(velocity, v))
        horizontal = math.hypot(ax, ay)
        if horizontal > self.max_horizontal:
            ax, ay = ax * self.max_horizontal / horizontal, ay * self.max_horizontal / horizontal
        az = min(max(az, -self.max_climb_acc), self.max_climb_acc)
        fx, fy, fz = exact.rotate_t(rows, (ax, ay, az + GRAVITY))  # the specific force, body frame
        size = math.sqrt(fx * fx + fy * fy + fz * fz)
        thrust = self.mass * fz * self.per_newton
        # z_body x f / |f| = (-fy, fx, 0) / |f|: the rotation taking the body z axis to f
        p, q = -self.k_att * fy / size, self.k_att * fx / size
        r = 0.0
        if heading is not None:
            yaw = math.atan2(rows[1][0], rows[0][0])
            r = self.k_yaw * math.remainder(heading - yaw, math.tau)
        limit = self.rate_limit
        rates = [min(max(c, -limit), limit) for c in (p, q, r)]
        return np.array([*rates, min(max(thrust, 0.0), 1.0)])


__all__ = ["QuadXVelocityPilot", "dict_observation"]
