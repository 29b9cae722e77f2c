"""pyflyt_engine: the simulation library (world, components, control, vehicles)."""

__version__ = "0.1.0"

# First, before anything loads NumPy or PyTorch: one floating-point kernel set on every
# AVX2 CPU (pyflyt_engine/numerics.py; PYFLYT_NUMERICS=native opts out).
from pyflyt_engine import numerics as _numerics  # noqa: E402

_numerics.pin()

# Register the Gymnasium ids (PyFlyt/QuadX-Hover-v0, ...).  Cheap: entry points are
# strings, so this imports Gymnasium's registry but neither PyBullet nor the env classes.
from pyflyt_engine import envs as _envs  # noqa: E402,F401
