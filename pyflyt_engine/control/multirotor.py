"""Cascaded PID flight controller for multirotors.

    position --> velocity --> (tilt, thrust) --> attitude --> body rates --> mixer
      [m]         [m/s]          [rad], [N]        [rad]        [rad/s]      throttles

Each flight mode (see :mod:`pyflyt_engine.control.modes`) enters the cascade at its own
level; every level below is shared, so no PID stack is written twice.  Gains are in
physical units (the rate loop asks for an angular acceleration, multiplied by the
inertia; the velocity loop asks for an acceleration, multiplied by the mass), so the
same gains fly airframes of very different size; the values live in each airframe's
YAML (``control:`` section, :class:`~pyflyt_engine.spec.MultirotorControlSpec`).

The controller is plain Python on floats: at four values per loop, that is several
times cheaper than NumPy's per-call overhead, and the loop runs at 120 Hz per vehicle.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.control.mixer import Mixer
from pyflyt_engine.control.modes import FlightMode, resolve_mode
from pyflyt_engine.frames import wrap_angle
from pyflyt_engine.spec import MultirotorControlSpec
from pyflyt_engine.state import KinematicState


def _clip(value: float, limit: float) -> float:
    return limit if value > limit else -limit if value < -limit else value


class MultirotorController:
    """Turns a flight-mode setpoint into motor throttles.

    Args:
        gains: the airframe's ``control`` section.
        mass: vehicle mass [kg].
        inertia: principal inertia (Ixx, Iyy, Izz) [kg m^2].
        mixer: the airframe's mixer.
        dt: control period [s].
    """

    def __init__(
        self,
        gains: MultirotorControlSpec,
        mass: float,
        inertia: Sequence[float],
        mixer: Mixer,
        dt: float,
    ) -> None:
        self.gains = gains
        self.mass = mass
        self.inertia = tuple(float(i) for i in inertia)
        self.mixer = mixer
        self.dt = dt
        self._rate = gains.rate
        rate = gains.rate
        # integrator limits on int(e), from the limit on ki * int(e); no integration when ki = 0
        self._rate_gains = (
            tuple(rate.kp),
            tuple(rate.ki),
            tuple(rate.kd),
            tuple(lim / k if k > 0 else 0.0 for lim, k in zip(rate.integral_limit, rate.ki)),
        )
        self._att = gains.attitude
        self._vel = gains.velocity
        vel = gains.velocity
        self._vel_gains = (
            tuple(vel.kp),
            tuple(vel.ki),
            tuple(lim / k if k > 0 else 0.0 for lim, k in zip(vel.integral_limit, vel.ki)),
            vel.integral_window,
        )
        self._pos = gains.position
        self.mode: FlightMode = resolve_mode(gains.mode)
        self.reset()

    def reset(self) -> None:
        """Clear integrators and derivative memory (on spawn, reset and mode change)."""
        self._rate_integral = [0.0, 0.0, 0.0]
        self._prev_rate: tuple[float, float, float] | None = None
        self._vel_integral = [0.0, 0.0, 0.0]

    def set_mode(self, mode: FlightMode) -> None:
        """Switch flight mode; integrators restart from zero."""
        if mode.name != self.mode.name:
            self.mode = mode
            self.reset()

    # ------------------------------------------------------------------ loops

    def _rate_loop(self, state: KinematicState, p_sp: float, q_sp: float, r_sp: float) -> tuple[float, float, float]:
        """Body torques [N m] that drive the body rates to the setpoint."""
        dt = self.dt
        kp, ki, kd, limit = self._rate_gains
        wx, wy, wz = rates = state.ang_vel
        px, py, pz = self._prev_rate or rates
        self._prev_rate = rates
        ix, iy, iz = self._rate_integral
        ex, ey, ez = p_sp - wx, q_sp - wy, r_sp - wz
        ix, iy, iz = _clip(ix + ex * dt, limit[0]), _clip(iy + ey * dt, limit[1]), _clip(iz + ez * dt, limit[2])
        self._rate_integral = [ix, iy, iz]
        jx, jy, jz = self.inertia
        ax = kp[0] * ex + ki[0] * ix - kd[0] * (wx - px) / dt
        ay = kp[1] * ey + ki[1] * iy - kd[1] * (wy - py) / dt
        az = kp[2] * ez + ki[2] * iz - kd[2] * (wz - pz) / dt
        # torque = J alpha plus the gyroscopic feed-forward omega x (J omega)
        return (
            jx * ax + (jz - jy) * wy * wz,
            jy * ay + (jx - jz) * wz * wx,
            jz * az + (jy - jx) * wx * wy,
        )

    def _attitude_loop(self, state: KinematicState, roll: float, pitch: float, yaw: float | None, yaw_rate: float) -> tuple[float, float, float]:
        """Body-rate setpoint from an attitude setpoint (yaw=None: hold ``yaw_rate``)."""
        kp, lim = self._att.kp, self._att.max_rate
        cur = state.ang_pos
        p = _clip(kp[0] * (roll - cur[0]), lim[0])
        q = _clip(kp[1] * (pitch - cur[1]), lim[1])
        r = yaw_rate if yaw is None else kp[2] * wrap_angle(yaw - cur[2])
        return p, q, _clip(r, lim[2])

    def _velocity_loop(self, state: KinematicState, vx: float | None, vy: float | None, vz: float | None) -> tuple[float, float, float]:
        """Ground-frame acceleration command [m/s^2]; a None setpoint leaves that axis at 0."""
        dt = self.dt
        kp, ki, limit, window = self._vel_gains
        cur = state.lin_vel_ground
        integral = self._vel_integral
        out = [0.0, 0.0, 0.0]
        for i, sp in enumerate((vx, vy, vz)):
            if sp is None:
                continue
            err = sp - cur[i]
            if -window < err < window:  # integrate near the setpoint only (anti-windup)
                integral[i] = _clip(integral[i] + err * dt, limit[i])
            out[i] = kp[i] * err + ki[i] * integral[i]
        return out[0], out[1], out[2]

    def _tilt_for(self, state: KinematicState, ax: float, ay: float, az: float) -> tuple[float, float]:
        """Roll and pitch [rad] that point the thrust to give the ground acceleration."""
        yaw = state.ang_pos[2]
        cy, sy = math.cos(yaw), math.sin(yaw)
        forward = cy * ax + sy * ay
        left = -sy * ax + cy * ay
        lift = max(GRAVITY + az, 0.1 * GRAVITY)
        pitch = math.atan2(forward, lift)
        roll = math.atan2(-left * math.cos(pitch), lift)
        limit = self._vel.max_tilt
        return _clip(roll, limit), _clip(pitch, limit)

    def _thrust_for(self, state: KinematicState, az: float) -> float:
        """Collective thrust [N] for vertical acceleration ``az``, tilt-compensated."""
        roll, pitch = state.ang_pos[0], state.ang_pos[1]
        tilt = max(math.cos(roll) * math.cos(pitch), 0.5)
        return max(self.mass * (GRAVITY + az) / tilt, 0.0)

    def _climb(self, state: KinematicState, z: float) -> float:
        """Climb-rate setpoint [m/s] from an altitude setpoint."""
        return _clip(self._pos.kp[2] * (z - state.lin_pos[2]), self._pos.max_velocity[2])

    def _horizontal(self, state: KinematicState, x: float, y: float) -> tuple[float, float]:
        """Ground velocity setpoint [m/s] from a horizontal position setpoint."""
        kp, lim = self._pos.kp, self._pos.max_velocity
        pos = state.lin_pos
        return _clip(kp[0] * (x - pos[0]), lim[0]), _clip(kp[1] * (y - pos[1]), lim[1])

    # --------------------------------------------------------------- dispatch

    def __call__(self, state: KinematicState, setpoint: Sequence[float]) -> list[float]:
        """Motor throttles for the current mode and setpoint."""
        name = self.mode.name
        if name == "motors":
            return [float(s) for s in setpoint]
        a, b, c, d = setpoint
        if name == "rates_thrust":
            tx, ty, tz = self._rate_loop(state, a, b, c)
            return self.mixer.throttles(d * self.mixer.max_collective, tx, ty, tz)
        if name == "rates_z":
            _, _, az = self._velocity_loop(state, None, None, self._climb(state, d))  # type: ignore[arg-type]
            tx, ty, tz = self._rate_loop(state, a, b, c)
            return self.mixer.throttles(self._thrust_for(state, az), tx, ty, tz)
        if name in ("attitude_vz", "attitude_z"):
            vz = d if name == "attitude_vz" else self._climb(state, d)
            _, _, az = self._velocity_loop(state, None, None, vz)  # type: ignore[arg-type]
            rates = self._attitude_loop(state, a, b, c, 0.0)
            return self._finish(state, rates, az)

        # translational modes: build a ground velocity setpoint, a yaw target and vz
        yaw, yaw_rate = (None, c) if name in ("heading_velocity_z", "heading_velocity_vz", "velocity_yawrate", "position_yawrate") else (c, 0.0)
        if name in ("heading_velocity_z", "heading_velocity_vz"):
            heading = state.ang_pos[2]
            ch, sh = math.cos(heading), math.sin(heading)
            vx, vy = ch * a - sh * b, sh * a + ch * b
        elif name in ("velocity_yawrate", "velocity_yaw"):
            vx, vy = a, b
        else:  # position_yaw, position_yawrate
            vx, vy = self._horizontal(state, a, b)
        vz = self._climb(state, d) if name in ("heading_velocity_z", "position_yaw", "position_yawrate") else d
        ax, ay, az = self._velocity_loop(state, vx, vy, vz)
        roll, pitch = self._tilt_for(state, ax, ay, az)
        rates = self._attitude_loop(state, roll, pitch, yaw, yaw_rate)
        return self._finish(state, rates, az)

    def _finish(self, state: KinematicState, rates: tuple[float, float, float], az: float) -> list[float]:
        tx, ty, tz = self._rate_loop(state, *rates)
        return self.mixer.throttles(self._thrust_for(state, az), tx, ty, tz)
