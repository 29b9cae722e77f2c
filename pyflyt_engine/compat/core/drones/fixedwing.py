"""The reference's ``core.drones.fixedwing`` module path: ``Fixedwing``, the ``drone_type="fixedwing"`` of an Aviary."""

from pyflyt_engine.compat.core.abstractions import DroneClass

__all__ = ["Fixedwing"]


class Fixedwing(DroneClass):
    """PyFlyt 0.29.0 ``Fixedwing``: fly it with ``Aviary(drone_type="fixedwing")`` (the shipped
    airframe); built directly it is refused."""
