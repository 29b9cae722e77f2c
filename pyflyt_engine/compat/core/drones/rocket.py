"""The reference's ``core.drones.rocket`` module path: ``Rocket``, the ``drone_type="rocket"`` of an Aviary."""

from pyflyt_engine.compat.core.abstractions import DroneClass

__all__ = ["Rocket"]


class Rocket(DroneClass):
    """PyFlyt 0.29.0 ``Rocket``: fly it with ``Aviary(drone_type="rocket")`` (the shipped
    airframe); built directly it is refused."""
