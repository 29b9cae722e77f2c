"""``WaypointHandler``: the reference's helper that draws and tracks a course of waypoints.

PyFlyt 0.29.0 ``gym_envs.utils.waypoint_handler.WaypointHandler`` (constructor, methods and
properties as there), written for this project: targets are drawn on a half sphere around
the origin (direction from two angles, radius U(1, 0.9 x flight_dome_size), height at
least ``min_height``); deltas are in the body frame; a target is reached within
``goal_reach_distance`` (and, with yaw targets, ``goal_reach_angle``).  Used by the
reference-style base envs (:mod:`pyflyt_engine.compat.gym_envs.quadx_envs.quadx_base_env`)
and importable by user tasks.  Target markers, when rendering, are plain spheres.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["WaypointHandler"]


class WaypointHandler:
    """Draws ``num_targets`` waypoints at each :meth:`reset` and tracks progress to them."""

    def __init__(
        self,
        enable_render: bool,
        num_targets: int,
        use_yaw_targets: bool,
        goal_reach_distance: float,
        goal_reach_angle: float,
        flight_dome_size: float,
        min_height: float,
        np_random: np.random.Generator,
    ) -> None:
        self.enable_render = enable_render
        self.num_targets = int(num_targets)
        self.use_yaw_targets = use_yaw_targets
        self.goal_reach_distance = goal_reach_distance
        self.goal_reach_angle = goal_reach_angle
        self.flight_dome_size = flight_dome_size
        self.min_height = min_height
        self.np_random = np_random
        self.targets: Any = np.zeros((0, 3))
        self.yaw_targets: Any = np.zeros(0)
        self.target_visual: list[int] = []

    def reset(self, p: Any, np_random: None | np.random.Generator = None) -> None:
        """A new course; ``p`` is the Aviary (any PyBullet client with its functions as methods)."""
        self.p = p
        if np_random is not None:
            self.np_random = np_random
        self.new_distance = math.inf
        self.old_distance = math.inf
        n = self.num_targets
        # PyFlyt 0.29.0: azimuth theta and polar angle phi, each U(0, 2 pi), drawn for all
        # targets first, then one radius per target; z folded to the upper half
        thetas = self.np_random.uniform(0.0, 2.0 * math.pi, size=(n,))
        phis = self.np_random.uniform(0.0, 2.0 * math.pi, size=(n,))
        self.targets = np.zeros((n, 3))
        for i in range(n):
            radius = self.np_random.uniform(low=1.0, high=0.9 * self.flight_dome_size)
            horizontal = radius * math.sin(phis[i])
            z = abs(radius * math.cos(phis[i]))
            x, y = horizontal * math.cos(thetas[i]), horizontal * math.sin(thetas[i])
            self.targets[i] = (x, y, max(z, self.min_height))
        if self.use_yaw_targets:
            self.yaw_targets = self.np_random.uniform(low=-math.pi, high=math.pi, size=(n,))
        if self.enable_render:
            self.target_visual = [self._marker(t) for t in self.targets]
            self._recolour()

    def _marker(self, position: np.ndarray) -> int:
        shape = self.p.createVisualShape(self.p.GEOM_SPHERE, radius=self.goal_reach_distance, rgbaColor=(0, 1, 0, 1))
        return int(self.p.createMultiBody(baseMass=0.0, baseVisualShapeIndex=shape, basePosition=list(position)))

    def _recolour(self) -> None:
        for i, body in enumerate(self.target_visual):
            self.p.changeVisualShape(body, -1, rgbaColor=(0, 1 - i / len(self.target_visual), 0, 1))

    @property
    def distance_to_next_target(self) -> float:
        return self.new_distance

    def distance_to_targets(self, ang_pos: np.ndarray, lin_pos: np.ndarray, quaternion: np.ndarray) -> np.ndarray:
        """(n, 3) body-frame vectors to every remaining target ((n, 4) with a yaw error per target)."""
        rotation = np.array(self.p.getMatrixFromQuaternion(quaternion)).reshape(3, 3)
        deltas = (np.asarray(self.targets) - lin_pos) @ rotation  # ground -> body
        self.old_distance = self.new_distance
        self.new_distance = float(np.linalg.norm(deltas[0])) if len(deltas) else math.inf
        if self.use_yaw_targets:
            yaw = (np.asarray(self.yaw_targets) - ang_pos[-1] + math.pi) % (2.0 * math.pi) - math.pi
            self.yaw_error_scalar = np.abs(yaw[0]) if len(yaw) else 0.0
            deltas = np.concatenate([deltas, yaw[:, None]], axis=-1)
        return deltas

    @property
    def progress_to_next_target(self) -> float:
        """Distance gained on the next target since the last :meth:`distance_to_targets` (0 at first)."""
        if math.isinf(self.old_distance + self.new_distance):
            return 0.0
        return self.old_distance - self.new_distance

    @property
    def target_reached(self) -> bool:
        if not self.new_distance < self.goal_reach_distance:
            return False
        return not self.use_yaw_targets or bool(self.yaw_error_scalar < self.goal_reach_angle)

    def advance_targets(self) -> None:
        """Drop the reached target (and its marker)."""
        self.targets = self.targets[1:] if len(self.targets) > 1 else []
        if self.use_yaw_targets:
            self.yaw_targets = self.yaw_targets[1:] if len(self.yaw_targets) > 1 else []
        if self.enable_render and self.target_visual:
            self.p.removeBody(self.target_visual.pop(0))
            self._recolour()

    @property
    def num_targets_reached(self) -> int:
        return self.num_targets - len(self.targets)

    @property
    def all_targets_reached(self) -> bool:
        return len(self.targets) == 0
