"""Exceptions the engine raises for bad input, each carrying a message fit for a user."""


class PyFlytError(Exception):
    """Base class: a problem the user can fix, described in the message."""


class SpecError(PyFlytError, ValueError):
    """A vehicle (UAV) spec is malformed: the message names the file, the field and the fix."""


class ConfigError(PyFlytError, ValueError):
    """A configuration value is invalid (loop rates, flight modes, setpoints, ...)."""


class TelemetryError(PyFlytError, ValueError):
    """An MCAP telemetry file cannot be written or read: the message names the file and the problem."""


class SimulationError(PyFlytError):
    """The simulation produced a non-finite observation or reward (the physics blew up):
    the message names the episode step, the vehicle's state and the action."""
