"""Waypoint logic shared by every waypoint task (QuadX now, Fixedwing later).

Pure functions (generation, body-frame deltas, reach test) plus :class:`WaypointTracker`,
the small state machine that walks an ordered list of waypoints.  Nothing here touches
PyBullet: positions and quaternions come in as plain numbers.

Reach test.  The paper counts a waypoint as reached when the centre of mass is within
the reach distance d of it.  The vehicle is only observed once per agent step (33 ms at
30 Hz, during which a quadrotor at 6 m/s moves 0.2 m, the default d), so testing the
sampled positions alone would let a fast pass through the sphere go unnoticed depending
on the agent rate.  The tracker therefore tests the straight segment between the
positions at the start and end of the step: reached when its closest point is within d
(the sampling-rate-independent form of the paper's test; for a vehicle at rest it is the
point test).  Until a waypoint is reached, the end-of-step distance is >= d, so the
1/delta reward term is bounded by 1/d.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from pyflyt_engine import exact
from pyflyt_engine.frames import quaternion_to_rows


def sample_waypoints(
    rng: np.random.Generator,
    count: int,
    min_distance: float,
    max_distance: float,
    min_height: float,
) -> np.ndarray:
    """Random waypoints above the ground, ``(count, 3)`` ground-frame positions [m].

    Each waypoint is at a distance from the origin uniform in
    ``[min_distance, max_distance]``, in a direction uniform on the upper unit
    hemisphere; heights below ``min_height`` are raised to it (as the reference does).
    Draws exactly ``4 * count`` numbers from ``rng``.
    """
    direction = rng.standard_normal((count, 3))
    norm = np.sqrt(np.sum(direction * direction, axis=1, keepdims=True))
    direction = direction / np.maximum(norm, 1e-12)
    direction[:, 2] = np.abs(direction[:, 2])
    distance = rng.uniform(min_distance, max_distance, size=(count, 1))
    targets = direction * distance
    targets[:, 2] = np.maximum(targets[:, 2], min_height)
    return targets


def body_frame_deltas(targets: np.ndarray, position: Sequence[float], quaternion: Sequence[float]) -> np.ndarray:
    """Vectors from the vehicle to each target, in the body frame [m], shape ``(n, 3)``.

    ``delta_body = R^T (target - position)`` with ``R`` the body-to-ground rotation of
    ``quaternion`` (x, y, z, w); row-wise that is ``(targets - position) @ R``, written
    out element-wise (:func:`pyflyt_engine.exact.rows_rotate_t`, not BLAS).
    """
    targets = np.asarray(targets, dtype=np.float64).reshape(-1, 3)
    return exact.rows_rotate_t(targets, quaternion_to_rows(quaternion), position)


def segment_point_distance(start: Sequence[float], end: Sequence[float], point: Sequence[float]) -> float:
    """Shortest distance from ``point`` to the segment ``start``-``end`` [m]."""
    ax, ay, az = start
    dx, dy, dz = end[0] - ax, end[1] - ay, end[2] - az
    px, py, pz = point[0] - ax, point[1] - ay, point[2] - az
    length2 = dx * dx + dy * dy + dz * dz
    t = 0.0 if length2 == 0.0 else min(max((px * dx + py * dy + pz * dz) / length2, 0.0), 1.0)
    ex, ey, ez = px - t * dx, py - t * dy, pz - t * dz
    return math.sqrt(ex * ex + ey * ey + ez * ez)


def _distance(a: Sequence[float], b: Sequence[float]) -> float:
    return math.sqrt((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2)


class WaypointTracker:
    """Walks an ordered list of waypoints; one :meth:`step` per agent step.

    Attributes:
        targets: every waypoint of the episode, ``(n, 3)`` ground frame [m].
        num_reached: how many have been reached (the next one is ``targets[num_reached]``).
        reach_distance: d [m].
    """

    def __init__(self, reach_distance: float) -> None:
        self.reach_distance = float(reach_distance)
        self.targets = np.zeros((0, 3))
        self.num_reached = 0
        self._position: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self._distance = 0.0

    def reset(self, targets: np.ndarray, position: Sequence[float]) -> None:
        """Start a new list; ``position`` is the vehicle's current position."""
        self.targets = np.array(targets, dtype=np.float64).reshape(-1, 3)
        self.num_reached = 0
        self._position = tuple(position)  # type: ignore[assignment]
        self._distance = _distance(position, self.targets[0]) if len(self.targets) else 0.0

    @property
    def remaining(self) -> np.ndarray:
        """Waypoints not yet reached, in order (a view; do not modify)."""
        return self.targets[self.num_reached :]

    @property
    def all_reached(self) -> bool:
        return self.num_reached >= len(self.targets)

    def step(self, position: Sequence[float], dt: float) -> tuple[float, float, bool]:
        """Advance one agent step to ``position``; returns ``(delta, delta_dot, reached)``.

        ``delta`` [m] and ``delta_dot`` [m/s] are measured to the waypoint that was next
        at the start of the step; if it was reached (segment test, see the module
        docstring) the tracker moves on to the following one, whose distance from
        ``position`` becomes the reference for the next step's rate.  Once every
        waypoint is reached, returns ``(0.0, 0.0, False)``.
        """
        if self.all_reached:
            self._position = tuple(position)  # type: ignore[assignment]
            return 0.0, 0.0, False
        target = self.targets[self.num_reached]
        distance = _distance(position, target)
        rate = (distance - self._distance) / dt
        reached = segment_point_distance(self._position, position, target) < self.reach_distance
        if reached:
            self.num_reached += 1
            if not self.all_reached:
                self._distance = _distance(position, self.targets[self.num_reached])
        else:
            self._distance = distance
        self._position = tuple(position)  # type: ignore[assignment]
        return distance, rate, reached
