"""The reference PyFlyt's Gymnasium ids, registered on import (``import PyFlyt.gym_envs``'s counterpart).

    import gymnasium
    import pyflyt_engine.compat.gym_envs  # noqa: F401
    env = gymnasium.make("PyFlyt/QuadX-Hover-v4")

Each id has the reference's arguments, defaults, spaces and episodes (its rewards and
endings) over a world built from a native env config (:mod:`.envs`); the reference's
module tree is mirrored (``quadx_envs``, ``fixedwing_envs``, ``rocket_envs``, ``utils``,
with the base envs users subclass); ``docs/migrating_from_pyflyt.md`` lists what still
differs.
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

from pyflyt_engine.compat.gym_envs.flatten import FlattenWaypointEnv

_MODULE = "pyflyt_engine.compat.gym_envs.envs"

#: reference id -> class in :mod:`.envs`: the ids PyFlyt 0.29.0 gym_envs/__init__.py registers.
#: Not Fixedwing-Waypoints-v4 (later releases' id of the same env): with it registered,
#: Gymnasium warns at every ``make`` of -v3 that it is out of date, and the reference does not.
REFERENCE_IDS: dict[str, str] = {
    "PyFlyt/QuadX-Hover-v4": "QuadXHoverEnv",
    "PyFlyt/QuadX-Waypoints-v4": "QuadXWaypointsEnv",
    "PyFlyt/QuadX-Gates-v3": "QuadXGatesEnv",
    "PyFlyt/QuadX-Pole-Balance-v4": "QuadXPoleBalanceEnv",
    "PyFlyt/QuadX-Pole-Waypoints-v4": "QuadXPoleWaypointsEnv",
    "PyFlyt/QuadX-Ball-In-Cup-v4": "QuadXBallInCupEnv",
    "PyFlyt/Fixedwing-Waypoints-v3": "FixedwingWaypointsEnv",
    "PyFlyt/Rocket-Landing-v4": "RocketLandingEnv",
}

for _id, _cls in REFERENCE_IDS.items():
    if _id not in registry:
        register(id=_id, entry_point=f"{_MODULE}:{_cls}")

__all__ = ["REFERENCE_IDS", "FlattenWaypointEnv"]
