"""The atmosphere: wind fields (steady, sheared, gusts, Dryden turbulence) and their configs.

See ``docs/atmosphere.md``.  A :class:`~pyflyt_engine.world.World` built with
``wind=<preset name | path | mapping | WindConfig>`` owns one :class:`WindField`, inside
its :class:`~pyflyt_engine.atmosphere.air.Atmosphere` (with the rotor interactions of
:mod:`.rotors`); at every read of a vehicle the world samples it at the vehicle's
position and subtracts it from its velocity (:mod:`.air`), so every aerodynamic model
(body drag, lifting surfaces) gets the air-relative velocity as its input.
"""

from pyflyt_engine.atmosphere.config import CALM, WindConfig, available_winds, load_wind_config, parse_wind_config
from pyflyt_engine.atmosphere.field import WindField, WindSample, gust_profile, shear_factor, vehicle_span

__all__ = [
    "CALM",
    "WindConfig",
    "WindField",
    "WindSample",
    "available_winds",
    "gust_profile",
    "load_wind_config",
    "parse_wind_config",
    "shear_factor",
    "vehicle_span",
]
