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

import numpy as np


def lag_coefficient(dt: float, tau: float | np.ndarray) -> float | np.ndarray:
    """Fraction of the remaining error removed in one step of length ``dt``.

    Args:
        dt: step length in seconds (> 0).
        tau: time constant(s) in seconds; ``tau <= 0`` means no lag (coefficient 1).

    Returns:
        ``1 - exp(-dt / tau)``, in (0, 1]; same shape as ``tau``.
    """
    tau_arr = np.asarray(tau, dtype=np.float64)
    with np.errstate(divide="ignore"):
        coeff = np.where(tau_arr > 0.0, -np.expm1(-dt / np.where(tau_arr > 0.0, tau_arr, 1.0)), 1.0)
    if np.ndim(tau) == 0:
        return float(coeff)
    return coeff
