"""``RocketBaseEnv``: the reference's rocket base env, for tasks users write (see :mod:`.._aviary_base`)."""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from gymnasium import spaces

from pyflyt_engine.compat.gym_envs._aviary_base import AviaryTaskEnv

# the names the reference's module holds through its own imports, for code that takes them from here
from pyflyt_engine.compat.core.aviary import Aviary
from pyflyt_engine.compat.core.utils.compile_helpers import check_numpy

__all__ = ["Aviary", "RocketBaseEnv", "check_numpy"]


class RocketBaseEnv(AviaryTaskEnv):
    """A rocket task over the compat Aviary, filled in by a subclass.

    PyFlyt 0.29.0 RocketBaseEnv: ``start_pos`` [[0, 0, 10]], ``start_orn`` [[0, 0, 0]],
    ``ceiling`` inf, ``max_displacement`` inf, ``max_duration_seconds`` 60,
    ``angle_representation`` "quaternion", ``agent_hz`` 30; always flight mode 0; action
    [fin x, fin y, fin roll, ignition, throttle, gimbal a, gimbal b] in [-1, 1]^3 x
    [0, 1]^2 x [-1, 1]^2; auxiliary state 9 entries [fins x 4, ignition, fuel, throttle,
    gimbals x 2]; the reward starts each step at 0; info ``out_of_bounds``,
    ``fatal_collision``, ``env_complete``.  Reset options (``begin_reset``):
    ``randomize_drop`` draws x, y in U(+-0.1 max_displacement), z in U(0.8, 0.9) x
    ceiling and attitude U(+-0.3) rad; ``accelerate_drop`` starts the drop at -100 m/s.
    """

    drone_type = "rocket"
    aux_size = 9
    step_reward = 0.0

    def __init__(
        self,
        start_pos: np.ndarray = np.array([[0.0, 0.0, 10.0]]),  # noqa: B008 - the reference's signature
        start_orn: np.ndarray = np.array([[0.0, 0.0, 0.0]]),  # noqa: B008
        ceiling: float = np.inf,
        max_displacement: float = np.inf,
        max_duration_seconds: float = 60.0,
        angle_representation: Literal["euler", "quaternion"] = "quaternion",
        agent_hz: int = 30,
        render_mode: None | Literal["human", "rgb_array"] = None,
        render_resolution: tuple[int, int] = (480, 480),
    ) -> None:
        super().__init__(
            start_pos,
            start_orn,
            0,
            float(np.hypot(ceiling, max_displacement)),
            max_duration_seconds,
            angle_representation,
            agent_hz,
            render_mode,
            render_resolution,
        )
        self.ceiling = ceiling
        self.max_displacement = max_displacement

    def _make_action_space(self, flight_mode: int) -> spaces.Box:
        low = np.array([-1.0, -1.0, -1.0, 0.0, 0.0, -1.0, -1.0])
        high = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0])
        return spaces.Box(low, high, dtype=np.float64)

    def begin_reset(
        self,
        seed: None | int = None,
        options: None | dict[str, Any] = None,
        drone_options: None | dict[str, Any] = None,
    ) -> None:
        options = dict(options or {})
        if options.get("randomize_drop"):  # drawn after the seeding, as the reference does
            super(AviaryTaskEnv, self).reset(seed=seed)
            if seed is not None:  # the world's streams, seeded apart from np_random (AviaryTaskEnv)
                self._world_rng = np.random.default_rng([int(seed), 1])
            seed = None
            spread = 0.1 * self.max_displacement
            xy = self.np_random.uniform(-spread, spread, size=(2,))
            z = self.np_random.uniform(0.8 * self.ceiling, 0.9 * self.ceiling)
            self.start_pos = np.array([[xy[0], xy[1], z]])
            self.start_orn = self.np_random.uniform(-0.3, 0.3, size=(3,))[None, :]
        super().begin_reset(seed=seed, options=options, drone_options=drone_options)
        self.info = {"out_of_bounds": False, "fatal_collision": False, "env_complete": False}
        if options.get("accelerate_drop"):
            self.env.resetBaseVelocity(self.env.drones[0].Id, [0.0, 0.0, -100.0], [0.0, 0.0, 0.0])
            self.env.drones[0].vehicle.state_changed()

    def end_reset(self, seed: None | int = None, options: None | dict[str, Any] = None) -> None:
        self.flight_mode = 0
        super().end_reset(seed, options)

    def compute_base_term_trunc_reward(
        self, collision_ignore_mask: np.ndarray | list[int] | tuple[int, ...] = ()
    ) -> None:
        """The time limit; a contact not between consecutive ids of ``collision_ignore_mask``, or
        the rocket below z = 0, is fatal (``fatal_collision``); beyond ``max_displacement``
        sideways or above ``ceiling`` is ``out_of_bounds``.  No reward is given here."""
        if self.step_count > self.max_steps:
            self.truncation |= True
        contacts = self.env.contact_array.copy()
        mask = list(collision_ignore_mask)
        for a, b in zip(mask[1:], mask[:-1]):
            contacts[a, b] = contacts[b, a] = False
        position = self.env.state(0)[-1]
        if np.any(contacts) or position[2] < 0.0:
            self.info["fatal_collision"] = True
            self.termination |= True
        if np.linalg.norm(position[:2]) > self.max_displacement or position[2] > self.ceiling:
            self.info["out_of_bounds"] = True
            self.termination |= True
