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

# Limits are written as conditional expressions, not min()/max(): cheaper at the control
# rate, and they keep min/max's exact results (NaN and signed zeros included).
# ruff: noqa: FURB136

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.control.mixer import Mixer
from pyflyt_engine.control.modes import FlightMode, resolve_mode
from pyflyt_engine.spec import MultirotorControlSpec
from pyflyt_engine.state import KinematicState

#: Translational modes: (yaw is a rate setpoint, setpoint is heading-frame velocity,
#: setpoint is a position, vertical setpoint is an altitude).
_TRANSLATIONAL = {
    "heading_velocity_z": (True, True, False, True),
    "heading_velocity_vz": (True, True, False, False),
    "velocity_yawrate": (True, False, False, False),
    "velocity_yaw": (False, False, False, False),
    "position_yaw": (False, False, True, True),
    "position_yawrate": (True, False, True, True),
}
_TWO_PI = 2 * math.pi
_MIN_LIFT = 0.1 * GRAVITY


class MultirotorController:
    """Turns a flight-mode setpoint into motor throttles.

    Args:
        gains: the airframe's ``control`` section.
        mass: vehicle mass [kg].
        inertia: principal inertia (Ixx, Iyy, Izz) [kg m^2].
        mixer: the airframe's mixer.
        dt: control period [s].

    Each loop is written out on local floats with the gains unpacked once here (the
    spec is frozen); the arithmetic of every loop is spelled out in its docstring.

    Attributes:
        law: the current mode's control law, ``law(state, setpoint) -> throttles``
            (what calling the controller runs; it changes with :meth:`set_mode`).
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
        rate, att, vel, pos = gains.rate, gains.attitude, gains.velocity, gains.position
        # integrator limits on int(e), from the limit on ki * int(e); no integration when ki = 0
        rate_limit = tuple(lim / k if k > 0 else 0.0 for lim, k in zip(rate.integral_limit, rate.ki))
        jx, jy, jz = self.inertia
        self._rate_constants = (
            *rate.kp, *rate.ki, *rate.kd, *rate_limit, dt, jx, jy, jz, jz - jy, jx - jz, jy - jx,
        )  # fmt: skip
        self._rate_derivative = any(k != 0.0 for k in rate.kd)
        self._attitude_constants = (*att.kp, *att.max_rate)
        vel_limit = tuple(lim / k if k > 0 else 0.0 for lim, k in zip(vel.integral_limit, vel.ki))
        self._velocity_constants = (*vel.kp, *vel.ki, *vel_limit, vel.integral_window, dt)
        self._max_tilt = vel.max_tilt
        self._position_constants = (*pos.kp, *pos.max_velocity)
        self.mode: FlightMode = resolve_mode(gains.mode)
        self.law: Callable[[KinematicState, Sequence[float]], list[float]]
        self._select(self.mode)
        self.reset()

    def reset(self) -> None:
        """Clear integrators and derivative memory (on spawn, reset and mode change)."""
        self._rate_integral = (0.0, 0.0, 0.0)
        self._prev_rate: tuple[float, float, float] | None = None
        self._vel_integral = [0.0, 0.0, 0.0]

    def set_mode(self, mode: FlightMode) -> None:
        """Switch flight mode; integrators restart from zero."""
        if mode.name != self.mode.name:
            self.mode = mode
            self._select(mode)
            self.reset()

    def _select(self, mode: FlightMode) -> None:
        name = mode.name
        self._translational = _TRANSLATIONAL.get(name)
        if name == "motors":
            self.law = self._motors
        elif name == "rates_thrust":
            self.law = self._rates_thrust
        elif name == "rates_z":
            self.law = self._rates_z
        elif name in ("attitude_vz", "attitude_z"):
            self.law = self._attitude
        elif self._translational is not None:
            self.law = self._translate
        else:
            raise ValueError(f"no control law for mode {name!r}")

    # --------------------------------------------------------------- dispatch

    def __call__(self, state: KinematicState, setpoint: Sequence[float]) -> list[float]:
        """Motor throttles for the current mode and setpoint."""
        return self.law(state, setpoint)

    # ------------------------------------------------------------------ loops

    def _rate_loop(self, state: KinematicState, p_sp: float, q_sp: float, r_sp: float) -> tuple[float, float, float]:
        """Body torques [N m] that drive the body rates to the setpoint.

        Per axis: ``e = sp - omega``; ``I = clip(I + e dt, limit)``;
        ``alpha = kp e + ki I - kd (omega - omega_prev) / dt``; torque = J alpha plus the
        gyroscopic feed-forward omega x (J omega).
        """
        (
            kpx, kpy, kpz, kix, kiy, kiz, kdx, kdy, kdz, lx, ly, lz, dt, jx, jy, jz, jzy, jxz, jyx
        ) = self._rate_constants  # fmt: skip
        wx, wy, wz = rates = state.ang_vel
        px, py, pz = self._prev_rate or rates
        self._prev_rate = rates
        ix, iy, iz = self._rate_integral
        ex, ey, ez = p_sp - wx, q_sp - wy, r_sp - wz
        ix = ix + ex * dt
        ix = lx if ix > lx else -lx if ix < -lx else ix
        iy = iy + ey * dt
        iy = ly if iy > ly else -ly if iy < -ly else iy
        iz = iz + ez * dt
        iz = lz if iz > lz else -lz if iz < -lz else iz
        self._rate_integral = (ix, iy, iz)
        ax = kpx * ex + kix * ix
        ay = kpy * ey + kiy * iy
        az = kpz * ez + kiz * iz
        if self._rate_derivative:  # (with kd = 0 the term is zero: left out)
            ax = ax - kdx * (wx - px) / dt
            ay = ay - kdy * (wy - py) / dt
            az = az - kdz * (wz - pz) / dt
        return jx * ax + jzy * wy * wz, jy * ay + jxz * wz * wx, jz * az + jyx * wx * wy

    def _climb(self, state: KinematicState, z: float) -> float:
        """Climb-rate setpoint [m/s] from an altitude setpoint: clip(kp_z (z - z_now))."""
        kp, lim = self._position_constants[2], self._position_constants[5]
        v = kp * (z - state.lin_pos[2])
        return lim if v > lim else -lim if v < -lim else v

    def _vertical(self, state: KinematicState, vz: float) -> float:
        """The z row of the velocity loop alone (x and y left at 0, not integrated)."""
        _, _, kp, _, _, ki, _, _, limit, window, dt = self._velocity_constants
        integral = self._vel_integral
        err = vz - state.lin_vel_ground[2]
        if -window < err < window:  # integrate near the setpoint only (anti-windup)
            i = integral[2] + err * dt
            integral[2] = limit if i > limit else -limit if i < -limit else i
        return kp * err + ki * integral[2]

    def _thrust_for(self, state: KinematicState, az: float) -> float:
        """Collective thrust [N] for vertical acceleration ``az``, tilt-compensated:
        ``max(m (g + az) / max(cos(roll) cos(pitch), 0.5), 0)``."""
        roll, pitch, _ = state.ang_pos
        tilt = math.cos(roll) * math.cos(pitch)
        tilt = 0.5 if 0.5 > tilt else tilt  # max(tilt, 0.5)
        thrust = self.mass * (GRAVITY + az) / tilt
        return 0.0 if 0.0 > thrust else thrust  # max(thrust, 0.0)

    def _attitude_rates(self, state: KinematicState, roll: float, pitch: float, yaw: float | None, yaw_rate: float):
        """Body-rate setpoint from an attitude setpoint (yaw=None: hold ``yaw_rate``):
        ``clip(kp (angle_sp - angle))`` per axis, the yaw error wrapped to [-pi, pi)
        as :func:`~pyflyt_engine.frames.wrap_angle` does."""
        kx, ky, kz, lx, ly, lz = self._attitude_constants
        cr, cp, cy = state.ang_pos
        p = kx * (roll - cr)
        p = lx if p > lx else -lx if p < -lx else p
        q = ky * (pitch - cp)
        q = ly if q > ly else -ly if q < -ly else q
        r = yaw_rate if yaw is None else kz * ((yaw - cy + math.pi) % _TWO_PI - math.pi)
        r = lz if r > lz else -lz if r < -lz else r
        return p, q, r

    # ------------------------------------------------------------------ laws

    def _motors(self, state: KinematicState, setpoint: Sequence[float]) -> list[float]:
        return [float(s) for s in setpoint]

    def _rates_thrust(self, state: KinematicState, setpoint: Sequence[float]) -> list[float]:
        a, b, c, d = setpoint
        tx, ty, tz = self._rate_loop(state, a, b, c)
        return self.mixer.throttles(d * self.mixer.max_collective, tx, ty, tz)

    def _rates_z(self, state: KinematicState, setpoint: Sequence[float]) -> list[float]:
        a, b, c, d = setpoint
        az = self._vertical(state, self._climb(state, d))
        tx, ty, tz = self._rate_loop(state, a, b, c)
        return self.mixer.throttles(self._thrust_for(state, az), tx, ty, tz)

    def _attitude(self, state: KinematicState, setpoint: Sequence[float]) -> list[float]:
        a, b, c, d = setpoint
        az = self._vertical(state, d if self.mode.name == "attitude_vz" else self._climb(state, d))
        p, q, r = self._attitude_rates(state, a, b, c, 0.0)
        tx, ty, tz = self._rate_loop(state, p, q, r)
        return self.mixer.throttles(self._thrust_for(state, az), tx, ty, tz)

    def _translate(self, state: KinematicState, setpoint: Sequence[float]) -> list[float]:
        """Translational modes: a ground velocity setpoint, a yaw target (or rate) and vz.

        position -> velocity: ``clip(kp (x_sp - x))``; velocity -> acceleration (ground
        frame, per axis): ``kp e + ki I``, integrating only while ``|e| < window``;
        acceleration -> tilt: ``pitch = atan2(forward, lift)``,
        ``roll = atan2(-left cos(pitch), lift)`` with ``lift = max(g + az, 0.1 g)`` and
        (forward, left) the acceleration in the heading frame, both clipped to max_tilt.
        """
        yaw_is_rate, heading_frame, position, altitude = self._translational  # type: ignore[misc]
        a, b, c, d = setpoint
        x, y, z = state.lin_pos
        cos, sin = math.cos, math.sin
        pkx, pky, pkz, plx, ply, plz = self._position_constants
        if heading_frame:
            heading = state.ang_pos[2]
            ch, sh = cos(heading), sin(heading)
            vx, vy = ch * a - sh * b, sh * a + ch * b
        elif position:
            vx = pkx * (a - x)
            vx = plx if vx > plx else -plx if vx < -plx else vx
            vy = pky * (b - y)
            vy = ply if vy > ply else -ply if vy < -ply else vy
        else:
            vx, vy = a, b
        if altitude:
            vz = pkz * (d - z)
            vz = plz if vz > plz else -plz if vz < -plz else vz
        else:
            vz = d

        # velocity loop, ground frame
        kpx, kpy, kpz, kix, kiy, kiz, lx, ly, lz, window, dt = self._velocity_constants
        gx, gy, gz = state.lin_vel_ground
        integral = self._vel_integral
        ix, iy, iz = integral
        ex = vx - gx
        if -window < ex < window:  # integrate near the setpoint only (anti-windup)
            ix = ix + ex * dt
            ix = lx if ix > lx else -lx if ix < -lx else ix
        ey = vy - gy
        if -window < ey < window:
            iy = iy + ey * dt
            iy = ly if iy > ly else -ly if iy < -ly else iy
        ez = vz - gz
        if -window < ez < window:
            iz = iz + ez * dt
            iz = lz if iz > lz else -lz if iz < -lz else iz
        integral[0], integral[1], integral[2] = ix, iy, iz
        ax = kpx * ex + kix * ix
        ay = kpy * ey + kiy * iy
        az = kpz * ez + kiz * iz

        # acceleration -> tilt
        roll_now, pitch_now, yaw = state.ang_pos
        cy, sy = cos(yaw), sin(yaw)
        forward = cy * ax + sy * ay
        left = -sy * ax + cy * ay
        lift = GRAVITY + az
        lift = _MIN_LIFT if _MIN_LIFT > lift else lift  # max(g + az, 0.1 g)
        pitch = math.atan2(forward, lift)
        roll = math.atan2(-left * cos(pitch), lift)
        limit = self._max_tilt
        roll = limit if roll > limit else -limit if roll < -limit else roll
        pitch = limit if pitch > limit else -limit if pitch < -limit else pitch

        # attitude -> body rates, and the thrust: _attitude_rates and _thrust_for, inline
        kx, ky, kz, mx, my, mz = self._attitude_constants
        p = kx * (roll - roll_now)
        p = mx if p > mx else -mx if p < -mx else p
        q = ky * (pitch - pitch_now)
        q = my if q > my else -my if q < -my else q
        r = c if yaw_is_rate else kz * ((c - yaw + math.pi) % _TWO_PI - math.pi)
        r = mz if r > mz else -mz if r < -mz else r
        tilt = cos(roll_now) * cos(pitch_now)
        tilt = 0.5 if 0.5 > tilt else tilt
        thrust = self.mass * (GRAVITY + az) / tilt
        thrust = 0.0 if 0.0 > thrust else thrust
        tx, ty, tz = self._rate_loop(state, p, q, r)
        return self.mixer.throttles(thrust, tx, ty, tz)
