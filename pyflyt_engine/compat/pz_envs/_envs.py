"""The reference's PettingZoo envs (``from PyFlyt.pz_envs import ...``'s counterpart).

Both are subclasses of the reference-style bases of :mod:`._aviary_base`, as the
reference's are, and run its episodes over the compat Aviary: :class:`MAQuadXHoverEnvV2`
here (PyFlyt 0.29.0 ``MAQuadXHoverEnv``) and ``MAFixedwingDogfightEnvV2``
(:mod:`._dogfight`).  Facts about the reference are cited as "PyFlyt 0.29.0 <class>: ...".
"""

from __future__ import annotations

from typing import Any, ClassVar, Literal

import numpy as np
from gymnasium import spaces

from pyflyt_engine.compat.pz_envs._aviary_base import MAQuadXBaseEnv
from pyflyt_engine.compat.pz_envs._dogfight import MAFixedwingDogfightEnvV2

__all__ = ["MAFixedwingDogfightEnvV2", "MAQuadXHoverEnvV2"]

# PyFlyt 0.29.0 MAQuadXHoverEnv: four QuadX at (+-1, +-1, 1), level
_HOVER_START_POS = np.array([[-1.0, -1.0, 1.0], [1.0, -1.0, 1.0], [-1.0, 1.0, 1.0], [1.0, 1.0, 1.0]])
_HOVER_START_ORN = np.zeros((4, 3))


class MAQuadXHoverEnvV2(MAQuadXBaseEnv):
    """PyFlyt 0.29.0 ``MAQuadXHoverEnv``: every QuadX holds its start position.

    Defaults (PyFlyt 0.29.0): ``start_pos`` the four corners (+-1, +-1, 1), ``flight_mode``
    0, ``flight_dome_size`` 10.0, ``max_duration_seconds`` 30.0, ``angle_representation``
    "quaternion", ``agent_hz`` 40.  A new compat Aviary per reset at
    ``start_pos``/``start_orn``, 10 settling steps; per agent step ``120 / agent_hz``
    Aviary steps, after each of which every live agent is judged
    (:meth:`compute_term_trunc_reward_info_by_id`: rewards summed, flags or-ed, infos
    merged) and observed (:meth:`compute_observation_by_id`).  Action ``Box(4,)`` as the
    reference's (mode 0: [-pi, pi]^3 x [0, 0.8], the thrust a motor command).
    Observation ``Box(24,)`` / ``Box(23,)``: [ang_vel, quaternion | Euler, lin_vel,
    lin_pos, aux (4), previous action (4), start position (3)]; reset infos are empty.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["human"], "name": "ma_quadx_hover"}

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
        super().__init__(
            start_pos=start_pos,
            start_orn=start_orn,
            flight_mode=flight_mode,
            flight_dome_size=flight_dome_size,
            max_duration_seconds=max_duration_seconds,
            angle_representation=angle_representation,
            agent_hz=agent_hz,
            render_mode=render_mode,
        )
        self.sparse_reward = bool(sparse_reward)
        self._observation_space = spaces.Box(
            -np.inf, np.inf, shape=(self.combined_space.shape[0] + 3,), dtype=np.float64
        )

    def observation_space(self, agent: Any = None) -> spaces.Space:
        return self._observation_space

    @property
    def world(self) -> Any:
        """The native :class:`~pyflyt_engine.world.World` under the Aviary (after a reset)."""
        return self.aviary.world

    def reset(
        self, seed: None | int = None, options: None | dict[str, Any] = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """PyFlyt 0.29.0 ``MAQuadXHoverEnv.reset``: ``begin_reset``, ``end_reset``, the observations
        and empty infos (``options`` are ignored, as there)."""
        super().begin_reset(seed, options)
        super().end_reset(seed, options)
        observations = {a: self.compute_observation_by_id(self.agent_name_mapping[a]) for a in self.agents}
        return observations, {a: {} for a in self.agents}

    def compute_observation_by_id(self, agent_id: int) -> np.ndarray:
        """[ang_vel, Euler angles | quaternion, lin_vel, lin_pos, aux, previous action, start position]."""
        ang_vel, ang_pos, lin_vel, lin_pos, quaternion = self.compute_attitude_by_id(agent_id)
        angles = ang_pos if self.angle_representation == 0 else quaternion
        return np.concatenate(
            (
                ang_vel,
                angles,
                lin_vel,
                lin_pos,
                self.aviary.aux_state(agent_id),
                self.past_actions[agent_id],
                self.start_pos[agent_id],
            )
        )

    def compute_term_trunc_reward_info_by_id(self, agent_id: int) -> tuple[bool, bool, float, dict[str, Any]]:
        """PyFlyt 0.29.0, per 1/120 s and agent: any contact of its vehicle: -100, terminated
        (``collision``); beyond the dome: -100 (``out_of_bounds``); dense: + 1 - |p - its
        start| - 0.1 |(roll, pitch)|; truncated once ``step_count > max_steps``."""
        reward, term, info = 0.0, False, {}
        if np.any(self.aviary.contact_array[self.aviary.drones[agent_id].Id]):
            reward -= 100.0
            info["collision"] = True
            term = True
        _, ang_pos, _, lin_pos = self.aviary.state(agent_id)
        if np.linalg.norm(lin_pos) > self.flight_dome_size:
            reward -= 100.0
            info["out_of_bounds"] = True
            term = True
        if not self.sparse_reward:
            reward -= float(np.linalg.norm(lin_pos - self.start_pos[agent_id]) + 0.1 * np.linalg.norm(ang_pos[:2]))
            reward += 1.0
        return term, self.step_count > self.max_steps, reward, info
