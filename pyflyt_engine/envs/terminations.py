"""How an agent's step ends its episode: named, registered termination terms.

An env config declares the rules that end an episode under ``terminations`` -- entry name
-> ``{term: <registered name, default the entry's key>, params: {...}}``, or ``null`` to
switch a declared entry off -- as a reward preset declares its terms (the defaults, every
shipped env's, are in ``conf/env/_base.yaml``)::

    terminations:
      contact: {}                 # a contact is a crash (the task's crash_on_contact) ...
      out_of_dome: {}             # ... and so is leaving the flight dome
      task_failure: {}
      task_complete: {}
      payload_on_ground: {}       # only where the config has payloads
      obstacle_contact: {}        # only where it has obstacles
      time_limit: {}

Each registered term (:class:`TerminationTerm`) has a *kind*:

* ``crash`` -- the step ends the episode in failure: *terminated*, and the reward
  context's ``crashed`` (the ``crash`` condition) is True;
* ``end`` -- the step ends the episode without a crash (the task completed): *terminated*;
* ``truncate`` -- the episode is cut short: *truncated*, unless a ``crash`` or ``end``
  term terminated it on the same step.

and a ``bind(episode, **params)`` that returns the term's judge for one built episode (an
:class:`~pyflyt_engine.envs.episode.EpisodeCore`), or None where the rule cannot fire in
it (``payload_on_ground`` without payloads, ``contact`` where contacts are no crash): the
episode core loops over the judges of its declared terms, in declaration order, and has no
branch of its own for any of them.  A judge is called with the agent's
:class:`~pyflyt_engine.envs.step.AgentStep` and the dict its own info entries go into
(``payload_ground_contact``, ``obstacle_contact``...: a term's info entries come and go
with it); a :class:`Judge`'s :meth:`Judge.reset_info` gives those entries at a reset.

The episode's measurements -- ``info["collision"]``, ``info["out_of_bounds"]`` (the
flight-dome check, :func:`outside_dome`), the task's signals -- are taken whichever terms
are declared: a term decides only whether they end the episode.

Adding a term: write ``bind`` (a function of the episode and keyword parameters with
defaults, documented in its first docstring line) returning the judge -- a function of
the step and the info, or a :class:`Judge` for one with state and reset-info entries --
and register it with :func:`register_termination`; configs can then name it.  The batched backend
(:mod:`pyflyt_engine.batched.terms`) reads the same declaration and refuses, by name, a
term it does not implement.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

from pyflyt_engine.errors import ConfigError
from pyflyt_engine.state import KinematicState
from pyflyt_engine.suggest import did_you_mean

if TYPE_CHECKING:
    from pyflyt_engine.envs.step import AgentStep

Kind = Literal["crash", "end", "truncate"]
KINDS: tuple[Kind, ...] = ("crash", "end", "truncate")


def outside_dome(state: KinematicState, dome_squared: float) -> bool:
    """Whether the centre of mass is farther from the origin than the flight dome's radius."""
    x, y, z = state.lin_pos
    return x * x + y * y + z * z > dome_squared


#: a bound term: ``judge(step, info) -> bool``, whether the agent's step meets the rule (the
#: term's kind says what that does to the episode); it may put its own entries into ``info``
JudgeFn = Callable[["AgentStep", dict[str, Any]], bool]


class Judge:
    """A bound term with state and info entries of its own (a plain function of the step
    and the info is one too): ``judge(step, info) -> bool``, and :meth:`reset_info`."""

    __slots__ = ()

    def __call__(self, step: AgentStep, info: dict[str, Any]) -> bool:
        raise NotImplementedError

    def reset_info(self, i: int, info: dict[str, Any]) -> None:
        """Put the term's info entries of agent ``i`` at a reset into ``info`` (none by default)."""


@dataclass(frozen=True)
class TerminationTerm:
    """A registered termination term: its kind and how it binds to an episode."""

    bind: Callable[..., JudgeFn | None]
    kind: Kind

    @property
    def description(self) -> str:
        return (self.bind.__doc__ or "").strip().splitlines()[0]

    def parameters(self) -> dict[str, Any]:
        """The term's keyword parameters and their defaults."""
        return {p.name: p.default for p in list(inspect.signature(self.bind).parameters.values())[1:]}


# ------------------------------------------------------------------------ terms


def _contact(step: AgentStep, info: dict[str, Any]) -> bool:
    return step.collision


def _out_of_bounds(step: AgentStep, info: dict[str, Any]) -> bool:
    return step.out_of_bounds


def _failed(step: AgentStep, info: dict[str, Any]) -> bool:
    return step.signals.failed


def _complete(step: AgentStep, info: dict[str, Any]) -> bool:
    return step.signals.complete


def contact(episode: Any, crash_on_contact: bool | None = None) -> JudgeFn | None:
    """Any contact of the vehicle (ground included) is a crash; crash_on_contact: null the task's (a landing's is false)."""
    crashes = episode.tasks.crash_on_contact if crash_on_contact is None else bool(crash_on_contact)
    return _contact if crashes else None


def out_of_dome(episode: Any) -> JudgeFn | None:
    """Leaving the flight dome (|lin_pos| > flight_dome_size) is a crash."""
    return _out_of_bounds


def task_failure(episode: Any) -> JudgeFn | None:
    """A failure the task declares (its signals' failed: a fatal landing, a shot-down plane) is a crash."""
    return _failed


def task_complete(episode: Any) -> JudgeFn | None:
    """The task completed (its signals' complete: the last waypoint reached) ends the episode."""
    return _complete


def time_limit(episode: Any) -> JudgeFn | None:
    """Truncate after max_duration_seconds of simulated time (max_steps agent steps)."""
    max_steps = episode.config.max_steps

    def judge(step: AgentStep, info: dict[str, Any]) -> bool:
        return step.steps >= max_steps

    return judge


class _PayloadOnGround(Judge):
    __slots__ = ("payloads",)

    def __init__(self, payloads: list[Any]) -> None:
        self.payloads = payloads

    def __call__(self, step: AgentStep, info: dict[str, Any]) -> bool:
        failed = self.payloads[step.index].ground_failure()
        info["payload_ground_contact"] = failed
        return failed

    def reset_info(self, i: int, info: dict[str, Any]) -> None:
        info["payload_ground_contact"] = False


def payload_on_ground(episode: Any) -> JudgeFn | None:
    """A payload that declares ground_contact_fails touching the ground is a crash (info payload_ground_contact)."""
    return _PayloadOnGround(episode.agent_payloads) if episode.agent_payloads else None


class _ObstacleContact(Judge):
    __slots__ = ("obstacles", "crashes")

    def __init__(self, obstacles: Any, crashes: bool) -> None:
        self.obstacles = obstacles
        self.crashes = crashes

    def __call__(self, step: AgentStep, info: dict[str, Any]) -> bool:
        touched = self.obstacles.touched(step.index)
        info["obstacle_contact"] = touched
        info["obstacles_parked"] = self.obstacles.parked
        return touched and self.crashes

    def reset_info(self, i: int, info: dict[str, Any]) -> None:
        info["obstacle_contact"] = False
        info["obstacles_parked"] = self.obstacles.parked


def obstacle_contact(episode: Any) -> JudgeFn | None:
    """Touching an obstacle is a crash when obstacles.crash_on_contact (info obstacle_contact, obstacles_parked)."""
    obstacles = episode.obstacles
    if obstacles is None:
        return None
    return _ObstacleContact(obstacles, bool(episode.config.obstacles.crash_on_contact))


#: Every termination term an env config may name: the generic ones here, and those a task
#: registers from its own module (:func:`register_termination`).
TERMINATIONS: dict[str, TerminationTerm] = {
    "contact": TerminationTerm(contact, "crash"),
    "out_of_dome": TerminationTerm(out_of_dome, "crash"),
    "task_failure": TerminationTerm(task_failure, "crash"),
    "task_complete": TerminationTerm(task_complete, "end"),
    "payload_on_ground": TerminationTerm(payload_on_ground, "crash"),
    "obstacle_contact": TerminationTerm(obstacle_contact, "crash"),
    "time_limit": TerminationTerm(time_limit, "truncate"),
}

#: the declaration of every shipped env (``conf/env/_base.yaml``; an env config's default)
DEFAULT_TERMINATIONS: dict[str, dict[str, Any]] = {name: {} for name in TERMINATIONS}


def register_termination(name: str, term: TerminationTerm) -> None:
    """Make ``term`` available to env configs as ``name``."""
    if term.kind not in KINDS:
        raise ValueError(f"termination term '{name}': kind must be one of {', '.join(KINDS)}, got {term.kind!r}")
    if name in TERMINATIONS and TERMINATIONS[name] != term:
        raise ValueError(f"termination term '{name}' is registered already, by another function")
    TERMINATIONS[name] = term


def resolve_termination(name: str) -> TerminationTerm:
    """The registered term ``name``. Raises ConfigError listing the valid ones."""
    try:
        return TERMINATIONS[name]
    except KeyError:
        valid = list(TERMINATIONS)
        raise ConfigError(
            f"unknown termination term '{name}'.{did_you_mean(str(name), valid)} Valid: {', '.join(valid)}"
        ) from None


def _field(spec: Any, name: str) -> Any:
    return spec.get(name) if isinstance(spec, Mapping) else getattr(spec, name, None)


def declared(terminations: Mapping[str, Any]) -> list[tuple[str, TerminationTerm, dict[str, Any]]]:
    """The entries of a ``terminations`` declaration that are on, in order: ``(key, term,
    params)``, names and parameters checked (entries given as None are off).

    Raises:
        ConfigError: an unknown term or parameter, naming the entry and the valid ones.
    """
    out = []
    for key, spec in terminations.items():
        if spec is None:
            continue
        name = _field(spec, "term") or key
        try:
            term = resolve_termination(name)
        except ConfigError as exc:
            raise ConfigError(f"terminations.{key}: {exc}") from None
        params = dict(_field(spec, "params") or {})
        allowed = term.parameters()
        for param in params:
            if param not in allowed:
                valid = ", ".join(allowed) or "none"
                raise ConfigError(f"terminations.{key}: '{name}' has no parameter '{param}'; its parameters: {valid}")
        out.append((key, term, params))
    return out


@dataclass(frozen=True)
class Terminations:
    """A declaration bound to one episode: the judges of its terms that can fire, by kind
    (each in declaration order), and the reset-info hooks of those that report entries."""

    crash: tuple[JudgeFn, ...]
    end: tuple[JudgeFn, ...]
    truncate: tuple[JudgeFn, ...]
    reset_infos: tuple[Callable[[int, dict[str, Any]], None], ...] = ()

    def reset_info(self, i: int, info: dict[str, Any]) -> None:
        """Agent ``i``'s entries of the terms at a reset, into ``info``."""
        for hook in self.reset_infos:
            hook(i, info)


def bind_terminations(terminations: Mapping[str, Any], episode: Any) -> Terminations:
    """The declared terms bound to ``episode`` (what they read of it: ``tasks``, ``config``,
    ``agent_payloads``, ``obstacles``); terms that cannot fire in it are left out."""
    task = getattr(episode.tasks, "task", episode.tasks)  # a single-agent task through OneAgentTask
    if callable(getattr(task, "termination", None)):
        raise ConfigError(
            f"task '{task.name}' defines termination(), which the episode does not ask: how a step ends an episode "
            "is the env config's termination terms; register the task's rule with "
            "pyflyt_engine.envs.terminations.register_termination and name it under terminations (or switch the "
            "default ones off with null, e.g. terminations: {out_of_dome: null})"
        )
    by_kind: dict[str, list[JudgeFn]] = {kind: [] for kind in KINDS}
    for key, term, params in declared(terminations):
        try:
            judge = term.bind(episode, **params)
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"terminations.{key}: {exc}") from None
        if judge is not None:
            by_kind[term.kind].append(judge)
    judges = [*by_kind["crash"], *by_kind["end"], *by_kind["truncate"]]
    hooks = tuple(judge.reset_info for judge in judges if isinstance(judge, Judge))
    return Terminations(tuple(by_kind["crash"]), tuple(by_kind["end"]), tuple(by_kind["truncate"]), hooks)
