"""First-order lag shared by every actuator model (motors, boosters, gimbals, flaps).

The paper writes each actuator as the forward-Euler step of the first-order system
``dx/dt = (target - x) / tau``::

    x[t+1] = x[t] + (target - x[t]) / (tau * r_p)

where ``r_p`` is the physics rate.  We use the exact zero-order-hold discretisation of
the same system instead::

    x[t+1] = x[t] + (1 - exp(-1 / (tau * r_p))) * (target - x[t])

It equals the paper's coefficient to first order when ``tau * r_p >> 1``, keeps the
defining property of a first-order lag (63.2 % of a step after ``tau``) at any step
size, and stays stable for time constants shorter than half a physics step, where the
Euler form oscillates or diverges (at 240 Hz the Crazyflie's tau = 0.01 s is only 2.4
physics steps, and Euler would overshoot 63 % by ten points after one tau).
"""

from __future__ import annotations

import math

import numpy as np

from pyflyt_engine import exact


def lag_coefficient(dt: float, tau: float | np.ndarray) -> float | np.ndarray:
    """Fraction of the remaining error removed in one step of length ``dt``.

    Args:
        dt: step length in seconds (> 0).
        tau: time constant(s) in seconds; ``tau <= 0`` means no lag (coefficient 1).

    Returns:
        ``1 - exp(-dt / tau)``, in (0, 1]; same shape as ``tau``.
    """
    if np.ndim(tau) == 0:
        return _coefficient(dt, float(tau))
    return exact.apply(lambda t: _coefficient(dt, t), tau)


def _coefficient(dt: float, tau: float) -> float:
    # math.expm1, not np.expm1: NumPy's float64 loop is SVML on AVX-512 machines and
    # rounds differently from the C library (pyflyt_engine.exact)
    return -math.expm1(-dt / tau) if tau > 0.0 else 1.0
