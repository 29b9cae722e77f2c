"""The reference's ``PyFlyt.core.drones``: ``QuadX``, ``Fixedwing``, ``Rocket``.

Here each is a shipped YAML airframe (``Aviary(drone_type="quadx" | "fixedwing" |
"rocket")``), not a Python class: the names import (type hints, ``isinstance`` against an
Aviary's drones) and building one directly is refused with the message of
:mod:`pyflyt_engine.compat.core.abstractions`.
"""

from pyflyt_engine.compat.core.drones.fixedwing import Fixedwing
from pyflyt_engine.compat.core.drones.quadx import QuadX
from pyflyt_engine.compat.core.drones.rocket import Rocket

__all__ = ["Fixedwing", "QuadX", "Rocket"]
