"""The reference's multi-agent base-env pattern, for tasks users write themselves.

PyFlyt 0.29.0 ``MAQuadXBaseEnv`` and ``MAFixedwingBaseEnv`` are PettingZoo parallel envs
that a task subclasses: ``reset`` calls ``begin_reset`` (a new Aviary with one drone per
row of ``start_pos``, agents ``uav_0`` ...) and ``end_reset`` (track new bodies, flight
mode, 10 Aviary steps, ``update_states``); ``step`` stores ``past_actions`` /
``current_actions``, sends them, and runs ``120 / agent_hz`` Aviary steps.  The QuadX base
asks ``compute_term_trunc_reward_info_by_id`` and ``compute_observation_by_id`` for every
live agent after every Aviary step (rewards summed, flags or-ed, infos merged); the
fixed-wing base asks ``pop_obs_by_id`` and ``pop_term_trunc_rew_info_by_id`` once per
agent step and sends the thrust entry as ``T / 2 + 0.5``.  Agents that ended leave
``agents``.  Here they run over the compat Aviary; the stock
:class:`~pyflyt_engine.compat.pz_envs.MAFixedwingDogfightEnvV2` is a subclass of
:class:`MAFixedwingBaseEnv`, as the reference's is, while
:class:`~pyflyt_engine.compat.pz_envs.MAQuadXHoverEnvV2` is a native env running the
reference's episode.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, ClassVar, Literal

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.compat.gym_envs._base import (
    QUADX_RATE_LIMIT,
    QUADX_THRUST_LIMIT,
    REFERENCE_STEP_HZ,
    SETTLE_STEPS,
    check_agent_hz,
)

__all__ = ["MAFixedwingBaseEnv", "MAQuadXBaseEnv"]

_FOUR_CORNERS = np.array([[-1.0, -1.0, 1.0], [1.0, -1.0, 1.0], [-1.0, 1.0, 1.0], [1.0, 1.0, 1.0]])


class _MAAviaryEnv(ParallelEnv):
    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["human"], "name": "ma_base"}
    drone_type: ClassVar[str] = "quadx"
    aux_size: ClassVar[int] = 4
    #: the Aviary of the episode (built by each reset)
    aviary: Any

    def _setup(
        self,
        start_pos: np.ndarray,
        start_orn: np.ndarray,
        action_space: spaces.Box,
        flight_dome_size: float,
        max_duration_seconds: float,
        angle_representation: str,
        agent_hz: int,
        render_mode: None | str,
    ) -> None:
        check_agent_hz(agent_hz)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise AssertionError(f"Invalid render mode {render_mode}, only {self.metadata['render_modes']} allowed.")
        if angle_representation not in ("euler", "quaternion"):
            raise AssertionError(
                f"angle_representation must be either `euler` or `quaternion`, not {angle_representation}"
            )
        start_pos, start_orn = np.asarray(start_pos, dtype=np.float64), np.asarray(start_orn, dtype=np.float64)
        if start_pos.ndim != 2 or start_pos.shape[-1] != 3 or start_pos.shape != start_orn.shape:
            raise AssertionError(
                f"Expected `start_pos` and `start_orn` of shape [num_agents, 3], got {start_pos.shape} "
                f"and {start_orn.shape}."
            )
        self.render_mode = render_mode is not None
        attitude_shape = 12 if angle_representation == "euler" else 13
        self._action_space = action_space
        self.auxiliary_space = spaces.Box(-np.inf, np.inf, shape=(self.aux_size,), dtype=np.float64)
        self.combined_space = spaces.Box(
            -np.inf, np.inf, shape=(attitude_shape + self.aux_size + action_space.shape[0],), dtype=np.float64
        )
        self.start_pos, self.start_orn = start_pos, start_orn
        self.flight_dome_size = flight_dome_size
        self.max_steps = int(agent_hz * max_duration_seconds)
        self.env_step_ratio = int(REFERENCE_STEP_HZ / agent_hz)
        self.angle_representation = 0 if angle_representation == "euler" else 1
        #: PyFlyt 0.29.0: one agent per row of start_pos, named uav_0, uav_1, ...
        self.num_possible_agents = len(start_pos)
        self.possible_agents = [f"uav_{i}" for i in range(self.num_possible_agents)]
        self.agent_name_mapping = {name: i for i, name in enumerate(self.possible_agents)}
        self.agents: list[str] = []
        self.current_actions = np.zeros((self.num_possible_agents, *action_space.shape))
        self.past_actions = np.zeros((self.num_possible_agents, *action_space.shape))

    def observation_space(self, agent: Any = None) -> spaces.Space:
        raise NotImplementedError

    def action_space(self, agent: Any = None) -> spaces.Box:
        return self._action_space

    def close(self) -> None:
        if hasattr(self, "aviary"):
            self.aviary.disconnect()

    def reset(self, seed: None | int = None, options: None | dict[str, Any] = None) -> tuple[dict, dict]:
        raise NotImplementedError

    def _flight_mode(self) -> int:
        raise NotImplementedError

    def begin_reset(
        self,
        seed: None | int = None,
        options: None | dict[str, Any] = None,
        drone_options: None | dict[str, Any] | Sequence[dict[str, Any]] = None,
    ) -> None:
        """A fresh Aviary at ``start_pos``/``start_orn``, every agent live, step 0."""
        from pyflyt_engine.compat.core import Aviary

        if hasattr(self, "aviary"):
            self.aviary.disconnect()
        self.step_count = 0
        self.agents = self.possible_agents[:]
        self.aviary = Aviary(
            start_pos=self.start_pos,
            start_orn=self.start_orn,
            drone_type=self.drone_type,
            render=bool(self.render_mode),
            drone_options=drone_options or {},
            seed=seed,
        )

    def end_reset(self, seed: None | int = None, options: None | dict[str, Any] = None) -> None:
        self.aviary.register_all_new_bodies()
        self.aviary.set_mode(self._flight_mode())
        for _ in range(SETTLE_STEPS):
            self.aviary.step()
        self.update_states()

    def update_states(self) -> None:
        """Called after every Aviary step: cache what the per-agent hooks read."""

    def compute_attitude_by_id(self, agent_id: int) -> tuple[np.ndarray, ...]:
        """``(ang_vel, ang_pos, lin_vel, lin_pos, quaternion)`` of drone ``agent_id``."""
        ang_vel, ang_pos, lin_vel, lin_pos = self.aviary.state(agent_id)
        return ang_vel, ang_pos, lin_vel, lin_pos, np.array(p.getQuaternionFromEuler(ang_pos))

    #: PyFlyt 0.29.0: the fixed-wing base takes actions of live agents only (the others get
    #: zeros); the QuadX base takes every known agent's
    _live_actions_only: ClassVar[bool] = False

    def _take_actions(self, actions: dict[str, np.ndarray]) -> np.ndarray:
        self.past_actions = self.current_actions.copy()
        self.current_actions = np.zeros_like(self.current_actions)
        takes = self.agents if self._live_actions_only else self.agent_name_mapping
        for name, action in actions.items():
            if name in takes:
                self.current_actions[self.agent_name_mapping[name]] = action
        return self.current_actions.copy()

    def _cull(self, terminations: dict[str, bool], truncations: dict[str, bool]) -> None:
        self.step_count += 1
        self.agents = [a for a in self.agents if not (terminations[a] or truncations[a])]


class MAQuadXBaseEnv(_MAAviaryEnv):
    """PyFlyt 0.29.0 ``MAQuadXBaseEnv``: defaults ``start_pos`` the four corners (+-1, +-1, 1),
    ``flight_mode`` 0, ``flight_dome_size`` 10, ``max_duration_seconds`` 10,
    ``angle_representation`` "euler", ``agent_hz`` 40; action [p, q, r, T] in
    [-pi, pi]^3 x [0, 0.8]; auxiliary state 4.  A subclass writes ``reset``,
    ``observation_space``, ``compute_observation_by_id`` and
    ``compute_term_trunc_reward_info_by_id``."""

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["human"], "name": "ma_quadx_base"}

    def __init__(
        self,
        start_pos: np.ndarray = _FOUR_CORNERS,
        start_orn: np.ndarray = np.zeros((4, 3)),  # noqa: B008 - the reference's signature
        flight_mode: int = 0,
        flight_dome_size: float = 10.0,
        max_duration_seconds: float = 10.0,
        angle_representation: Literal["euler", "quaternion"] = "euler",
        agent_hz: int = 40,
        render_mode: None | str = None,
    ) -> None:
        r = QUADX_RATE_LIMIT
        box = spaces.Box(np.array([-r, -r, -r, 0.0]), np.array([r, r, r, QUADX_THRUST_LIMIT]), dtype=np.float64)
        self.flight_mode = flight_mode
        self._setup(
            start_pos,
            start_orn,
            box,
            flight_dome_size,
            max_duration_seconds,
            angle_representation,
            agent_hz,
            render_mode,
        )

    def _flight_mode(self) -> int:
        return int(self.flight_mode)

    def compute_observation_by_id(self, agent_id: int) -> Any:
        raise NotImplementedError

    def compute_term_trunc_reward_info_by_id(self, agent_id: int) -> tuple[bool, bool, float, dict[str, Any]]:
        raise NotImplementedError

    def step(self, actions: dict[str, np.ndarray]) -> tuple[dict, dict, dict, dict, dict]:
        self.aviary.set_all_setpoints(self._take_actions(actions))
        observations: dict[str, Any] = {}
        terminations = {a: False for a in self.agents}
        truncations = {a: False for a in self.agents}
        rewards = {a: 0.0 for a in self.agents}
        infos: dict[str, dict[str, Any]] = {a: {} for a in self.agents}
        for _ in range(self.env_step_ratio):
            self.aviary.step()
            self.update_states()
            for agent in self.agents:
                i = self.agent_name_mapping[agent]
                term, trunc, reward, info = self.compute_term_trunc_reward_info_by_id(i)
                terminations[agent] |= term
                truncations[agent] |= trunc
                rewards[agent] += reward
                infos[agent].update(info)
                observations[agent] = self.compute_observation_by_id(i)
        self._cull(terminations, truncations)
        return observations, rewards, terminations, truncations, infos


class MAFixedwingBaseEnv(_MAAviaryEnv):
    """PyFlyt 0.29.0 ``MAFixedwingBaseEnv``: defaults ``start_pos`` [[0, 0, 1]],
    ``assisted_flight`` True, ``flight_dome_size`` 300, ``max_duration_seconds`` 60,
    ``angle_representation`` "euler", ``agent_hz`` 30; action in [-1, 1]^4 (assisted:
    roll, pitch, yaw, thrust) or [-1, 1]^6 (the raw surfaces, thrust last); auxiliary
    state 6.  A subclass writes ``reset``, ``observation_space``, ``pop_obs_by_id`` and
    ``pop_term_trunc_rew_info_by_id``.  The reference flies its "acrowing" model here;
    the compat Aviary flies the shipped fixed-wing."""

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["human"], "name": "ma_fixedwing_base"}
    drone_type = "fixedwing"
    aux_size = 6
    _live_actions_only = True

    def __init__(
        self,
        start_pos: np.ndarray = np.array([[0.0, 0.0, 1.0]]),  # noqa: B008 - the reference's signature
        start_orn: np.ndarray = np.array([[0.0, 0.0, 0.0]]),  # noqa: B008
        assisted_flight: bool = True,
        flight_dome_size: float = 300.0,
        max_duration_seconds: float = 60.0,
        angle_representation: Literal["euler", "quaternion"] = "euler",
        agent_hz: int = 30,
        render_mode: None | str = None,
    ) -> None:
        n = 4 if assisted_flight else 6
        self.assisted_flight = bool(assisted_flight)
        box = spaces.Box(-np.ones(n), np.ones(n), dtype=np.float64)
        self._setup(
            start_pos,
            start_orn,
            box,
            flight_dome_size,
            max_duration_seconds,
            angle_representation,
            agent_hz,
            render_mode,
        )

    def _flight_mode(self) -> int:
        return 0 if self.assisted_flight else -1

    def pop_obs_by_id(self, agent_id: int) -> Any:
        raise NotImplementedError

    @staticmethod
    def compute_rotation_forward(orn: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Body-to-ground rotation matrices (n, 3, 3) and nose directions (n, 3) from (n, 3) Euler angles.

        PyFlyt 0.29.0 ``MAFixedwingBaseEnv.compute_rotation_forward``: R = Rz(yaw) Ry(pitch)
        Rx(roll), PyBullet's convention; the nose is R's first column, (cos yaw cos pitch,
        sin yaw cos pitch, -sin pitch).
        """
        orn = np.asarray(orn, dtype=np.float64).reshape(-1, 3)
        c, s = np.cos(orn), np.sin(orn)
        n = orn.shape[0]
        rx, ry, rz = (np.tile(np.eye(3), (n, 1, 1)) for _ in range(3))
        rx[:, 1, 1], rx[:, 1, 2], rx[:, 2, 1], rx[:, 2, 2] = c[:, 0], -s[:, 0], s[:, 0], c[:, 0]
        ry[:, 0, 0], ry[:, 0, 2], ry[:, 2, 0], ry[:, 2, 2] = c[:, 1], s[:, 1], -s[:, 1], c[:, 1]
        rz[:, 0, 0], rz[:, 0, 1], rz[:, 1, 0], rz[:, 1, 1] = c[:, 2], -s[:, 2], s[:, 2], c[:, 2]
        forward = np.stack((c[:, 2] * c[:, 1], s[:, 2] * c[:, 1], -s[:, 1]), axis=-1)
        return rz @ ry @ rx, forward

    def pop_term_trunc_rew_info_by_id(self, agent_id: int) -> tuple[bool, bool, float, dict[str, Any]]:
        raise NotImplementedError

    def step(self, actions: dict[str, np.ndarray]) -> tuple[dict, dict, dict, dict, dict]:
        commands = self._take_actions(actions)
        commands[..., -1] = commands[..., -1] / 2.0 + 0.5
        self.aviary.set_all_setpoints(commands)
        for _ in range(self.env_step_ratio):
            self.aviary.step()
            self.update_states()
        observations, terminations, truncations, rewards, infos = {}, {}, {}, {}, {}
        for agent in self.agents:
            i = self.agent_name_mapping[agent]
            observations[agent] = self.pop_obs_by_id(i)
            ended = self.pop_term_trunc_rew_info_by_id(i)
            terminations[agent], truncations[agent], rewards[agent], infos[agent] = ended
        self._cull(terminations, truncations)
        return observations, rewards, terminations, truncations, infos
