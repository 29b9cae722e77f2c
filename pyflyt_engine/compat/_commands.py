"""The reference's command meanings, shared by the compat envs and the compat Aviary.

Facts about the reference are cited as "PyFlyt 0.29.0 <class>: ...".
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: the mode-0 thrust command at which the reference's QuadX (cf2x) hovers: 0.300, measured
#: on PyFlyt 0.29.0 QuadX-Hover-v4 (constant command, level; the vertical acceleration
#: fitted over 1 to 2.5 s goes through zero at 0.300, +0.36 m/s^2 at 0.305, +0.90 at
#: 0.3125); its motor noise is biased upwards, so this is not sqrt(weight / max thrust)
REFERENCE_QUADX_HOVER_COMMAND = 0.300

#: the same for the reference's "primitive_drone" (its Pole and Ball-in-Cup envs' QuadX):
#: 0.480, measured on PyFlyt 0.29.0 (Aviary, mode -1, four equal commands, level, from 5 m;
#: the vertical acceleration fitted over 0.3 to 1 s: -0.24 m/s^2 at 0.475, -0.06 at 0.480,
#: +0.17 at 0.485)
REFERENCE_PRIMITIVE_HOVER_COMMAND = 0.480


def thrust_gain(vehicle: Any, reference_hover: float = REFERENCE_QUADX_HOVER_COMMAND) -> float:
    """Scale from a reference mode-0 thrust command to this airframe's motor throttle: the
    reference's hover command (its cf2x's unless given) meets this airframe's hover throttle
    (1 without a mixer)."""
    try:
        return float(vehicle.hover_throttle()) / reference_hover
    except Exception:  # noqa: BLE001 - an airframe without multirotor motors: no scaling
        return 1.0


def command_to_thrust_fraction(command: float, gain: float) -> float:
    """PyFlyt 0.29.0 QuadX mode 0: the thrust entry is a motor command and a motor's thrust goes
    as the square of its command; here the entry is a fraction of the full collective
    thrust.  So ``T`` becomes ``(gain x T)**2`` (negative commands: idle), ``gain`` from
    :func:`thrust_gain`; exact at hover by construction, quadratic around it."""
    t = max(float(command), 0.0) * gain
    return t * t


def surface_commands_to_channels(setpoint: Any) -> np.ndarray:
    """PyFlyt 0.29.0 Fixedwing mode -1 commands (left aileron, right aileron, horizontal tail,
    vertical tail, main wing, thrust) folded onto the airframe's channels (roll, pitch,
    yaw, thrust): roll = (left - right) / 2, pitch = horizontal tail, yaw = -vertical tail
    (PyFlyt Fixedwing mode 0 drives them as left = roll, right = -roll, tail = pitch,
    vertical tail = -yaw); the main wing's entry has no surface here."""
    la, ra, ht, vt, _mw, thrust = (float(v) for v in setpoint)
    return np.array((0.5 * (la - ra), ht, -vt, thrust))
