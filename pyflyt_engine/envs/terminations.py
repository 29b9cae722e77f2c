"""How an agent's step ends its episode: the flight-dome check."""

from __future__ import annotations

from pyflyt_engine.state import KinematicState


def outside_dome(state: KinematicState, dome_squared: float) -> bool:
    """Whether the centre of mass is farther from the origin than the flight dome's radius."""
    x, y, z = state.lin_pos
    return x * x + y * y + z * z > dome_squared
