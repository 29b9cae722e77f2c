"""How an actuator group turns the vehicle's control outputs into its commands.

At every control tick the vehicle has a channel vector (the spec's ``channels``, in
order) and, for a multirotor, the mixer's outputs (one throttle per mixer motor, then
one servo command per gimbal the mixer flies).  Each group routes them to its own
actuators with the tables it was built with (:meth:`Motors.route`, :meth:`Surfaces.route`,
:meth:`Boosters.route`, :meth:`Gimbals.route`):

* an actuator the mixer flies takes its output (0 when there is none this tick: disarmed,
  or a mode that bypasses the mixer);
* any other takes the weighted sum of the channels its ``mix`` names (:func:`mixed`);

then each command is limited to its actuator's range.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: One actuator's ``mix``: (channel index, weight) pairs with a non-zero weight.
MixRow = tuple[tuple[int, float], ...]


def mix_rows(matrix: np.ndarray) -> list[MixRow]:
    """Per row of a (actuators x channels) mix matrix, its non-zero (channel index, weight) pairs."""
    return [tuple((j, w) for j, w in enumerate(row) if w != 0.0) for row in np.asarray(matrix).tolist()]


def mixed(channels: Sequence[float], row: MixRow) -> float:
    """The weighted sum of ``channels`` a mix row names (0 for an empty row)."""
    value = 0.0
    for j, w in row:
        value += w * channels[j]
    return value


def clamp(value: float, low: float, high: float) -> float:
    """``value`` limited to [low, high]."""
    return high if value > high else low if value < low else value
