"""The one numba decorator of the batched backend's compiled code.

:func:`njit` is ``numba.njit`` compiling with NumPy's error model (``error_model="numpy"``):
a float division by zero gives IEEE's ``inf`` or ``nan`` (an integer one 0) instead of
raising Python's ``ZeroDivisionError``.  Python's model puts a test and a branch on every division's
divisor, which keeps the compiler from packing neighbouring divisions into one vector
instruction: on QuadX-Hover's physics (8 physics steps per agent step, a dozen divisions
in each) those tests cost ~9 % (``experiments/speed_advance.py``).  No number changes: a
vector division rounds each lane as the scalar one does (IEEE 754), and no law here divides
by zero on a valid input (masses, inertias, norms and full thrusts are positive; the
configs refuse the rest at load).  Fast-math stays off, so nothing is reassociated or
contracted into fused multiply-adds (:mod:`pyflyt_engine.batched.kernels`).
"""

from __future__ import annotations

from typing import Any

import numba


def njit(*args: Any, **options: Any) -> Any:
    """``numba.njit(*args, **options)`` with ``error_model="numpy"`` unless given."""
    options.setdefault("error_model", "numpy")
    return numba.njit(*args, **options)
