"""Named flight modes for multirotors.

Every mode has a name and a setpoint layout.  The paper lists seven setpoint
definitions; the reference PyFlyt package numbers its modes -1 ... 7, and those integers
are accepted as aliases of the same modes with the same four-value layouts
``[horizontal 1, horizontal 2, yaw-ish, vertical]``.

| name | PyFlyt id | setpoint | frames / units |
|---|---|---|---|
| motors | -1 | one throttle per motor | normalised [-1, 1] |
| rates_thrust | 0 | p, q, r, thrust | body rates [rad/s], thrust normalised [0, 1] |
| attitude_vz | 1 | roll, pitch, yaw, vz | ground Euler angles [rad], climb rate [m/s] |
| rates_z | 2 | p, q, r, z | body rates [rad/s], altitude [m] |
| attitude_z | 3 | roll, pitch, yaw, z | [rad], [m] |
| heading_velocity_z | 4 | u, v, yaw rate, z | heading-frame velocity [m/s], [rad/s], [m] |
| heading_velocity_vz | 5 | u, v, yaw rate, vz | [m/s], [rad/s], [m/s] |
| velocity_yawrate | 6 | vx, vy, yaw rate, vz | ground velocity [m/s], [rad/s] |
| position_yaw | 7 | x, y, yaw, z | ground position [m], yaw [rad] |
| velocity_yaw | - | vx, vy, yaw, vz | ground velocity [m/s], yaw [rad] |
| position_yawrate | - | x, y, yaw rate, z | ground position [m], [rad/s] |

The heading frame is the body frame with roll and pitch removed (u forward, v left, both
horizontal), which is what PyFlyt calls "local" velocity.
"""

from __future__ import annotations

from dataclasses import dataclass

from pyflyt_engine.errors import ConfigError
from pyflyt_engine.suggest import did_you_mean


@dataclass(frozen=True)
class FlightMode:
    """A flight mode: its name, PyFlyt alias and setpoint layout."""

    name: str
    pyflyt_id: int | None
    setpoint: tuple[str, ...]
    description: str


MULTIROTOR_MODES: dict[str, FlightMode] = {
    m.name: m
    for m in (
        FlightMode("motors", -1, ("motors",), "raw motor throttles"),
        FlightMode("rates_thrust", 0, ("p", "q", "r", "thrust"), "body rates + normalised thrust"),
        FlightMode("attitude_vz", 1, ("roll", "pitch", "yaw", "vz"), "attitude + climb rate"),
        FlightMode("rates_z", 2, ("p", "q", "r", "z"), "body rates + altitude"),
        FlightMode("attitude_z", 3, ("roll", "pitch", "yaw", "z"), "attitude + altitude"),
        FlightMode(
            "heading_velocity_z", 4, ("u", "v", "yaw_rate", "z"), "heading-frame velocity + yaw rate + altitude"
        ),
        FlightMode(
            "heading_velocity_vz", 5, ("u", "v", "yaw_rate", "vz"), "heading-frame velocity + yaw rate + climb rate"
        ),
        FlightMode("velocity_yawrate", 6, ("vx", "vy", "yaw_rate", "vz"), "ground velocity + yaw rate"),
        FlightMode("position_yaw", 7, ("x", "y", "yaw", "z"), "position + yaw angle"),
        FlightMode("velocity_yaw", None, ("vx", "vy", "yaw", "vz"), "ground velocity + yaw angle"),
        FlightMode("position_yawrate", None, ("x", "y", "yaw_rate", "z"), "position + yaw rate"),
    )
}

#: Short names users reach for.
MODE_ALIASES = {"position": "position_yaw", "velocity": "velocity_yawrate", "rates": "rates_thrust"}

_BY_ID = {m.pyflyt_id: m for m in MULTIROTOR_MODES.values() if m.pyflyt_id is not None}


def resolve_mode(mode: str | int, extra: dict[str, FlightMode] | None = None) -> FlightMode:
    """The :class:`FlightMode` for a name, an alias or a PyFlyt integer.

    Args:
        mode: e.g. ``"position_yaw"``, ``"position"``, ``7`` or ``"7"``.
        extra: further modes (user-registered controllers) to accept.

    Raises:
        ConfigError: unknown mode, naming the valid ones.
    """
    table = {**MULTIROTOR_MODES, **(extra or {})}
    if isinstance(mode, str) and mode.lstrip("-").isdigit():
        mode = int(mode)
    if isinstance(mode, int) and not isinstance(mode, bool):
        if mode in _BY_ID:
            return _BY_ID[mode]
        raise ConfigError(f"unknown flight mode {mode}: PyFlyt mode numbers are -1 to 7")
    name = MODE_ALIASES.get(str(mode), str(mode))
    if name in table:
        return table[name]
    hint = did_you_mean(str(mode), list(table) + list(MODE_ALIASES))
    raise ConfigError(f"unknown flight mode '{mode}'.{hint} Available: {', '.join(table)} (or -1 ... 7)")
