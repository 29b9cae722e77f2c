"""What a run's parts cost, on the run's own clock.

:class:`CostLedger`: the start-up, ``learn()``, each checkpoint (and the replay buffer's share
of it) and each evaluation; a run's :class:`~pyflyt_cli.training.loop.RunResult` carries it
(``costs``), so a study measures a run's phases on the clock it chooses
(``train(..., clock=time.process_time)``: this process's CPU seconds) instead of timing the
loop's internals from outside.  The phase split (collect / update / eval / checkpoint) is
:class:`~pyflyt_cli.training.timing.PhaseClock`'s, on the same clock.  Imports nothing of
the learning library (the loop imports it at module level).
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass

Clock = Callable[[], float]


@dataclass(frozen=True)
class CheckpointCost:
    """One checkpoint's seconds, the replay buffer's share of them, and the transitions it wrote."""

    seconds: float
    buffer_seconds: float
    transitions: int


class CostLedger:
    """Seconds a run's parts took on ``clock``, from the ledger's creation (the call to
    :func:`~pyflyt_cli.training.loop.train` or ``resume``) on.

    ``startup``: from its creation to ``learn()``'s start (building the model and envs, the
    cost measurement, an imitation stage); ``learn``: ``learn()`` itself; ``checkpoints``: one
    :class:`CheckpointCost` per checkpoint saved (the final one included); ``evaluations``: the
    seconds of each evaluation (the final weights' included); ``split``: the
    :class:`PhaseClock`'s seconds per phase at the end.
    """

    def __init__(self, clock: Clock = time.perf_counter) -> None:
        self.clock = clock
        self.created = clock()
        self.learn_started: float | None = None
        self.learn_ended: float | None = None
        self.checkpoints: list[CheckpointCost] = []
        self.evaluations: list[float] = []
        self.split: dict[str, float] = {}

    @property
    def startup(self) -> float:
        return (self.learn_started if self.learn_started is not None else self.clock()) - self.created

    @property
    def learn(self) -> float:
        if self.learn_started is None:
            return 0.0
        return (self.learn_ended if self.learn_ended is not None else self.clock()) - self.learn_started

    @contextlib.contextmanager
    def timed(self, into: list[float]) -> Iterator[None]:
        """Append the seconds the block takes (on this ledger's clock) to ``into``, however it ends."""
        started = self.clock()
        try:
            yield
        finally:
            into.append(self.clock() - started)
