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


class MissingExtraError(PyFlytError, ImportError):
    """A feature needs a package of an optional extra that is not installed: the message
    names the package and the ``pip install`` that brings it."""


def require(module: str, extra: str, feature: str):
    """Import ``module`` for ``feature``, or raise :class:`MissingExtraError` naming the extra."""
    import importlib

    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as error:
        raise MissingExtraError(
            f"{feature} needs the package '{(error.name or module).split('.')[0]}', which is not installed: "
            f'install the \'{extra}\' extra, e.g. pip install "pyflyt-toolkit[{extra}]" (or ".[{extra}]" in a checkout)'
        ) from None
