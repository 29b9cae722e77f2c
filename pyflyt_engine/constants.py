"""Physical constants shared by the engine, with units and sources."""

#: Standard gravity [m/s^2]; the paper and the reference model files use 9.81.
GRAVITY = 9.81

#: Air density [kg/m^3], ISA sea level (ICAO Doc 7488); constant until an atmosphere
#: model is added.
AIR_DENSITY = 1.225
