"""pyflyt_engine: the simulation library (world, components, control, vehicles)."""

__version__ = "0.1.0"

# Register the Gymnasium ids (PyFlyt/QuadX-Hover-v0, ...).  Cheap: entry points are
# strings, so this imports Gymnasium's registry but neither PyBullet nor the env classes.
from pyflyt_engine import envs as _envs  # noqa: E402,F401
