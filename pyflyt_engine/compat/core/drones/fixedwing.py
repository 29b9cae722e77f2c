"""The reference's ``core.drones.fixedwing`` module path: ``Fixedwing``, the ``drone_type="fixedwing"`` of an Aviary."""

from pyflyt_engine.compat.core.abstractions import DroneClass

# the names the reference's module holds through its own imports, for code that takes them from here
from pyflyt_engine.compat.core.abstractions import Camera, LiftingSurface, LiftingSurfaces, Motors

__all__ = ["Camera", "Fixedwing", "LiftingSurface", "LiftingSurfaces", "Motors"]


class Fixedwing(DroneClass):
    """PyFlyt 0.29.0 ``Fixedwing``: fly it with ``Aviary(drone_type="fixedwing")`` (the shipped
    airframe); built directly it is refused."""
