"""The reference's ``PyFlyt.core.abstractions`` names.

:class:`ControlClass` and :class:`WindFieldClass` are the bases of user controllers and
wind fields, used as in the reference.  The component classes a Python drone class is
assembled from (:class:`DroneClass`, ``Motors``, ``LiftingSurface`` ...) exist so that
such modules import, and refuse to be built: airframes here are YAML files
(docs/uav_authoring.md, docs/migrating_from_pyflyt.md).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any

import numpy as np

YAML_AIRFRAMES = (
    "custom Python drone classes are not supported by pyflyt_engine.compat: describe the airframe in a YAML "
    "file instead (motors, lifting surfaces, boosters, gimbals, cameras; docs/uav_authoring.md, translation "
    "in docs/migrating_from_pyflyt.md) and fly it with pyflyt_engine.World"
)
#: the refusal of the reference's drone model files (drone_options model_dir / drone_model)
MODEL_FILES = (
    "the reference's drone model files (a URDF with its YAML of motor_params, drag_params and "
    "control_params, picked by drone_options model_dir / drone_model) are not read by pyflyt_engine.compat: "
    "describe the airframe in this project's airframe YAML (docs/uav_authoring.md; the parameter "
    "translation in docs/migrating_from_pyflyt.md) and pass its path as the Aviary's drone_type"
)


class UnsupportedFeature(NotImplementedError):
    """A reference feature this layer refuses by design (the message says what to do instead)."""


class ControlClass(ABC):
    """Base of a custom flight controller (PyFlyt 0.29.0 ``ControlClass``).

    ``step(state, setpoint)`` gets the drone's (4, 3) state array (ang_vel, ang_pos,
    lin_vel, lin_pos) and the setpoint, and returns the base mode's setpoint (4,).
    """

    def reset(self) -> None:  # noqa: B027 - optional, as in the reference
        """Reset the controller's internal state."""

    @abstractmethod
    def step(self, state: np.ndarray, setpoint: np.ndarray) -> np.ndarray:
        """The base mode's setpoint for this state and setpoint."""


class WindFieldClass(ABC):
    """Base of a custom wind field (PyFlyt 0.29.0 ``WindFieldClass``).

    ``__call__(time, position)`` gets the time [s] and an (n, 3) array of positions and
    returns the (n, 3) wind velocities [m/s] there, ground frame.
    """

    def __init__(self, np_random: None | np.random.Generator = None) -> None:
        self.np_random = np.random.default_rng() if np_random is None else np_random

    @abstractmethod
    def __call__(self, time: float, position: np.ndarray) -> np.ndarray:
        """Wind velocities (n, 3) at ``position`` (n, 3) and ``time``."""

    @staticmethod
    def _check_wind_field_validity(wind_field: Any) -> None:
        """The reference's check: the field maps (3, 3) positions to a (3, 3) float array."""
        test = wind_field(0.0, np.ones((3, 3), dtype=np.float64))
        if not isinstance(test, np.ndarray) or test.shape != (3, 3) or not np.issubdtype(test.dtype, np.floating):
            raise AssertionError(
                "the wind field must map (time, an (n, 3) float array of positions) to an (n, 3) float array, "
                f"got {type(test).__name__} {getattr(test, 'shape', '')}"
            )


class _Refused:
    """A component of Python drone classes: importable, never built."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        raise UnsupportedFeature(YAML_AIRFRAMES)


class DroneClass(_Refused):
    """PyFlyt 0.29.0 ``DroneClass``: subclassing it imports; building one raises (see module)."""


class Boosters(_Refused):
    """Refused (see module): a ``boosters`` section of a YAML airframe."""


class BoringBodies(_Refused):
    """Refused (see module): the airframe's ``drag`` section."""


class Camera(_Refused):
    """Refused (see module): a ``cameras`` entry of a YAML airframe, or Aviary ``drone_options`` use_camera."""


class Gimbals(_Refused):
    """Refused (see module): a ``gimbals`` section of a YAML airframe."""


class LiftingSurface(_Refused):
    """Refused (see module): a ``surfaces`` entry of a YAML airframe."""


class LiftingSurfaces(_Refused):
    """Refused (see module): the ``surfaces`` section of a YAML airframe."""


class Motors(_Refused):
    """Refused (see module): the ``motors`` section of a YAML airframe."""


class PID(_Refused):
    """Refused (see module): the airframe's ``control`` gains."""


__all__ = [
    "PID",
    "Boosters",
    "BoringBodies",
    "Camera",
    "ControlClass",
    "DroneClass",
    "Gimbals",
    "LiftingSurface",
    "LiftingSurfaces",
    "Motors",
    "UnsupportedFeature",
    "WindFieldClass",
]
