"""One agent's step: its action clipped to the bounds, what the step was (:class:`AgentStep`)
and the reward context of it."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
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


@dataclass(slots=True)
class AgentStep:
    """What one agent's step was, as the termination terms and the reward context read it.

    Attributes:
        index: the agent's index (its vehicle's in the World).
        state: its vehicle's state at the end of the step.
        action: the action it applied (clipped to the bounds).
        collision: its vehicle touched anything (ground included) during the step.
        out_of_bounds: its centre of mass is outside the flight dome.
        signals: the task's signals of its step (``complete``, ``failed``, ``target_distance``,
            ``target_distance_rate``, ``waypoint_reached``, ``extras``).
        steps: agent steps since the reset, this one included.

    The episode core keeps one per agent and rewrites it at each step: a termination term
    reads it during its call and keeps what it needs, not the record.
    """

    index: int
    state: KinematicState
    action: np.ndarray
    collision: bool
    out_of_bounds: bool
    signals: Any
    steps: int


def step_context(world: Any, step: AgentStep, *, crashed: bool, steps_remaining: int, agent_dt: float) -> StepContext:
    """The reward context of one agent's ``step`` (``crashed``: a ``crash`` termination term held)."""
    signals = step.signals
    return StepContext(
        step.state,
        step.action,
        step.collision,
        world.collided_with_ground(step.index) if step.collision else False,
        step.out_of_bounds,
        crashed,
        signals.complete,
        signals.target_distance,
        signals.target_distance_rate,
        signals.waypoint_reached,
        signals.extras,
        steps_remaining,
        agent_dt,
    )
