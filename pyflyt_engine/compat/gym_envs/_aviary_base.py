"""The reference's base-env pattern, for tasks users write themselves.

Research code built on the reference writes a new task by subclassing one of its base
envs (``QuadXBaseEnv``, ``FixedwingBaseEnv``, ``RocketBaseEnv``) and filling in three
hooks: ``reset`` (calling ``begin_reset`` then ``end_reset``), ``compute_state`` (sets
``self.state``) and ``compute_term_trunc_reward`` (adjusts ``self.reward``,
``self.termination``, ``self.truncation``, ``self.info``), reading the world through
``self.env``, a :class:`~pyflyt_engine.compat.core.Aviary`.  :class:`AviaryTaskEnv` runs
that pattern here, over the compat Aviary, with the reference's order of events (facts
from PyFlyt 0.29.0 ``QuadXBaseEnv`` / ``FixedwingBaseEnv`` / ``RocketBaseEnv``):

* ``begin_reset`` seeds ``np_random``, closes the previous Aviary and builds a new one at
  ``self.start_pos`` / ``self.start_orn`` (so assigning ``start_pos`` moves the next
  spawn; the world's random streams come from a generator of their own seeded with the
  env's seed, so an episode is repeatable under a seed and nothing is drawn from
  ``np_random`` before the task's set-up: a ``WaypointHandler`` reset with it draws the
  reference's course for that seed), and zeroes ``step_count``, ``action``, ``reward`` and the info flags
  ``out_of_bounds``, ``collision``, ``env_complete``;
* ``end_reset`` tracks new bodies, selects ``flight_mode`` and runs 10 Aviary steps
  before ``compute_state``;
* ``step`` stores the action, starts the reward at -0.1 (the rocket's at 0), and runs ``120 / agent_hz``
  Aviary steps, calling ``compute_state`` and ``compute_term_trunc_reward`` after each
  (so a per-step shaping term is added once per Aviary step), stopping early once the
  episode ended; ``step_count`` then counts up, and ``step_count > max_steps`` truncates;
* ``compute_base_term_trunc_reward``: the time limit, a crash (contact; reward -100,
  ``collision``) and leaving the dome (reward -100, ``out_of_bounds``).

The stock envs of :mod:`pyflyt_engine.compat.gym_envs` run the same episode over worlds
built from native env configs (restored, not rebuilt, at each reset; their payloads and
scenery); these bases build a fresh compat Aviary per reset, as the reference does, for
code that brings its own task and scenery.
"""

from __future__ import annotations

from typing import Any, ClassVar, Literal, cast

import gymnasium
import numpy as np
from gymnasium import spaces

from pyflyt_engine.compat.gym_envs._base import (
    REFERENCE_STEP_HZ,
    SETTLE_STEPS,
    ReferenceHooks,
    fresh,
    check_agent_hz,
    check_angle_representation,
    check_render_mode,
)


class AviaryTaskEnv(ReferenceHooks, gymnasium.Env):
    """The shared part of the reference-style base envs (see the module docstring)."""

    metadata: dict[str, Any] = {"render_modes": ["human", "rgb_array"], "render_fps": 30}
    #: the Aviary ``drone_type`` flown
    drone_type: ClassVar[str] = "quadx"
    #: the auxiliary state's length (PyFlyt 0.29.0: QuadX 4, Fixedwing 6, Rocket 9)
    aux_size: ClassVar[int] = 4
    #: the reward each step starts from (PyFlyt 0.29.0: -0.1; the rocket's 0)
    step_reward: ClassVar[float] = -0.1

    def __init__(
        self,
        start_pos: np.ndarray,
        start_orn: np.ndarray,
        flight_mode: int,
        flight_dome_size: float,
        max_duration_seconds: float,
        angle_representation: Literal["euler", "quaternion"],
        agent_hz: int,
        render_mode: None | Literal["human", "rgb_array"],
        render_resolution: tuple[int, int],
    ) -> None:
        check_agent_hz(agent_hz)
        check_render_mode(render_mode)
        check_angle_representation(angle_representation)
        self.render_mode = render_mode
        self.render_resolution = render_resolution
        attitude_shape = 12 if angle_representation == "euler" else 13
        self.attitude_space = spaces.Box(-np.inf, np.inf, shape=(attitude_shape,), dtype=np.float64)
        self.auxiliary_space = spaces.Box(-np.inf, np.inf, shape=(self.aux_size,), dtype=np.float64)
        self.action_space = self._make_action_space(int(flight_mode))
        self.combined_space = spaces.Box(
            -np.inf,
            np.inf,
            shape=(attitude_shape + self.action_space.shape[0] + self.aux_size,),
            dtype=np.float64,
        )
        self.start_pos = start_pos
        self.start_orn = start_orn
        self.flight_mode = flight_mode
        self.flight_dome_size = flight_dome_size
        self.max_steps = int(agent_hz * max_duration_seconds)
        self.env_step_ratio = int(REFERENCE_STEP_HZ / agent_hz)
        #: 0 for Euler angles, 1 for quaternions (the reference's encoding)
        self.angle_representation = 0 if angle_representation == "euler" else 1

    def _make_action_space(self, flight_mode: int) -> spaces.Box:
        raise NotImplementedError

    # ------------------------------------------------------------------ lifecycle

    def close(self) -> None:
        if hasattr(self, "env"):
            self.env.disconnect()

    def reset(self, *, seed: None | int = None, options: None | dict[str, Any] = None) -> tuple[Any, dict[str, Any]]:
        """A task's reset: ``begin_reset``, its own set-up, ``end_reset``; returns ``(state, info)``."""
        raise NotImplementedError

    def begin_reset(
        self,
        seed: None | int = None,
        options: None | dict[str, Any] = None,
        drone_options: None | dict[str, Any] = None,
    ) -> None:
        """Seed, then a fresh Aviary at ``start_pos``/``start_orn`` and zeroed episode state."""
        from pyflyt_engine.compat.core import Aviary

        super().reset(seed=seed)
        if seed is not None or getattr(self, "_world_rng", None) is None:
            # the world's streams come from a generator of their own, so that nothing is drawn
            # from np_random before the task's set-up, as in the reference (whose courses are
            # the first draws of the seeded np_random)
            self._world_rng = np.random.default_rng(None if seed is None else [int(seed), 1])
        if hasattr(self, "env"):
            self.env.disconnect()
        self.step_count = 0
        self.termination = False
        self.truncation = False
        self.state: Any = None
        self.action = np.zeros(cast(spaces.Box, self.action_space).shape)
        self.reward = 0.0
        self.info: dict[str, Any] = {"out_of_bounds": False, "collision": False, "env_complete": False}
        drone_options = dict(drone_options or {})
        drone_options.update(self._drone_options())
        self.env = Aviary(
            start_pos=np.asarray(self.start_pos, dtype=np.float64).reshape(-1, 3),
            start_orn=np.asarray(self.start_orn, dtype=np.float64).reshape(-1, 3),
            drone_type=self.drone_type,
            render=self.render_mode == "human",
            drone_options=drone_options,
            # the world's own streams (motor noise): deterministic under a seed
            seed=int(self._world_rng.integers(2**31)),
            np_random=self.np_random,
        )

    def _drone_options(self) -> dict[str, Any]:
        """drone_options every reset adds (the rocket's fuel)."""
        return {}

    def end_reset(self, seed: None | int = None, options: None | dict[str, Any] = None) -> None:
        """Track new bodies, select the flight mode, settle 10 Aviary steps, compute the state."""
        self.env.register_all_new_bodies()
        self.env.set_mode(self.flight_mode)
        for _ in range(SETTLE_STEPS):
            self.env.step()
        self.compute_state()

    # ------------------------------------------------------------------ hooks

    def compute_state(self) -> None:
        """Set ``self.state`` (the observation) from ``self.env``."""
        raise NotImplementedError

    def compute_term_trunc_reward(self) -> None:
        """Adjust ``self.reward``, ``self.termination``, ``self.truncation`` and ``self.info``."""
        raise NotImplementedError

    def _to_setpoint(self, action: np.ndarray) -> np.ndarray:
        return action

    def step(self, action: np.ndarray) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        self.action = np.array(action, dtype=np.float64)
        self.reward = self.step_reward
        self.env.set_setpoint(0, self._to_setpoint(self.action.copy()))
        for _ in range(self.env_step_ratio):
            if self.termination or self.truncation:
                break
            self.env.step()
            self.compute_state()
            self.compute_term_trunc_reward()
        self.step_count += 1
        return fresh(self.state), self.reward, self.termination, self.truncation, dict(self.info)

    def render(self) -> np.ndarray | None:
        """An (H, W, 4) RGBA frame from the chase camera (``human``: the GUI follows too)."""
        if self.render_mode is None:
            raise ValueError(
                "Please set `render_mode='human'` or `render_mode='rgb_array'` in init to use this function."
            )
        from pyflyt_engine.envs import render as _render
        from pyflyt_engine.state import KinematicState

        world = self.env.world
        state: KinematicState = world.vehicles[0].state
        frame = _render.chase_camera(
            world.client, state, (int(self.render_resolution[0]), int(self.render_resolution[1])), 3.0, 1.0, 60.0
        )
        alpha = np.full(frame.shape[:2] + (1,), 255, dtype=np.uint8)
        return np.concatenate((frame, alpha), axis=-1)
