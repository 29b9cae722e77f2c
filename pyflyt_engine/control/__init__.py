"""Flight control: named flight modes, the geometric mixer, the cascaded PID controller and the rocket autopilot."""

from pyflyt_engine.control.mixer import Mixer
from pyflyt_engine.control.modes import MULTIROTOR_MODES, FlightMode, resolve_mode
from pyflyt_engine.control.multirotor import MultirotorController
from pyflyt_engine.control.rocket import ROCKET_MODES, RocketAutopilot

__all__ = [
    "MULTIROTOR_MODES",
    "ROCKET_MODES",
    "FlightMode",
    "Mixer",
    "MultirotorController",
    "RocketAutopilot",
    "resolve_mode",
]
