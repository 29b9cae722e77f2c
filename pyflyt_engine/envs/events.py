"""What happens at a reset besides the World's reset, the spawns and the task's start: the
registered reset events, each bound from the env config's section that declares it.

:func:`~pyflyt_engine.envs.build.reset_episode` runs one order for one agent or N::

    World.reset(seed)
    event.draw(rng)                    every event, in registry order (domain randomisation)
    per vehicle, in agent order:
        spawn(i)                       the front's (the task's spawn or the layout's)
        event.spawn(i, pose) -> pose   every event (the randomised spawn offsets)
        vehicle.reset(pose)
    event.placed()                     every event (payloads placed on their parents)
    start_task(states) -> keep_clear   the front's
    event.started(rng, states, keep_clear)   every event (obstacle layouts, clear of the spawns and the goals)

and :meth:`~pyflyt_engine.envs.episode.EpisodeCore._reset_info` asks every event for its
info entries (``randomization``).  An event binds to the built episode's parts
(:class:`~pyflyt_engine.envs.build.EpisodeParts`) or is None where its section is absent,
so the reset has no branch of its own per feature.

* ``randomize`` -- ``config.randomize``: the per-episode draws, applied to every vehicle and
  the world, the spawn offsets, ``info["randomization"]``;
* ``place_payloads`` -- ``config.payloads``: each agent's payloads placed on their parents;
* ``obstacle_layouts`` -- ``config.obstacles``: this episode's seeded layouts.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, ClassVar

import numpy as np

from pyflyt_engine.envs.randomization import Randomizer
from pyflyt_engine.state import KinematicState


class ResetEvent:
    """One reset event bound to one episode; every hook does nothing by default."""

    __slots__ = ()
    #: the event's key in :data:`RESET_EVENTS`
    name: ClassVar[str] = ""

    def draw(self, rng: np.random.Generator) -> None:
        """Before the spawns: draw this episode's values from ``rng``."""

    def spawn(self, i: int, position: Any, orientation: Any) -> tuple[Any, Any]:
        """Vehicle ``i``'s spawn pose, as the event moves it."""
        return position, orientation

    def placed(self) -> None:
        """After every vehicle is placed."""

    def started(self, rng: np.random.Generator, states: Sequence[KinematicState], keep_clear: Any) -> None:
        """After the task started on the vehicles' ``states``; ``keep_clear``: the points
        (ground frame, reshaped to (n, 3)) the task's goals need kept clear besides the vehicles."""

    @property
    def drawn(self) -> dict[str, float] | None:
        """The values drawn at the last reset (None: the event draws none)."""
        return None

    def reset_info(self, info: dict[str, Any]) -> None:
        """Put the event's entries of a reset's info into ``info``."""


class _Randomize(ResetEvent):
    __slots__ = ("randomizer", "values")
    name = "randomize"

    def __init__(self, randomizer: Randomizer) -> None:
        self.randomizer = randomizer
        self.values: dict[str, float] = {}

    def draw(self, rng: np.random.Generator) -> None:
        self.values = self.randomizer.sample(rng)

    def spawn(self, i: int, position: Any, orientation: Any) -> tuple[Any, Any]:
        return Randomizer.spawn(self.values, position, orientation)

    @property
    def drawn(self) -> dict[str, float] | None:
        return self.values

    def reset_info(self, info: dict[str, Any]) -> None:
        info["randomization"] = dict(self.values)


def randomize(parts: Any) -> ResetEvent | None:
    """Domain randomisation (config.randomize): drawn before the spawns, the spawn offsets, info randomization."""
    return _Randomize(parts.randomizer) if parts.randomizer is not None else None


class _PlacePayloads(ResetEvent):
    __slots__ = ("payloads",)
    name = "place_payloads"

    def __init__(self, payloads: list[Any]) -> None:
        self.payloads = payloads

    def placed(self) -> None:
        for payloads in self.payloads:
            payloads.place()


def place_payloads(parts: Any) -> ResetEvent | None:
    """Each agent's payloads (config.payloads) placed on their parents, once every vehicle is."""
    return _PlacePayloads(parts.payloads) if parts.payloads else None


class _ObstacleLayouts(ResetEvent):
    __slots__ = ("obstacles",)
    name = "obstacle_layouts"

    def __init__(self, obstacles: Any) -> None:
        self.obstacles = obstacles

    def started(self, rng: np.random.Generator, states: Sequence[KinematicState], keep_clear: Any) -> None:
        self.obstacles.generate(rng, [*(state.lin_pos for state in states), *np.asarray(keep_clear).reshape(-1, 3)])


def obstacle_layouts(parts: Any) -> ResetEvent | None:
    """This episode's obstacle layouts (config.obstacles), drawn clear of every spawn point and the task's goals."""
    return _ObstacleLayouts(parts.obstacles) if parts.obstacles is not None else None


#: Every reset event, in the order its hooks run.
RESET_EVENTS: dict[str, Callable[[Any], ResetEvent | None]] = {
    "randomize": randomize,
    "place_payloads": place_payloads,
    "obstacle_layouts": obstacle_layouts,
}


def bind_events(parts: Any) -> tuple[ResetEvent, ...]:
    """The reset events that apply to ``parts`` (what :func:`~pyflyt_engine.envs.build.build_episode` built)."""
    bound = (bind(parts) for bind in RESET_EVENTS.values())
    return tuple(event for event in bound if event is not None)
