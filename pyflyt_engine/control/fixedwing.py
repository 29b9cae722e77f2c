"""Fixed-wing autopilot: attitude and airspeed hold from PID loops, writing channels.

Channel sign convention (every shipped airframe's ``mix`` follows it, see
docs/uav_authoring.md): a positive roll channel rolls the vehicle in the positive roll
direction (right wing down), a positive pitch channel pitches it positive (nose down,
ENU convention), a positive yaw channel yaws it positive (nose left), and the thrust
channel in [0, 1] pushes it forward.

Mode ``attitude_airspeed``, setpoint [roll rad, pitch rad, yaw rate rad/s, airspeed m/s]::

    roll channel   = kp (roll_sp - roll) + ki int(.) - kd p
    pitch channel  = kp (pitch_sp - pitch) + ki int(.) - kd q
    yaw channel    = kp (yaw_rate_sp - r)                    (yaw damper)
    thrust channel = cruise_thrust + kp (V_sp - u) + ki int(.)    (u: forward body speed)
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pyflyt_engine.control.modes import FlightMode
from pyflyt_engine.spec import AxisGains, FixedwingControlSpec
from pyflyt_engine.state import KinematicState

FIXEDWING_MODES = {
    "channels": FlightMode("channels", None, ("channels",), "raw control channels (the paper's action)"),
    "attitude_airspeed": FlightMode(
        "attitude_airspeed", None, ("roll", "pitch", "yaw_rate", "airspeed"), "attitude and airspeed hold autopilot"
    ),
}


class _Loop:
    def __init__(self, gains: AxisGains, dt: float) -> None:
        self.g, self.dt, self.integral = gains, dt, 0.0

    def __call__(self, error: float, rate: float) -> float:
        g = self.g
        if g.ki > 0:
            limit = g.integral_limit / g.ki
            self.integral = min(max(self.integral + error * self.dt, -limit), limit)
        return g.kp * error + g.ki * self.integral - g.kd * rate


class FixedwingAutopilot:
    """Maps an autopilot setpoint to the channel vector of a fixed-wing airframe.

    Args:
        gains: the airframe's ``control`` section.
        channels: the airframe's channel names (setpoint order).
        low, high: channel ranges.
        dt: control period [s].
    """

    def __init__(
        self, gains: FixedwingControlSpec, channels: Sequence[str], low: np.ndarray, high: np.ndarray, dt: float
    ) -> None:
        self.gains, self.dt = gains, dt
        self.low, self.high = low, high
        self._index = [
            channels.index(c)
            for c in (gains.roll_channel, gains.pitch_channel, gains.yaw_channel, gains.thrust_channel)
        ]
        self.n = len(channels)
        self.reset()

    def reset(self) -> None:
        """Clear the integrators."""
        g, dt = self.gains, self.dt
        self._roll, self._pitch, self._yaw, self._speed = (
            _Loop(g.roll, dt),
            _Loop(g.pitch, dt),
            _Loop(g.yaw, dt),
            _Loop(g.airspeed, dt),
        )

    def __call__(self, state: KinematicState, setpoint: Sequence[float]) -> np.ndarray:
        roll_sp, pitch_sp, yaw_rate_sp, speed_sp = setpoint
        p, q, r = state.ang_vel
        roll, pitch, _ = state.ang_pos
        out = np.zeros(self.n)
        i_roll, i_pitch, i_yaw, i_thrust = self._index
        out[i_roll] = self._roll(roll_sp - roll, p)
        out[i_pitch] = self._pitch(pitch_sp - pitch, q)
        out[i_yaw] = self._yaw(yaw_rate_sp - r, 0.0)
        out[i_thrust] = self.gains.cruise_thrust + self._speed(speed_sp - state.lin_vel[0], 0.0)
        return out.clip(self.low, self.high)  # np.clip's own call, without its wrapper
