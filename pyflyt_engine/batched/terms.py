"""Reward terms, conditions and termination terms over a batch: the registered scalar ones, on arrays.

A batched env compiles its reward preset with the engine's own
:func:`~pyflyt_engine.envs.rewards.compile_reward` (the same checks, the same messages),
then evaluates each entry on arrays of N agents through the vector form of its term and
conditions, found here by the scalar function.  Each vector form is the scalar law's
expression on arrays, in the same order of operations, so every element equals the scalar
term's value bit for bit (``tests/batched/test_laws.py`` draws random contexts and checks
every registered pair).  A preset naming a term without a vector form is refused at load,
by name.

The episode's end is the env config's own declaration (``terminations``,
:mod:`pyflyt_engine.envs.terminations`), read by :func:`batched_ends`: the batched kernels
implement the terms ``contact``, ``out_of_dome``, ``task_complete`` and ``time_limit``;
``task_failure`` holds nothing to do (the batched tasks, hover and waypoints, declare no
failure) and ``payload_on_ground`` / ``obstacle_contact`` cannot fire (payloads and
obstacles are refused, :mod:`pyflyt_engine.batched.support`).  Any other term is refused by name.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pyflyt_engine.batched.model import refuse
from pyflyt_engine.envs import rewards as r
from pyflyt_engine.envs import terminations as t
from pyflyt_engine.envs.tasks import ma_formation as formation
from pyflyt_engine.envs.rewards import RewardFunction


@dataclass
class BatchContext:
    """:class:`~pyflyt_engine.envs.rewards.StepContext` for N agents: each field an array
    with one row per agent (the state's fields (N, 3), flags (N,) bool, the target signals
    (N,) float, NaN where a task has no target)."""

    ang_vel: np.ndarray
    ang_pos: np.ndarray
    lin_vel: np.ndarray
    lin_pos: np.ndarray
    action: np.ndarray
    collision: np.ndarray
    ground_collision: np.ndarray
    out_of_bounds: np.ndarray
    crashed: np.ndarray
    task_complete: np.ndarray
    target_distance: np.ndarray
    target_distance_rate: np.ndarray
    waypoint_reached: np.ndarray
    steps_remaining: np.ndarray
    agent_dt: float
    #: a task's own signals by name, (N,) each (the formation's ``formation_error``, ...)
    extras: dict[str, np.ndarray] = field(default_factory=dict)


def _norm3(v: np.ndarray) -> np.ndarray:
    x, y, z = v[:, 0], v[:, 1], v[:, 2]
    return np.sqrt(x * x + y * y + z * z)


def _distance_to_point(ctx: BatchContext, point: Any = (0.0, 0.0, 1.0)) -> np.ndarray:
    p = ctx.lin_pos
    dx, dy, dz = p[:, 0] - point[0], p[:, 1] - point[1], p[:, 2] - point[2]
    return np.sqrt(dx**2 + dy**2 + dz**2)


def _inverse_target_distance(ctx: BatchContext, floor: float = 0.0) -> np.ndarray:
    delta = ctx.target_distance
    bounded = np.where(floor > delta, floor, delta)  # max(delta, floor): a NaN delta stays NaN
    with np.errstate(divide="ignore"):
        return 1.0 / bounded


def _yaw_rate_squared(ctx: BatchContext) -> np.ndarray:
    rate = ctx.ang_vel[:, 2]
    return rate * rate


#: the vector form of each scalar term (keyed by the registered function)
VECTOR_TERMS: dict[Callable[..., float], Callable[..., np.ndarray]] = {
    r.constant: lambda ctx: np.ones(len(ctx.crashed)),
    r.tilt: lambda ctx: np.sqrt(ctx.ang_pos[:, 0] * ctx.ang_pos[:, 0] + ctx.ang_pos[:, 1] * ctx.ang_pos[:, 1]),
    r.distance_to_point: _distance_to_point,
    r.target_distance: lambda ctx: ctx.target_distance,
    r.inverse_target_distance: _inverse_target_distance,
    r.target_distance_rate: lambda ctx: ctx.target_distance_rate,
    r.target_distance_decrease: lambda ctx: -ctx.target_distance_rate * ctx.agent_dt,
    r.target_distance_over_remaining_steps: lambda ctx: ctx.target_distance * ctx.steps_remaining,
    r.speed: lambda ctx: _norm3(ctx.lin_vel),
    r.angular_speed: lambda ctx: _norm3(ctx.ang_vel),
    r.altitude: lambda ctx: ctx.lin_pos[:, 2].copy(),
    r.yaw_rate_squared: _yaw_rate_squared,
    formation.formation_error: lambda ctx: ctx.extras["formation_error"].copy(),
    formation.crowding: lambda ctx: ctx.extras["crowding"].copy(),
}

#: the vector form of each scalar condition
VECTOR_CONDITIONS: dict[Callable[..., bool], Callable[[BatchContext], np.ndarray]] = {
    r.crash: lambda ctx: ctx.crashed,
    r.collision: lambda ctx: ctx.collision,
    r.ground_collision: lambda ctx: ctx.ground_collision,
    r.out_of_bounds: lambda ctx: ctx.out_of_bounds,
    r.waypoint_reached: lambda ctx: ctx.waypoint_reached,
    r.approaching: lambda ctx: ctx.target_distance_rate < 0.0,
    r.task_complete: lambda ctx: ctx.task_complete,
    formation.in_formation: lambda ctx: ~ctx.crashed & (ctx.extras["in_formation"] > 0.5),
}


class BatchedReward:
    """A compiled preset over N agents: ``total, breakdown = reward(ctx)`` with (N,) arrays;
    the entries, weights and conditions are the scalar :class:`RewardFunction`'s."""

    def __init__(self, function: RewardFunction) -> None:
        self.name = function.name
        self.keys = function.keys
        self._entries = []
        for entry in function._entries:
            vector = VECTOR_TERMS.get(entry.fn)
            if vector is None:
                raise refuse(f"the reward term of entry '{entry.key}' ({entry.fn.__name__}) of preset {function.name}")
            conditions = []
            for cond, negate in entry.conditions:
                vcond = VECTOR_CONDITIONS.get(cond)
                if vcond is None:
                    raise refuse(f"the condition {cond.__name__} (entry '{entry.key}' of preset {function.name})")
                conditions.append((vcond, negate))
            self._entries.append((entry.key, vector, entry.params, entry.weight, tuple(conditions)))

    def __call__(self, ctx: BatchContext) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        n = len(ctx.crashed)
        total = np.zeros(n)
        breakdown: dict[str, np.ndarray] = {}
        with np.errstate(invalid="ignore", divide="ignore"):
            for key, vector, params, weight, conditions in self._entries:
                active = None  # every row, until a condition says otherwise
                for cond, negate in conditions:
                    held = np.asarray(cond(ctx), dtype=bool)
                    held = ~held if negate else held
                    active = held if active is None else active & held
                if active is None or active.all():  # the term's value in every row
                    value = weight * np.asarray(vector(ctx, **params), dtype=np.float64)
                elif active.any():  # 0 where a condition fails (the term's value there is never used)
                    value = np.where(active, weight * np.asarray(vector(ctx, **params), dtype=np.float64), 0.0)
                else:  # no row: the term is not evaluated (1/delta is never computed without a target)
                    value = np.zeros(n)
                breakdown[key] = value
                np.add(total, value, out=total)
        return total, breakdown


@dataclass(frozen=True)
class BatchedEnds:
    """What ends a batched env's episode, from its config's ``terminations``: a contact is a
    crash (``contact``), leaving the dome is one (``out_of_dome``), completion ends it
    (``task_complete``), the time limit truncates it (``time_limit``)."""

    contact: bool
    dome: bool
    complete: bool
    time_limit: bool


#: the termination terms with nothing to do in the batched backend (see the module docstring)
_INERT = (t.task_failure, t.payload_on_ground, t.obstacle_contact)


def batched_ends(terminations: Any, crash_on_contact: bool) -> BatchedEnds:
    """The :class:`BatchedEnds` of a ``terminations`` declaration, the task crashing on a
    contact by ``crash_on_contact`` (unless the ``contact`` entry's parameter says otherwise).

    Raises:
        UnsupportedByBatched: a declared term the batched backend does not implement, by name.
    """
    contact = dome = complete = time_limit = False
    for key, term, params in t.declared(terminations):
        law = term.bind
        if law is t.contact:
            given = params.get("crash_on_contact")
            contact = crash_on_contact if given is None else bool(given)
        elif law is t.out_of_dome:
            dome = True
        elif law is t.task_complete:
            complete = True
        elif law is t.time_limit:
            time_limit = True
        elif law not in _INERT:
            raise refuse(
                f"the termination term '{key}' ({law.__name__})",
                "it ends episodes by contact, out_of_dome, task_failure, task_complete and time_limit",
            )
    return BatchedEnds(contact, dome, complete, time_limit)
