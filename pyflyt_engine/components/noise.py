"""Zero-mean actuator noise, drawn in blocks from a vehicle's seeded generator.

Motors and boosters perturb their state by ``(1 + sigma * eta)`` with ``eta ~ N(0, 1)``
drawn independently per actuator and per physics step (the reference package drew one
shared N(4, 1) scalar instead: a biased, correlated "noise").  Drawing one row per
physics step from NumPy would cost more than the step itself, so rows are drawn in
blocks: the first block after a reset is :data:`FIRST_BLOCK` rows and each next one
twice as many, up to :data:`BLOCK`.  A ``Generator``'s normals come out the same however
the stream is cut into blocks, so the schedule changes the cost of a refill, not the
noise; a reset discards the rest of a block (where the next unseeded episode starts in
the stream does depend on it).  The short first blocks keep a reset from paying for
1 024 rows that a short episode (a crashing QuadX: ~100 physics steps) never uses.

All the stochastic actuator groups of one vehicle draw from one :class:`NoiseSource`,
in the order they step, so a vehicle with noisy motors and noisy boosters interleaves
their blocks.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np

#: Largest block of rows drawn at once (per actuator group).
BLOCK = 1024
#: Rows drawn by the first refill after a reset or reseed.
FIRST_BLOCK = 16


class NoiseSource:
    """A vehicle's noise generator, shared by its actuator groups (replaced on a reseed)."""

    def __init__(self, rng: np.random.Generator) -> None:
        self.rng = rng


class NoiseBlocks:
    """Rows of ``width`` noise values, one per physics step, drawn from a :class:`NoiseSource` in blocks.

    Args:
        source: the vehicle's generator.
        width: values per row (one per actuator).
        transform: maps a (rows, width) block of standard normals to the values handed
            out (e.g. the motors' factors ``1 + sigma * eta``); None: the normals.

    Rows are built from the block's columns on demand (``zip``): a block is a few lists,
    not one container per row, so it never reaches the garbage collector's oldest
    generation (thousands of long-lived rows would trigger full collections).
    """

    def __init__(
        self, source: NoiseSource, width: int, transform: Callable[[np.ndarray], np.ndarray] | None = None
    ) -> None:
        self.source = source
        self.width = width
        self.transform = transform
        self._rows: Iterator[tuple[float, ...]] = iter(())
        self._block = FIRST_BLOCK

    def next(self) -> tuple[float, ...]:
        """The next row."""
        return next(self._rows, None) or self._refill()

    def _refill(self) -> tuple[float, ...]:
        rows, self._block = self._block, min(2 * self._block, BLOCK)
        block = self.source.rng.standard_normal((rows, self.width))
        if self.transform is not None:
            block = self.transform(block)
        self._rows = it = zip(*block.T.tolist())
        return next(it)

    def discard(self) -> None:
        """Drop the rest of the block; the next refill starts small again (on a reset or reseed)."""
        self._rows = iter(())
        self._block = FIRST_BLOCK
