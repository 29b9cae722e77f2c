"""The reference's PettingZoo envs (``from PyFlyt.pz_envs import ...``'s counterpart).

:class:`MAQuadXHoverEnvV2` and :class:`MAFixedwingDogfightEnvV2` take the reference's
constructor arguments and have its spaces and observation layouts.  ``MAQuadXHoverEnvV2``
is our multi-agent hover config (``conf/env/ma_quadx_hover.yaml``) adjusted
(:class:`~pyflyt_engine.envs.multi_agent.base.MultiAgentUAVEnv`), running the reference's
episode (settling, per-1/120 s rewards and endings); ``MAFixedwingDogfightEnvV2``
(:mod:`._dogfight`) is the reference's dogfight over the compat Aviary.  Facts about the
reference are cited as "PyFlyt 0.29.0 <class>: ...".
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any, ClassVar, Literal

import numpy as np

from pyflyt_engine.compat.pz_envs._dogfight import MAFixedwingDogfightEnvV2
from pyflyt_engine.compat.gym_envs._base import (
    REFERENCE_STEP_HZ,
    SETTLE_STEPS,
    _PwmThrust,
    check_agent_hz,
    check_angle_representation,
    native_config,
    quadx_action,
)
from pyflyt_engine.envs.multi_agent.hover import MAQuadXHoverEnv as _NativeMAHover
from pyflyt_engine.state import KinematicState

__all__ = ["MAFixedwingDogfightEnvV2", "MAQuadXHoverEnvV2"]


class _ReferenceParallel:
    """What both reference PettingZoo envs share, placed before the native class in the bases.

    * ``reset`` ignores its ``options`` silently, as the reference does (PettingZoo's API
      test passes ``{"options": 1}``); ``{"task": {...}}`` still changes an episode's task;
    * the reference's attributes: ``num_possible_agents``, ``agent_name_mapping``,
      ``step_count``, ``max_steps``, ``env_step_ratio`` (Aviary steps of 1/120 s per
      agent step) and ``aviary``, an :class:`~pyflyt_engine.compat.core.Aviary` view of the
      world (``aviary.state(i)`` is the (4, 3) state of agent ``i``).
    """

    #: the Aviary drone type of every agent
    _drone_kind: ClassVar[str] = "quadx"

    def _reference_attributes(self, agent_hz: float, max_duration_seconds: float) -> None:
        self.num_possible_agents = len(self.possible_agents)  # type: ignore[attr-defined]
        self.agent_name_mapping = dict(self.agent_index)  # type: ignore[attr-defined]
        self.max_steps = int(agent_hz * max_duration_seconds)
        self.env_step_ratio = int(REFERENCE_STEP_HZ / agent_hz)
        self._aviary_view: Any = None

    @property
    def step_count(self) -> int:
        """Agent steps since the reset."""
        return int(self._steps)  # type: ignore[attr-defined]

    @property
    def aviary(self) -> Any:
        from pyflyt_engine.compat.core import Aviary

        if self._aviary_view is None or self._aviary_view.world is not self.world:  # type: ignore[attr-defined]
            kinds = [self._drone_kind] * len(self.possible_agents)  # type: ignore[attr-defined]
            self._aviary_view = Aviary.over_world(self.world, kinds)  # type: ignore[attr-defined]
        return self._aviary_view

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[dict, dict]:
        kept = {"task": options["task"]} if isinstance(options, dict) and "task" in options else None
        return super().reset(seed=seed, options=kept)  # type: ignore[misc]

# PyFlyt 0.29.0 MAQuadXHoverEnv: four QuadX at (+-1, +-1, 1), level
_HOVER_START_POS = np.array([[-1.0, -1.0, 1.0], [1.0, -1.0, 1.0], [-1.0, 1.0, 1.0], [1.0, 1.0, 1.0]])
_HOVER_START_ORN = np.zeros((4, 3))


class MAQuadXHoverEnvV2(_ReferenceParallel, _NativeMAHover):
    """PyFlyt 0.29.0 ``MAQuadXHoverEnv``: every QuadX holds its start position.

    Defaults (PyFlyt 0.29.0): ``start_pos`` the four corners (+-1, +-1, 1), ``flight_mode``
    0, ``flight_dome_size`` 10.0, ``max_duration_seconds`` 30.0, ``agent_hz`` 40.  Spawn
    exactly at ``start_pos``/``start_orn``.  Action ``Box(4,)`` as the reference's (mode 0:
    [-pi, pi]^3 x [0, 0.8], the thrust a motor command).  Observation ``Box(24,)`` /
    ``Box(23,)``: [ang_vel, quaternion | Euler, lin_vel, lin_pos, aux (4), previous action
    (4), start position (3)].
    """

    metadata: ClassVar[dict] = {**_NativeMAHover.metadata, "name": "ma_quadx_hover"}

    def __init__(
        self,
        start_pos: np.ndarray = _HOVER_START_POS,
        start_orn: np.ndarray = _HOVER_START_ORN,
        sparse_reward: bool = False,
        flight_mode: int = 0,
        flight_dome_size: float = 10.0,
        max_duration_seconds: float = 30.0,
        angle_representation: Literal["euler", "quaternion"] = "quaternion",
        agent_hz: int = 40,
        render_mode: None | str = None,
    ) -> None:
        check_agent_hz(agent_hz)
        check_angle_representation(angle_representation)
        start_pos = np.asarray(start_pos, dtype=np.float64).reshape(-1, 3)
        start_orn = np.asarray(start_orn, dtype=np.float64).reshape(-1, 3)
        if start_pos.shape != start_orn.shape:
            raise ValueError(f"start_pos {start_pos.shape} and start_orn {start_orn.shape} must have the same shape")
        cfg = native_config("ma_quadx_hover")
        cfg.update(
            agent_hz=float(agent_hz),
            max_duration_seconds=float(max_duration_seconds),
            flight_dome_size=float(flight_dome_size),
            angle_representation=angle_representation,
            reward="sparse" if sparse_reward else "dense",
            action=quadx_action(flight_mode),
            agents=[
                {
                    "name": f"uav_{i}",
                    "spawn": {
                        "position": tuple(p),
                        "orientation": tuple(o),
                        "position_noise": 0.0,
                        "orientation_noise": 0.0,
                    },
                    "hover_point": tuple(p),
                }
                for i, (p, o) in enumerate(zip(start_pos, start_orn))
            ],
        )
        self.start_pos, self.start_orn, self.flight_mode = start_pos, start_orn, flight_mode
        super().__init__(cfg, render_mode=render_mode, info_reward_terms=False)
        self._reference_attributes(agent_hz, max_duration_seconds)
        if cfg["action"]["mode"] in ("rates_thrust", "motors"):
            self.vehicles = [_PwmThrust(v, motors=cfg["action"]["mode"] == "motors") for v in self.vehicles]
        self.sparse_reward = bool(sparse_reward)
        n = len(self.possible_agents)
        #: PyFlyt 0.29.0 MAQuadXBaseEnv: the actions of this step and of the one before it
        #: (observations carry the one before)
        self.current_actions = np.zeros((n, 4))
        self.past_actions = np.zeros((n, 4))

    def _observe(self, i: int, states: list[KinematicState]) -> np.ndarray:
        s = states[i]
        angles = s.quaternion if self._quaternion else s.ang_pos
        return np.concatenate(
            (
                np.array((*s.ang_vel, *angles, *s.lin_vel, *s.lin_pos), dtype=np.float64),
                self.vehicles[i].aux_state,
                self.past_actions[i],
                self.start_pos[i],
            )
        )

    @contextlib.contextmanager
    def _at_reference_rate(self) -> Iterator[None]:
        """The world steps 1/120 s at a time inside (PyFlyt 0.29.0: one Aviary step)."""
        world = self.world
        saved = world.physics_per_agent
        world.physics_per_agent = max(1, int(round(world.physics_hz / REFERENCE_STEP_HZ)))
        try:
            yield
        finally:
            world.physics_per_agent = saved

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[dict, dict]:
        """The native spawn, then the reference's 10 settling steps of 1/120 s with idle motors
        (PyFlyt 0.29.0 ``MAQuadXBaseEnv.end_reset``); infos are empty, as the reference's."""
        super().reset(seed=seed, options=options)
        self.current_actions[:] = 0.0
        self.past_actions[:] = 0.0
        with self._at_reference_rate():
            for vehicle in self.vehicles:
                vehicle.set_setpoint(np.zeros(4))
            for _ in range(SETTLE_STEPS):
                self.world.step()
        states = [v.state for v in self.vehicles]
        observations = {name: self._observe(i, states) for i, name in enumerate(self.possible_agents)}
        return observations, {name: {} for name in self.possible_agents}

    def _judge_reference(self, i: int) -> tuple[bool, bool, float, dict[str, Any]]:
        """PyFlyt 0.29.0 MAQuadXHoverEnv, per 1/120 s and agent: any contact of its vehicle: -100,
        terminated (``collision``); beyond the dome: -100 (``out_of_bounds``); dense: + 1 -
        |p - its start| - 0.1 |(roll, pitch)|; truncated once ``step_count > max_steps``."""
        aviary = self.aviary
        reward, term, info = 0.0, False, {}
        if np.any(aviary.contact_array[aviary.drones[i].Id]):
            reward -= 100.0
            info["collision"] = True
            term = True
        _, ang_pos, _, lin_pos = aviary.state(i)
        if np.linalg.norm(lin_pos) > self.config.flight_dome_size:
            reward -= 100.0
            info["out_of_bounds"] = True
            term = True
        if not self.sparse_reward:
            reward -= float(np.linalg.norm(lin_pos - self.start_pos[i]) + 0.1 * np.linalg.norm(ang_pos[:2]))
            reward += 1.0
        return term, self.step_count > self.max_steps, reward, info

    def step(self, actions: Any) -> tuple[dict, dict, dict, dict, dict]:
        """PyFlyt 0.29.0 ``MAQuadXBaseEnv.step``: every vehicle gets its agent's action (zero for
        agents that left), then ``120 / agent_hz`` world steps of 1/120 s, each judged per live
        agent (rewards summed, flags or-ed, infos merged); agents that ended leave ``agents``."""
        live = list(self.agents)
        if not live:
            raise RuntimeError("step() after the episode ended (no live agents): call reset()")
        self.past_actions = self.current_actions.copy()
        self.current_actions = np.zeros_like(self.current_actions)
        for name, action in actions.items():
            if name in self.agent_index:
                self.current_actions[self.agent_index[name]] = np.asarray(action, dtype=np.float64).reshape(-1)
        for i, vehicle in enumerate(self.vehicles):
            self._actions[i] = np.clip(self.current_actions[i], self._low, self._high)
            vehicle.set_setpoint(self._actions[i])
        observations: dict[str, Any] = {}
        terminations = {a: False for a in live}
        truncations = {a: False for a in live}
        rewards = {a: 0.0 for a in live}
        infos: dict[str, dict[str, Any]] = {a: {} for a in live}
        with self._at_reference_rate():
            for _ in range(self.env_step_ratio):
                self.world.step()
                states = [v.state for v in self.vehicles]
                for name in live:
                    i = self.agent_index[name]
                    term, trunc, reward, info = self._judge_reference(i)
                    terminations[name] |= term
                    truncations[name] |= trunc
                    rewards[name] += reward
                    infos[name].update(info)
                    observations[name] = self._observe(i, states)
        self._steps += 1
        self.agents = [a for a in live if not (terminations[a] or truncations[a])]
        for name in live:
            self._alive[self.agent_index[name]] = name in self.agents
        return observations, rewards, terminations, truncations, infos
