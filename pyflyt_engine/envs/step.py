"""One agent's step: its action clipped to the bounds, and the reward context of the step."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from pyflyt_engine.envs.rewards import StepContext
from pyflyt_engine.state import KinematicState


def clip_action(
    action: Any, low: np.ndarray, high: np.ndarray, names: Sequence[str], agent: str | None = None
) -> np.ndarray:
    """``action`` as a flat float64 array clipped to ``[low, high]``.

    Raises:
        ValueError: the action has another number of entries than ``names`` (naming
            ``agent`` when given).
    """
    a = np.asarray(action, dtype=np.float64).reshape(-1)
    if a.shape != low.shape:
        if agent is None:
            raise ValueError(f"action must have {low.size} values ({', '.join(names)}), got {a.size}")
        raise ValueError(f"agent '{agent}': action must have {low.size} values, got {a.size}")
    return np.minimum(np.maximum(a, low), high)


def step_context(
    world: Any,
    index: int,
    state: KinematicState,
    action: np.ndarray,
    collision: bool,
    out_of_bounds: bool,
    crashed: bool,
    signals: Any,
    waypoint_reached: bool,
    steps_remaining: int,
    agent_dt: float,
) -> StepContext:
    """The reward context of vehicle ``index``'s step; ``signals`` the task's (``complete``,
    ``target_distance``, ``target_distance_rate``, ``extras``)."""
    return StepContext(
        state,
        action,
        collision,
        world.collided_with_ground(index) if collision else False,
        out_of_bounds,
        crashed,
        signals.complete,
        signals.target_distance,
        signals.target_distance_rate,
        waypoint_reached,
        signals.extras,
        steps_remaining,
        agent_dt,
    )
