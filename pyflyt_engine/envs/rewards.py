"""Reward terms and conditions: pure named functions, and the weighted sum over them.

A reward preset (``conf/reward/*.yaml``) declares a reward as a weighted sum of named
terms, each gated by conditions::

    r = sum_i  w_i * term_i(ctx) * [all conditions_i hold]

Terms and conditions read only the :class:`StepContext` of the current agent step, so
each is a pure function that a test can evaluate by hand.  The registries below are
plain dicts (name -> entry); :func:`compile_reward` checks a preset against them and
against the signals its task provides, and returns a :class:`RewardFunction` that gives
the total and the per-term breakdown (after weights, in declaration order, inactive
terms reported as 0.0) that goes into ``info["reward_terms"]``.

Every condition ``X`` also exists as ``not_X``.

Adding a term: write ``def my_term(ctx, **params) -> float`` with a docstring and
register it with :func:`register_term` and the task signals it reads (``requires``); presets
can then name it.  This module holds the generic terms and conditions (of the vehicle state,
the action, the target distance, contacts); a term or condition that reads one task's own
signals lives in that task's module, which registers it (``tasks/pole.py``,
``tasks/ball_in_cup.py``, ``tasks/landing.py``, ``tasks/dogfight.py``,
``tasks/ma_formation.py``).  Task signals are the optional :class:`StepContext` fields
(``target_distance``, ``target_distance_rate``, ``waypoint_reached``) plus anything a task
puts in ``ctx.extras``.
"""

from __future__ import annotations

import functools
import inspect
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, NamedTuple

import numpy as np

from pyflyt_engine import exact
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.state import KinematicState
from pyflyt_engine.suggest import did_you_mean

_NO_EXTRAS: Mapping[str, float] = MappingProxyType({})  # read-only: one empty mapping shared by every step

#: Signals every task provides (read from the vehicle and the world, not the task).
BASE_SIGNALS = frozenset(
    {
        "state",
        "action",
        "collision",
        "ground_collision",
        "out_of_bounds",
        "crashed",
        "task_complete",
        "steps_remaining",
        "agent_dt",
    }
)


class StepContext(NamedTuple):
    """What reward terms and conditions may read at one agent step.

    Attributes:
        state: the vehicle's state at the end of the step (see :class:`KinematicState`).
        action: the action applied during the step (after clipping to the action space).
        collision: the vehicle touched anything (ground included) during the step.
        ground_collision: the vehicle touched the ground during the step.
        out_of_bounds: the vehicle is farther than the flight dome radius from the origin.
        crashed: the step ended the episode in failure: a contact (for tasks where any
            contact is a crash, as in every built-in task), leaving the flight dome, or a
            failure the task declares.
        task_complete: the task is finished (e.g. the last waypoint was just reached).
        target_distance: delta, distance from the centre of mass to the task's current
            target [m] (hover point, next waypoint, landing pad); None if the task has none.
        target_distance_rate: d(delta)/dt over the agent step [m/s], negative while
            approaching; measured to the same target at both ends of the step.
        waypoint_reached: a waypoint was reached during the step.
        extras: further task-specific signals by name (the landing task's ``pad_contact``,
            ``safe_landing``, ``fatal_landing`` as 0/1 and ``touchdown_speed`` [m/s]).
        steps_remaining: agent steps the episode had left after this one before its time
            limit (0 on the last step); every env sets it.
        agent_dt: duration of the agent step [s] (1 / agent_hz); every env sets it.

    A named tuple (immutable, and built at every agent step at a fraction of a frozen
    dataclass's cost).
    """

    state: KinematicState
    action: np.ndarray
    collision: bool
    ground_collision: bool
    out_of_bounds: bool
    crashed: bool
    task_complete: bool = False
    target_distance: float | None = None
    target_distance_rate: float | None = None
    waypoint_reached: bool = False
    extras: Mapping[str, float] = _NO_EXTRAS
    steps_remaining: int = 0
    agent_dt: float = math.nan


@dataclass(frozen=True)
class RewardTerm:
    """A registered term: a pure function of the context (and keyword parameters)."""

    fn: Callable[..., float]
    unit: str
    requires: tuple[str, ...] = ()
    nonnegative: tuple[str, ...] = ()
    """Parameters that must be numbers >= 0 (checked when a preset is compiled)."""

    @property
    def description(self) -> str:
        return (self.fn.__doc__ or "").strip().splitlines()[0]


@dataclass(frozen=True)
class Condition:
    """A registered condition: a pure predicate on the context."""

    fn: Callable[[StepContext], bool]
    requires: tuple[str, ...] = ()

    @property
    def description(self) -> str:
        return (self.fn.__doc__ or "").strip().splitlines()[0]


# ------------------------------------------------------------------------ terms


def constant(ctx: StepContext) -> float:
    """1: a fixed reward or penalty per step, sized by the weight."""
    return 1.0


def tilt(ctx: StepContext) -> float:
    """||[roll, pitch]||: tilt of the body from level [rad] (Euler angles, ground frame)."""
    roll, pitch, _ = ctx.state.ang_pos
    return math.sqrt(roll * roll + pitch * pitch)


def distance_to_point(ctx: StepContext, point: Sequence[float] = (0.0, 0.0, 1.0)) -> float:
    """||p - point||: distance of the centre of mass from a fixed ground-frame point [m]."""
    x, y, z = ctx.state.lin_pos
    return math.sqrt((x - point[0]) ** 2 + (y - point[1]) ** 2 + (z - point[2]) ** 2)


def target_distance(ctx: StepContext) -> float:
    """delta: distance from the centre of mass to the task's current target [m]."""
    return ctx.target_distance  # type: ignore[return-value]


def inverse_target_distance(ctx: StepContext, floor: float = 0.0) -> float:
    """1 / max(delta, floor): inverse distance to the task's current target [1/m] (floor [m] bounds it)."""
    delta = ctx.target_distance
    # (a NaN delta, first, stays NaN); the term needs target_distance, so delta is a float
    return 1.0 / max(delta, floor)  # type: ignore[operator,type-var]


def target_distance_rate(ctx: StepContext) -> float:
    """d(delta)/dt: rate of change of the distance to the current target [m/s], < 0 approaching."""
    return ctx.target_distance_rate  # type: ignore[return-value]


def target_distance_decrease(ctx: StepContext) -> float:
    """Decrease of delta over the agent step [m], > 0 approaching: the reference PyFlyt's waypoint progress."""
    return -ctx.target_distance_rate * ctx.agent_dt  # type: ignore[operator]


def target_distance_over_remaining_steps(ctx: StepContext) -> float:
    """delta x steps left before the time limit: a per-step distance cost, paid for the rest of the episode [m]."""
    return ctx.target_distance * ctx.steps_remaining  # type: ignore[operator]


def speed_per_squared_target_distance(ctx: StepContext) -> float:
    """||v|| / delta^2: speed over the squared distance to the target [1/(m s)] (Rocket-Landing's r_v)."""
    u, v, w = ctx.state.lin_vel
    return math.sqrt(u * u + v * v + w * w) / (ctx.target_distance * ctx.target_distance)  # type: ignore[operator]


def speed_above_braking_envelope(
    ctx: StepContext, deceleration: float = 30.0, floor_speed: float = 0.5, floor_distance: float = 0.0
) -> float:
    """max(0, ||v|| - v_env(delta)): speed above the braking envelope to the target [m/s].

    ``v_env(delta) = floor_speed + sqrt(2 * deceleration * max(delta - floor_distance, 0))``
    is the fastest approach from which braking at ``deceleration`` [m/s^2] still arrives
    at ``floor_distance`` [m] from the target no faster than ``floor_speed`` [m/s].  0
    inside the envelope, so it only costs speed that can no longer be braked away.
    """
    u, v, w = ctx.state.lin_vel
    room = max(ctx.target_distance - floor_distance, 0.0)  # type: ignore[operator]
    return max(0.0, math.sqrt(u * u + v * v + w * w) - floor_speed - math.sqrt(2.0 * deceleration * room))


def speed(ctx: StepContext) -> float:
    """||v||: linear speed of the centre of mass [m/s]."""
    u, v, w = ctx.state.lin_vel
    return math.sqrt(u * u + v * v + w * w)


def angular_speed(ctx: StepContext) -> float:
    """||omega||: body angular speed [rad/s]."""
    p, q, r = ctx.state.ang_vel
    return math.sqrt(p * p + q * q + r * r)


def altitude(ctx: StepContext) -> float:
    """z: height of the centre of mass above the ground plane [m]."""
    return ctx.state.lin_pos[2]


def action_magnitude(ctx: StepContext) -> float:
    """||a||: Euclidean norm of the action, in the action space's units."""
    return exact.norm(ctx.action)


def yaw_rate_squared(ctx: StepContext) -> float:
    """r^2: squared body yaw rate [rad^2/s^2] (the reference PyFlyt's yaw-rate penalty)."""
    r = ctx.state.ang_vel[2]
    return r * r


def state_error(ctx: StepContext, point: Sequence[float] = (0.0, 0.0, 1.0)) -> float:
    """||omega||^2 + ||[roll, pitch, yaw]||^2 + ||v||^2 + ||p - point||^2: the reference ball-in-cup's state error [SI^2]."""
    s = ctx.state
    total = 0.0
    for row in (s.ang_vel, s.ang_pos, s.lin_vel):
        total += row[0] * row[0] + row[1] * row[1] + row[2] * row[2]
    x, y, z = s.lin_pos
    return total + (x - point[0]) ** 2 + (y - point[1]) ** 2 + (z - point[2]) ** 2


def floor_margin(ctx: StepContext, scale: float = 0.1) -> float:
    """tanh(scale * z - 1): rises from -0.76 on the ground through 0 at z = 1/scale [-] (reference dogfight floor term)."""
    return math.tanh(scale * ctx.state.lin_pos[2] - 1.0)


def dome_proximity(ctx: StepContext, scale: float = 0.0025) -> float:
    """tanh(scale * ||p|| - 1): grows with the distance from the origin, 0 at ||p|| = 1/scale [-] (reference dogfight)."""
    x, y, z = ctx.state.lin_pos
    return math.tanh(scale * math.sqrt(x * x + y * y + z * z) - 1.0)


#: Every reward term a preset may name: the generic ones here, and those each task registers
#: from its own module (:func:`register_term`).
TERMS: dict[str, RewardTerm] = {
    "constant": RewardTerm(constant, "1"),
    "tilt": RewardTerm(tilt, "rad"),
    "distance_to_point": RewardTerm(distance_to_point, "m"),
    "target_distance": RewardTerm(target_distance, "m", ("target_distance",)),
    "inverse_target_distance": RewardTerm(inverse_target_distance, "1/m", ("target_distance",)),
    "target_distance_rate": RewardTerm(target_distance_rate, "m/s", ("target_distance_rate",)),
    "target_distance_decrease": RewardTerm(target_distance_decrease, "m", ("target_distance_rate",)),
    "target_distance_over_remaining_steps": RewardTerm(target_distance_over_remaining_steps, "m", ("target_distance",)),
    "speed_per_squared_target_distance": RewardTerm(speed_per_squared_target_distance, "1/(m s)", ("target_distance",)),
    "speed_above_braking_envelope": RewardTerm(
        speed_above_braking_envelope, "m/s", ("target_distance",), ("deceleration", "floor_speed", "floor_distance")
    ),
    "speed": RewardTerm(speed, "m/s"),
    "angular_speed": RewardTerm(angular_speed, "rad/s"),
    "altitude": RewardTerm(altitude, "m"),
    "action_magnitude": RewardTerm(action_magnitude, "action units"),
    "yaw_rate_squared": RewardTerm(yaw_rate_squared, "rad^2/s^2"),
    "state_error": RewardTerm(state_error, "SI^2"),
    "floor_margin": RewardTerm(floor_margin, "1"),
    "dome_proximity": RewardTerm(dome_proximity, "1"),
}


# ------------------------------------------------------------------- conditions


def always(ctx: StepContext) -> bool:
    """Every step."""
    return True


def crash(ctx: StepContext) -> bool:
    """The step ended in failure: a contact (ground included), leaving the flight dome, or a task failure."""
    return ctx.crashed


def collision(ctx: StepContext) -> bool:
    """The vehicle touched anything, ground included."""
    return ctx.collision


def ground_collision(ctx: StepContext) -> bool:
    """The vehicle touched the ground."""
    return ctx.ground_collision


def out_of_bounds(ctx: StepContext) -> bool:
    """The vehicle is outside the flight dome."""
    return ctx.out_of_bounds


def waypoint_reached(ctx: StepContext) -> bool:
    """A waypoint was reached during the step."""
    return ctx.waypoint_reached


def approaching(ctx: StepContext) -> bool:
    """The distance to the current target shrank over the step (d(delta)/dt < 0)."""
    return ctx.target_distance_rate is not None and ctx.target_distance_rate < 0.0


def task_complete(ctx: StepContext) -> bool:
    """The task was completed during the step (e.g. the last waypoint reached)."""
    return ctx.task_complete


#: Every condition a preset may name (each also as ``not_<name>``): the generic ones here,
#: and those each task registers from its own module (:func:`register_condition`).
CONDITIONS: dict[str, Condition] = {
    "always": Condition(always),
    "crash": Condition(crash),
    "collision": Condition(collision),
    "ground_collision": Condition(ground_collision),
    "out_of_bounds": Condition(out_of_bounds),
    "waypoint_reached": Condition(waypoint_reached, ("waypoints",)),
    "approaching": Condition(approaching, ("target_distance_rate",)),
    "task_complete": Condition(task_complete),
}


def register_term(name: str, term: RewardTerm) -> None:
    """Make ``term`` available to reward presets as ``name``: a task registers the terms that
    read its own signals from its own module (e.g. the pole task's ``pole_lean``)."""
    if name in TERMS and TERMS[name] != term:
        raise ValueError(f"reward term '{name}' is registered already, by another function")
    TERMS[name] = term


def register_condition(name: str, condition: Condition) -> None:
    """Make ``condition`` available to reward presets as ``name`` (and ``not_<name>``)."""
    if name == "always" or name.startswith("not_"):
        raise ValueError(f"'{name}' cannot name a condition (reserved)")
    if name in CONDITIONS and CONDITIONS[name] != condition:
        raise ValueError(f"condition '{name}' is registered already, by another function")
    CONDITIONS[name] = condition


def condition_names() -> list[str]:
    """Every valid condition name, negations included."""
    return list(CONDITIONS) + [f"not_{name}" for name in CONDITIONS if name != "always"]


def resolve_condition(name: str) -> tuple[Condition, bool]:
    """The condition for ``name`` and whether it is negated (``not_`` prefix).

    Raises:
        ConfigError: unknown name, listing the valid ones.
    """
    if name in CONDITIONS:
        return CONDITIONS[name], False
    if name.startswith("not_") and name[4:] in CONDITIONS and name != "not_always":
        return CONDITIONS[name[4:]], True
    raise ConfigError(_unknown("condition", name, condition_names()))


def resolve_term(name: str) -> RewardTerm:
    """The registered term ``name``. Raises ConfigError listing the valid ones."""
    try:
        return TERMS[name]
    except KeyError:
        raise ConfigError(_unknown("reward term", name, list(TERMS))) from None


def term_parameters(term: RewardTerm) -> dict[str, Any]:
    """Keyword parameters of a term and their defaults."""
    params = list(inspect.signature(term.fn).parameters.values())[1:]
    return {p.name: p.default for p in params}


def _unknown(kind: str, name: str, valid: list[str]) -> str:
    hint = did_you_mean(str(name), valid)
    return f"unknown {kind} '{name}'.{hint} Valid: {', '.join(valid)}"


# ------------------------------------------------------------ weighted sum


@dataclass(frozen=True)
class _Compiled:
    key: str
    fn: Callable[..., float]
    params: dict[str, Any]
    weight: float
    conditions: tuple[tuple[Callable[[StepContext], bool], bool], ...]


class RewardFunction:
    """A compiled preset: ``reward, breakdown = reward_fn(ctx)``.

    ``breakdown`` maps every declared entry (in order) to its weighted value, 0.0 when
    its conditions do not hold (the term is then not evaluated, so 1/delta is never
    computed without a target); ``reward`` is the sum of ``breakdown`` in that order.
    """

    def __init__(self, name: str, entries: Sequence[_Compiled]) -> None:
        self.name = name
        self._entries = tuple(entries)
        self.keys = tuple(e.key for e in entries)

    def __call__(self, ctx: StepContext) -> tuple[float, dict[str, float]]:
        breakdown: dict[str, float] = {}
        total = 0.0
        for entry in self._entries:
            value = 0.0
            for cond, negate in entry.conditions:
                if cond(ctx) == negate:
                    break
            else:
                value = entry.weight * float(entry.fn(ctx, **entry.params))
            breakdown[entry.key] = value
            total += value
        return total, breakdown

    def __repr__(self) -> str:
        return f"RewardFunction({self.name!r}, terms={list(self.keys)})"


def _field(spec: Any, name: str, default: Any = None) -> Any:
    """``spec.name`` or ``spec[name]``; ``default`` when absent or None."""
    value = spec.get(name, default) if isinstance(spec, Mapping) else getattr(spec, name, default)
    return default if value is None else value


def compile_reward(
    name: str,
    terms: Mapping[str, Any],
    provides: frozenset[str] | None = None,
    task_name: str = "?",
) -> RewardFunction:
    """Build a :class:`RewardFunction` from a preset's ``terms`` mapping.

    Args:
        name: the preset's name (for messages).
        terms: entry key -> object with ``term``, ``weight``, ``when``, ``params``
            (a :class:`~pyflyt_engine.envs.config.TermConfig` or a dict of those keys).
        provides: the signals the task provides; None skips that check.
        task_name: the task's name (for messages).

    Raises:
        ConfigError: unknown term, condition or parameter, or a signal the task lacks.
    """
    entries = []
    available = BASE_SIGNALS | (provides or frozenset())
    for key, spec in terms.items():
        get = functools.partial(_field, spec)
        term_name = get("term") or key
        where = f"reward preset '{name}', term '{key}'" if name else f"term '{key}'"
        try:
            term = resolve_term(term_name)
        except ConfigError as exc:
            raise ConfigError(f"{where}: {exc}") from None
        params = dict(get("params") or {})
        allowed = term_parameters(term)
        for param in params:
            if param not in allowed:
                valid = ", ".join(allowed) or "none"
                raise ConfigError(f"{where}: '{term_name}' has no parameter '{param}'; its parameters: {valid}")
            value = params[param]
            if param in term.nonnegative and (
                isinstance(value, bool) or not isinstance(value, (int, float)) or not value >= 0.0
            ):
                raise ConfigError(f"{where}: '{term_name}' parameter '{param}' must be a number >= 0, got {value!r}")
        when = get("when", "always")
        when = [when] if isinstance(when, str) else list(when)
        conditions = []
        for cond_name in when:
            try:
                cond, negate = resolve_condition(cond_name)
            except ConfigError as exc:
                raise ConfigError(f"{where}: {exc}") from None
            conditions.append((cond, negate, cond_name))
        if provides is not None:
            needs = [(term_name, s) for s in term.requires] + [(c[2], s) for c in conditions for s in c[0].requires]
            for what, signal in needs:
                if signal not in available:
                    raise ConfigError(
                        f"{where}: '{what}' needs the signal '{signal}', which task '{task_name}' does not provide "
                        f"(it provides: {', '.join(sorted(provides)) or 'none beyond the vehicle state'})"
                    )
        weight = float(get("weight", 1.0))
        entries.append(
            _Compiled(key, term.fn, params, weight, tuple((c.fn, n) for c, n, _ in conditions if c.fn is not always))
        )
    return RewardFunction(name, entries)
