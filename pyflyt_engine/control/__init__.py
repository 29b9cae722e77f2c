"""Flight control: named flight modes, the geometric mixer and the cascaded PID controller."""

from pyflyt_engine.control.mixer import Mixer
from pyflyt_engine.control.modes import MULTIROTOR_MODES, FlightMode, resolve_mode
from pyflyt_engine.control.multirotor import MultirotorController

__all__ = ["MULTIROTOR_MODES", "FlightMode", "Mixer", "MultirotorController", "resolve_mode"]
