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

import inspect
import math

import numpy as np

from pyflyt_engine.batched.compiled import njit
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


#: the terms and conditions :func:`reward_rows` evaluates compiled, by code (the index)
COMPILED_TERMS = (
    r.constant,
    r.tilt,
    r.distance_to_point,
    r.target_distance,
    r.inverse_target_distance,
    r.target_distance_rate,
    r.target_distance_decrease,
    r.target_distance_over_remaining_steps,
    r.speed,
    r.angular_speed,
    r.altitude,
    r.yaw_rate_squared,
)
COMPILED_CONDITIONS = (
    r.crash,
    r.collision,
    r.ground_collision,
    r.out_of_bounds,
    r.waypoint_reached,
    r.approaching,
    r.task_complete,
)
#: a compiled entry's parameters: distance_to_point's point, inverse_target_distance's floor
_PARAMS = 3


@njit(cache=True, inline="always")
def _term_value(code, k0, k1, k2, rates, angles, velocity, position, distance, rate, remaining, dt):  # fmt: skip
    """Term ``code`` (its index in :data:`COMPILED_TERMS`), parameters ``k0, k1, k2``, of one
    row's values (the state's 3-tuples, the target signals): the scalar law's expression
    (:mod:`pyflyt_engine.envs.rewards`) in its order of operations.  On scalars only: an
    array passed into a helper inside the row loop would be counted in and out of use at
    each call (:func:`~pyflyt_engine.batched.kernels.read_state`)."""
    if code == 0:
        return 1.0
    if code == 1:
        a, b = angles[0], angles[1]
        return math.sqrt(a * a + b * b)
    if code == 2:
        dx, dy, dz = position[0] - k0, position[1] - k1, position[2] - k2
        return math.sqrt(dx * dx + dy * dy + dz * dz)
    if code == 3:
        return distance
    if code == 4:
        return 1.0 / (k0 if k0 > distance else distance)  # 1 / max(delta, floor): a NaN delta stays NaN
    if code == 5:
        return rate
    if code == 6:
        return -rate * dt
    if code == 7:
        return distance * remaining
    if code == 8:
        x, y, z = velocity
        return math.sqrt(x * x + y * y + z * z)
    if code == 9:
        x, y, z = rates
        return math.sqrt(x * x + y * y + z * z)
    if code == 10:
        return position[2]
    w = rates[2]  # 11: yaw rate squared
    return w * w


@njit(cache=True)
def reward_rows(terms, params, weights, conditions, negate, ang_vel, ang_pos, lin_vel, lin_pos, collision, ground,
                out, crashed, complete, distance, rate, reached, remaining, dt, breakdown, total):  # fmt: skip
    """A compiled preset over every row: entry ``e`` is term ``terms[e]`` (parameters
    ``params[e]``) times ``weights[e]`` where each of its conditions ``conditions[e, c]``
    (-1: none; codes of :data:`COMPILED_CONDITIONS`) holds (``negate[e, c]``: does not
    hold), else 0, into ``breakdown[e]``; ``total`` their sum in entry order, as
    :meth:`RewardFunction.__call__` adds them."""
    for i in range(total.shape[0]):
        rates = (ang_vel[i, 0], ang_vel[i, 1], ang_vel[i, 2])
        angles = (ang_pos[i, 0], ang_pos[i, 1], ang_pos[i, 2])
        velocity = (lin_vel[i, 0], lin_vel[i, 1], lin_vel[i, 2])
        position = (lin_pos[i, 0], lin_pos[i, 1], lin_pos[i, 2])
        d, v, left = distance[i], rate[i], remaining[i]
        flags = (crashed[i], collision[i], ground[i], out[i], reached[i], v < 0.0, complete[i])
        sum_ = 0.0
        for e in range(terms.shape[0]):
            active = True
            for c in range(conditions.shape[1]):
                code = conditions[e, c]
                if code < 0:
                    break
                if flags[code] == negate[e, c]:
                    active = False
                    break
            value = 0.0
            if active:
                term = _term_value(
                    terms[e],
                    params[e, 0],
                    params[e, 1],
                    params[e, 2],
                    rates,
                    angles,
                    velocity,
                    position,
                    d,
                    v,
                    left,
                    dt,
                )
                value = weights[e] * term
            breakdown[e, i] = value
            sum_ += value
        total[i] = sum_


class BatchedReward:
    """A compiled preset over N agents: ``total, breakdown = reward(ctx)`` with (N,) arrays;
    the entries, weights and conditions are the scalar :class:`RewardFunction`'s.

    A preset of the terms and conditions in :data:`COMPILED_TERMS` and
    :data:`COMPILED_CONDITIONS` (every single-agent preset) is evaluated by one compiled
    pass, :func:`reward_rows`, row by row as the scalar function does; any other (a task's
    own signals, the formation's) by the entries' vector forms on whole arrays.  Both give
    the scalar law's numbers bit for bit (``tests/batched/test_laws.py``); the compiled
    pass takes ~4.9 us where the NumPy calls take ~11 at N = 256 (``experiments/speed_reward.py``)."""

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
        self._program = _program(function)

    @property
    def program(self) -> tuple[np.ndarray, ...] | None:
        """The arrays :func:`reward_rows` evaluates the preset from (term codes, parameters,
        weights, condition codes, negations), or None where an entry is not compiled."""
        return self._program

    def __call__(self, ctx: BatchContext) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        if self._program is not None:
            return self._compiled(ctx)
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

    def _compiled(self, ctx: BatchContext) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        n = len(ctx.crashed)
        total = np.empty(n)
        rows = np.empty((len(self.keys), n))
        assert self._program is not None  # __call__ takes this path only then
        terms, params, weights, conditions, negate = self._program
        reward_rows(  # the env's arrays as they are (a layout or dtype of its own compiles its own loop)
            terms,
            params,
            weights,
            conditions,
            negate,
            ctx.ang_vel,
            ctx.ang_pos,
            ctx.lin_vel,
            ctx.lin_pos,
            ctx.collision,
            ctx.ground_collision,
            ctx.out_of_bounds,
            ctx.crashed,
            ctx.task_complete,
            ctx.target_distance,
            ctx.target_distance_rate,
            ctx.waypoint_reached,
            ctx.steps_remaining,
            float(ctx.agent_dt),
            rows,
            total,
        )
        return total, dict(zip(self.keys, rows))


def _program(function: RewardFunction) -> tuple[np.ndarray, ...] | None:
    """The arrays :func:`reward_rows` evaluates ``function`` from (term codes, parameters,
    weights, condition codes, negations), or None where an entry is not compiled."""
    k = len(function._entries)
    width = max((len(e.conditions) for e in function._entries), default=0)
    terms = np.empty(k, dtype=np.int64)
    params = np.zeros((k, _PARAMS))
    weights = np.empty(k)
    conditions = np.full((k, max(width, 1)), -1, dtype=np.int64)
    negate = np.zeros((k, max(width, 1)), dtype=bool)
    for e, entry in enumerate(function._entries):
        if entry.fn not in COMPILED_TERMS:
            return None
        terms[e] = COMPILED_TERMS.index(entry.fn)
        given = {  # the term's defaults, then the preset's parameters
            **{k: p.default for k, p in inspect.signature(entry.fn).parameters.items() if k != "ctx"},
            **entry.params,
        }
        if entry.fn is r.distance_to_point:
            params[e] = tuple(given["point"])
        elif entry.fn is r.inverse_target_distance:
            params[e, 0] = given["floor"]
        weights[e] = entry.weight
        for c, (cond, neg) in enumerate(entry.conditions):
            if cond not in COMPILED_CONDITIONS:
                return None
            conditions[e, c], negate[e, c] = COMPILED_CONDITIONS.index(cond), neg
    return terms, params, weights, conditions, negate


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
