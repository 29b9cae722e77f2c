"""The task registry: every task, single- or multi-agent, under its name (``task.name`` of an env YAML).

One :class:`TaskEntry` per task: its kind (``single``: a
:class:`~pyflyt_engine.envs.tasks.base.Task` run by :class:`~pyflyt_engine.envs.env.UAVEnv`;
``multi``: a :class:`~pyflyt_engine.envs.tasks.multi.MultiAgentTask` run by a multi-agent
env), its task class, its options model (the class's ``Options``), the scripted
controllers that fly it (its oracles, :mod:`pyflyt_engine.envs.oracles`) and, for a
multi-agent task, the env class that runs it.  A task's own module registers it, after
its options, reward terms and oracles, with one call::

    register_task(LandingTask, oracles=(RocketLander, RocketVelocityLander, RocketDescentLander))

:mod:`pyflyt_engine.envs.tasks` imports every shipped task module, so importing it (as
loading any env config does) fills the registry; configs name tasks, they never import code.
The older name tables are views of this one: ``TASKS`` (:mod:`pyflyt_engine.envs.tasks`),
``MA_TASKS`` (:mod:`pyflyt_engine.envs.config`), ``MA_TASK_CLASSES``
(:mod:`pyflyt_engine.envs.tasks.multi`), ``TASK_CLASSES`` (:mod:`pyflyt_engine.envs.multi_agent`)
and ``ORACLES`` (:mod:`pyflyt_engine.envs.oracles`).

This module imports no task (a task class says its kind in ``task_kind``), so every task
module can import it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, MutableMapping
from dataclasses import dataclass
from typing import Any, Generic, Literal, Protocol, TypeVar, cast, overload

from pyflyt_engine.errors import ConfigError
from pyflyt_engine.suggest import did_you_mean

Kind = Literal["single", "multi"]

#: how a kind is named in messages
KIND_WORDS: dict[str, str] = {"single": "task", "multi": "multi-agent task"}

T = TypeVar("T", bound=type)
V = TypeVar("V")


class Oracle(Protocol):
    """An oracle class (:mod:`pyflyt_engine.envs.oracles`): its name, the env ids it flies,
    built on the env, then called on observations."""

    name: str
    env_ids: tuple[str, ...]

    def __init__(self, env: Any) -> None: ...

    def __call__(self, obs: Any) -> Any: ...


@dataclass(frozen=True)
class TaskEntry:
    """A registered task."""

    name: str
    """the registry key: ``task.name`` of an env config"""
    kind: Kind
    """``single`` (a Task, one vehicle) or ``multi`` (a MultiAgentTask, N agents in one world)"""
    task: type
    """the task class"""
    options: type
    """the pydantic model of the task's options (``task:`` of the env YAML): the class's ``Options``"""
    oracles: tuple[type[Oracle], ...] = ()
    """the scripted controllers that fly this task, each with its ``name`` and ``env_ids``"""
    env: str | None = None
    """the env class that runs the task, as ``module:Class`` (multi-agent tasks; imported on demand)"""


#: task name -> entry, in registration order; filled by :func:`register_task`
REGISTRY: dict[str, TaskEntry] = {}


def _kind(task: Any) -> Kind:
    """The kind of a task class: its ``task_kind``, which the two bases set (``single`` on
    :class:`~pyflyt_engine.envs.tasks.base.Task`, ``multi`` on
    :class:`~pyflyt_engine.envs.tasks.multi.MultiAgentTask`). Raises TypeError for anything else."""
    kind = getattr(task, "task_kind", None) if isinstance(task, type) else None
    if kind not in KIND_WORDS or not isinstance(getattr(task, "Options", None), type):
        raise TypeError(f"register_task needs a Task or MultiAgentTask subclass, got {task!r}")
    return cast(Kind, kind)


def _check_oracle(oracle: Any, task_name: str) -> None:
    name = getattr(oracle, "name", None)
    if not (isinstance(oracle, type) and isinstance(name, str) and name):
        raise TypeError(f"task '{task_name}': an oracle must be a class with a 'name', got {oracle!r}")
    env_ids = getattr(oracle, "env_ids", None)
    if not (isinstance(env_ids, tuple) and env_ids):
        raise TypeError(f"oracle '{name}' (task '{task_name}') must name the env ids it flies in 'env_ids'")
    owner = next((e.name for e in REGISTRY.values() for o in e.oracles if o.name == name), task_name)
    if owner != task_name:
        raise ValueError(f"oracle '{name}' is registered already, for task '{owner}': give it another name")


@overload
def register_task(
    task: T, *, oracles: tuple[type[Oracle], ...] = (), env: str | None = None, name: str | None = None
) -> T: ...


@overload
def register_task(
    task: None = None, *, oracles: tuple[type[Oracle], ...] = (), env: str | None = None, name: str | None = None
) -> Callable[[T], T]: ...


def register_task(
    task: Any = None, *, oracles: tuple[type[Oracle], ...] = (), env: str | None = None, name: str | None = None
) -> Any:
    """Register ``task`` (a Task or MultiAgentTask subclass) under ``task.name``; returns it.

    A call (``register_task(HoverTask)``) or a decorator (``@register_task``,
    ``@register_task(env="...")``).  Registering a name again replaces its entry (a task
    redefined), unless the name belongs to a task of the other kind.

    Args:
        oracles: the oracle classes that fly this task (:mod:`pyflyt_engine.envs.oracles`).
        env: the env class running a multi-agent task, as ``module:Class``.
        name: register under this name instead of ``task.name``.

    Raises:
        TypeError: ``task`` is no task class, or an oracle has no ``name`` or ``env_ids``.
        ValueError: the name is a task of the other kind already, or an oracle's name is
            another task's.
    """
    if task is None:
        return lambda cls: register_task(cls, oracles=oracles, env=env, name=name)
    kind = _kind(task)
    key = task.name if name is None else name
    if not isinstance(key, str) or not key:
        raise TypeError(f"register_task: {task!r} needs a non-empty 'name'")
    old = REGISTRY.get(key)
    if old is not None and old.kind != kind:
        raise ValueError(
            f"'{key}' is registered already as a {KIND_WORDS[old.kind]} ({old.task.__qualname__}): "
            f"give the {KIND_WORDS[kind]} {task.__qualname__} another name"
        )
    for oracle in oracles:
        _check_oracle(oracle, key)
    REGISTRY[key] = TaskEntry(key, kind, task, task.Options, tuple(oracles), env)
    return task


def unregister_task(name: str) -> TaskEntry:
    """Remove task ``name`` (and its oracles) from the registry; returns its entry.

    Raises:
        KeyError: no task of that name.
    """
    return REGISTRY.pop(name)


def names(kind: Kind | None = None) -> list[str]:
    """The registered task names of ``kind`` (every kind: None), in registration order."""
    return [n for n, e in REGISTRY.items() if kind is None or e.kind == kind]


def task_entry(name: str, kind: Kind | None = None) -> TaskEntry:
    """The entry of task ``name`` (of ``kind``, if given).

    Raises:
        ConfigError: no such task; the message names the valid ones (with a did-you-mean
            hint) and says when ``name`` is a task of the other kind.
    """
    entry = REGISTRY.get(name) if isinstance(name, str) else None
    if entry is not None and (kind is None or entry.kind == kind):
        return entry
    valid = names(kind)
    word = KIND_WORDS[kind] if kind is not None else "task"
    hint = did_you_mean(str(name), valid)
    other = f" ('{name}' is a {KIND_WORDS[entry.kind]})" if entry is not None else ""
    raise ConfigError(f"unknown {word} '{name}'.{hint} Valid: {', '.join(valid)}{other}")


class TaskTable(MutableMapping[str, V], Generic[V]):
    """A live view of the registry: the names of one kind -> one field of their entries.

    ``del table[name]`` unregisters the task; ``table[name] = cls`` registers a task class
    (only for a view of the ``task`` field).  Iterates in registration order.
    """

    def __init__(self, kind: Kind, field: str) -> None:
        self.kind = kind
        self.field = field

    def _entry(self, name: str) -> TaskEntry:
        entry = REGISTRY.get(name)
        if entry is None or entry.kind != self.kind:
            raise KeyError(name)
        return entry

    def __getitem__(self, name: str) -> V:
        return getattr(self._entry(name), self.field)

    def __setitem__(self, name: str, value: V) -> None:
        if self.field != "task":
            raise TypeError(
                f"register the task itself (pyflyt_engine.envs.task_registry.register_task), not its {self.field}"
            )
        if _kind(value) != self.kind:
            raise TypeError(f"this table holds {KIND_WORDS[self.kind]}s, not {value!r}")
        register_task(cast(type, value), name=name)

    def __delitem__(self, name: str) -> None:
        self._entry(name)
        unregister_task(name)

    def __iter__(self) -> Iterator[str]:
        return iter(names(self.kind))

    def __len__(self) -> int:
        return len(names(self.kind))

    def __contains__(self, name: object) -> bool:
        entry = REGISTRY.get(name) if isinstance(name, str) else None
        return entry is not None and entry.kind == self.kind

    def __repr__(self) -> str:
        return repr(dict(self.items()))


class OracleTable(Mapping[str, type[Oracle]]):
    """A live view of the registry: oracle name -> oracle class, over every task's oracles."""

    def _all(self) -> dict[str, type[Oracle]]:
        return {o.name: o for e in REGISTRY.values() for o in e.oracles}

    def __getitem__(self, name: str) -> type[Oracle]:
        return self._all()[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._all())

    def __len__(self) -> int:
        return len(self._all())

    def __repr__(self) -> str:
        return repr(self._all())


def oracle_task(name: str) -> TaskEntry:
    """The entry of the task whose oracles include ``name``.

    Raises:
        KeyError: no oracle of that name.
    """
    for entry in REGISTRY.values():
        if any(o.name == name for o in entry.oracles):
            return entry
    raise KeyError(name)


__all__ = [
    "KIND_WORDS",
    "REGISTRY",
    "Kind",
    "Oracle",
    "OracleTable",
    "TaskEntry",
    "TaskTable",
    "names",
    "oracle_task",
    "register_task",
    "task_entry",
    "unregister_task",
]
