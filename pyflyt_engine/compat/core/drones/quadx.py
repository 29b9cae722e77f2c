"""The reference's ``core.drones.quadx`` module path: ``QuadX``, the ``drone_type="quadx"`` of an Aviary."""

from pyflyt_engine.compat.core.abstractions import DroneClass

# the names the reference's module holds through its own imports, for code that takes them from here
from pyflyt_engine.compat.core.abstractions import BoringBodies, Camera, ControlClass, Motors, PID

__all__ = ["BoringBodies", "Camera", "ControlClass", "Motors", "PID", "QuadX"]


class QuadX(DroneClass):
    """PyFlyt 0.29.0 ``QuadX``: fly it with ``Aviary(drone_type="quadx")`` (the shipped
    airframe); built directly it is refused."""
