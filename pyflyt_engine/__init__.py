"""pyflyt_engine: the simulation library (world, components, control, vehicles)."""

__version__ = "0.1.0"
