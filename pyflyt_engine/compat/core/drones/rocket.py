"""The reference's ``core.drones.rocket`` module path: ``Rocket``, the ``drone_type="rocket"`` of an Aviary."""

from pyflyt_engine.compat.core.abstractions import DroneClass

# the names the reference's module holds through its own imports, for code that takes them from here
from pyflyt_engine.compat.core.abstractions import (
    Boosters,
    BoringBodies,
    Camera,
    Gimbals,
    LiftingSurface,
    LiftingSurfaces,
)

__all__ = ["Boosters", "BoringBodies", "Camera", "Gimbals", "LiftingSurface", "LiftingSurfaces", "Rocket"]


class Rocket(DroneClass):
    """PyFlyt 0.29.0 ``Rocket``: fly it with ``Aviary(drone_type="rocket")`` (the shipped
    airframe); built directly it is refused."""
