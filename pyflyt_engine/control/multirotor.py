"""Cascaded PID flight controller for multirotors.

    position --> velocity --> (tilt, thrust) --> attitude --> body rates --> mixer
      [m]         [m/s]          [rad], [N]        [rad]        [rad/s]      throttles

Each flight mode (see :mod:`pyflyt_engine.control.modes`) enters the cascade at its own
level; every level below is shared, so no PID stack is written twice.  Gains are in
physical units (the rate loop asks for an angular acceleration, multiplied by the
inertia; the velocity loop asks for an acceleration, multiplied by the mass), so the
same gains fly airframes of very different size; the values live in each airframe's
YAML (``control:`` section, :class:`~pyflyt_engine.spec.MultirotorControlSpec`).

Each loop is written once, as a small method whose docstring states its law, on plain
Python floats: at three values per loop that is cheaper than NumPy's per-call overhead,
and the cascade runs at 120 Hz per vehicle.
"""

# Limits are written as conditional expressions, not min()/max(): cheaper at the control
# rate, and they keep min/max's exact results (NaN and signed zeros included).
# ruff: noqa: FURB136

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence

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


def _clamp(value: float, limit: float) -> float:
    """``value`` limited to [-limit, limit]."""
    return limit if value > limit else -limit if value < -limit else value


def velocity_authority(max_collective: float, mass: float, max_tilt: float) -> tuple[float, float, float]:
    """The accelerations [m/s^2] the airframe can add to hover, from its thrust margin:
    (horizontal, up, down).

    Horizontal: the tilt loop leans the thrust by at most ``max_tilt`` with the vertical
    component held at ``m g``, so ``a_h = min(g tan(max_tilt), sqrt((T_max/m)^2 - g^2))``
    (the second, the full collective ``T_max`` leaned until its vertical part is the
    weight, binds only when the thrust margin is thin).  Up: ``T_max/m - g``.  Down: the
    tilt loop keeps at least 0.1 g of lift, so ``0.9 g``.  These bound the velocity loop's
    integral (a steady disturbance beyond them cannot be held) and mark where its output
    saturates (the anti-windup).
    """
    per_mass = max_collective / mass
    margin = per_mass * per_mass - GRAVITY * GRAVITY
    thrust_bound = math.sqrt(margin) if margin > 0.0 else 0.0
    tilt_bound = GRAVITY * math.tan(max_tilt)
    up = per_mass - GRAVITY
    return (
        tilt_bound if tilt_bound < thrust_bound else thrust_bound,
        up if up > 0.0 else 0.0,
        GRAVITY - _MIN_LIFT,
    )


def _integral_limits(limits: Sequence[float], ki: Sequence[float]) -> tuple[float, ...]:
    """Per axis, the bound on the integral of the error from the bound on ``ki * integral``
    (0: no integration when ``ki = 0``)."""
    return tuple(lim / k if k > 0 else 0.0 for lim, k in zip(limits, ki))


class MultirotorController:
    """Turns a flight-mode setpoint into motor throttles.

    Args:
        gains: the airframe's ``control`` section.
        mass: vehicle mass [kg].
        inertia: principal inertia (Ixx, Iyy, Izz) [kg m^2].
        mixer: the airframe's mixer.
        dt: control period [s].

    Attributes:
        law: the current mode's control law, ``law(state, setpoint) -> throttles``
            (what calling the controller runs; it changes with :meth:`set_mode`).
    """

    def __init__(
        self,
        gains: MultirotorControlSpec,
        mass: float,
        inertia: Iterable[float],
        mixer: Mixer,
        dt: float,
    ) -> None:
        self.gains = gains
        self.mass = mass
        self.inertia = tuple(float(i) for i in inertia)
        self.mixer = mixer
        self.dt = dt
        rate, vel = gains.rate, gains.velocity
        #: per body axis (kp, ki, kd, integral limit) of the rate loop
        self._rate_axes = tuple(zip(rate.kp, rate.ki, rate.kd, _integral_limits(rate.integral_limit, rate.ki)))
        self._rate_derivative = any(k != 0.0 for k in rate.kd)  # with kd = 0 the term is left out
        jx, jy, jz = self.inertia
        #: gyroscopic coefficients of omega x (J omega): (Jz - Jy, Jx - Jz, Jy - Jx)
        self._gyro = (jz - jy, jx - jz, jy - jx)
        #: (horizontal, up, down) acceleration the thrust margin allows [m/s^2]
        self.authority = velocity_authority(mixer.max_collective, mass, vel.max_tilt)
        horizontal, up, down = self.authority
        # per ground axis (low, high) saturation of the acceleration command: the integral's
        # bound unless integral_limit gives one
        bounds: tuple[tuple[float, float], ...] = ((-horizontal, horizontal), (-horizontal, horizontal), (-down, up))
        if vel.integral_limit is not None:
            bounds = tuple((-lim, lim) for lim in vel.integral_limit)
        #: per ground axis (kp, ki, lowest and highest integral term) of the velocity loop
        self._velocity_axes = tuple((kp, ki, lo, hi) for kp, ki, (lo, hi) in zip(vel.kp, vel.ki, bounds))
        # the gains the outer loops read at every tick, as plain floats
        self._window = vel.integral_window if vel.integral_window is not None else math.inf
        self._max_tilt = vel.max_tilt
        self._position_kp, self._max_velocity = tuple(gains.position.kp), tuple(gains.position.max_velocity)
        self._attitude_kp, self._max_rate = tuple(gains.attitude.kp), tuple(gains.attitude.max_rate)
        # attitude at which the mixer's side force per newton of thrust (a tilted tail's) and
        # the thrust add up to a force along body z of the level frame: (roll, pitch) trim
        fx, fy = mixer.side_force
        self._trim = (math.atan(fy), -math.atan(fx)) if (fx or fy) else None
        #: (roll, pitch) [rad] a level hover needs: the trim above, else (0, 0)
        self.trim = self._trim or (0.0, 0.0)
        self.mode: FlightMode = resolve_mode(gains.mode)
        self.law: Callable[[KinematicState, Sequence[float]], list[float]]
        self._select(self.mode)
        self.reset()

    def reset(self) -> None:
        """Clear integrators and derivative memory (on spawn, reset and mode change)."""
        self._rate_integral: Sequence[float] = (0.0, 0.0, 0.0)
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

    def __call__(self, state: KinematicState, setpoint: Sequence[float]) -> list[float]:
        """Motor throttles for the current mode and setpoint."""
        return self.law(state, setpoint)

    # ------------------------------------------------------------------ loops

    def _rate_loop(self, state: KinematicState, rates_sp: Sequence[float]) -> tuple[float, float, float]:
        """Body torques [N m] that drive the body rates to ``rates_sp`` [rad/s].

        Per axis: ``e = sp - omega``; ``I = clip(I + e dt, limit)``;
        ``alpha = kp e + ki I - kd (omega - omega_prev) / dt``; the torque is ``J alpha``
        plus the gyroscopic feed-forward ``omega x (J omega)``.
        """
        dt = self.dt
        rates = state.ang_vel
        previous = self._prev_rate or rates
        self._prev_rate = rates
        derivative = self._rate_derivative
        integrals, alphas = [], []
        for (kp, ki, kd, limit), sp, w, w_prev, i in zip(
            self._rate_axes, rates_sp, rates, previous, self._rate_integral
        ):
            e = sp - w
            i += e * dt
            i = limit if i > limit else -limit if i < -limit else i  # _clamp(i, limit)
            integrals.append(i)
            alphas.append(kp * e + ki * i - kd * (w - w_prev) / dt if derivative else kp * e + ki * i)
        self._rate_integral = integrals
        (jx, jy, jz), (gx, gy, gz) = self.inertia, self._gyro
        (ax, ay, az), (wx, wy, wz) = alphas, rates
        return jx * ax + gx * wy * wz, jy * ay + gy * wz * wx, jz * az + gz * wx * wy

    def _velocity_loop(self, state: KinematicState, velocity_sp: Sequence[float | None]) -> list[float]:
        """Ground-frame accelerations [m/s^2] that drive the ground velocity to ``velocity_sp``.

        Per axis with a setpoint (None: 0, not integrated): ``e = sp - v``;
        ``a = kp e + ki I``.  ``I`` integrates ``e dt`` unless ``a`` would pass the axis's
        saturation ``[lo, hi]`` (:func:`velocity_authority`, or ``integral_limit``) with
        ``e`` pushing it further (conditional integration: the integrator keeps working
        while the error is large, and stops only where the airframe cannot follow), and
        ``ki I`` is kept within ``[lo, hi]``.  With ``integral_window`` set it integrates
        only while ``|e|`` is below it as well.
        """
        window, dt = self._window, self.dt
        out = []
        integrals = []
        axes = zip(self._velocity_axes, velocity_sp, state.lin_vel_ground, self._vel_integral)
        for (kp, ki, lo, hi), sp, v, i in axes:
            if sp is None:
                out.append(0.0)
            else:
                e = sp - v
                if ki > 0.0 and -window < e < window:
                    trial = i + e * dt
                    a = kp * e + ki * trial
                    if not ((a > hi and e > 0.0) or (a < lo and e < 0.0)):
                        term = ki * trial
                        i = hi / ki if term > hi else lo / ki if term < lo else trial
                out.append(kp * e + ki * i)
            integrals.append(i)
        self._vel_integral = integrals
        return out

    def _climb(self, state: KinematicState, z: float) -> float:
        """Climb-rate setpoint [m/s] from an altitude setpoint: ``clip(kp_z (z - z_now))``."""
        return _clamp(self._position_kp[2] * (z - state.lin_pos[2]), self._max_velocity[2])

    def _thrust_for(self, state: KinematicState, az: float) -> float:
        """Collective thrust [N] for vertical acceleration ``az``, tilt-compensated:
        ``max(m (g + az) / max(cos(roll) cos(pitch), 0.5), 0)``."""
        roll, pitch, _ = state.ang_pos
        tilt = math.cos(roll) * math.cos(pitch)
        tilt = 0.5 if 0.5 > tilt else tilt  # max(tilt, 0.5)
        thrust = self.mass * (GRAVITY + az) / tilt
        return 0.0 if 0.0 > thrust else thrust  # max(thrust, 0.0)

    def _attitude_rates(
        self, state: KinematicState, roll: float, pitch: float, yaw: float | None, yaw_rate: float
    ) -> tuple[float, float, float]:
        """Body-rate setpoint from an attitude setpoint (yaw None: hold ``yaw_rate``):
        ``clip(kp (angle_sp - angle))`` per axis, the yaw error wrapped to [-pi, pi) as
        :func:`~pyflyt_engine.frames.wrap_angle` does."""
        (kx, ky, kz), (lx, ly, lz) = self._attitude_kp, self._max_rate
        roll_now, pitch_now, yaw_now = state.ang_pos
        p = kx * (roll - roll_now)
        q = ky * (pitch - pitch_now)
        r = yaw_rate if yaw is None else kz * ((yaw - yaw_now + math.pi) % _TWO_PI - math.pi)
        return (
            lx if p > lx else -lx if p < -lx else p,  # _clamp(p, lx), and so on
            ly if q > ly else -ly if q < -ly else q,
            lz if r > lz else -lz if r < -lz else r,
        )

    def _tilt_for(self, state: KinematicState, ax: float, ay: float, az: float) -> tuple[float, float]:
        """Roll and pitch [rad] that point the thrust along a ground-frame acceleration:
        ``pitch = atan2(forward, lift)``, ``roll = atan2(-left cos(pitch), lift)`` with
        ``lift = max(g + az, 0.1 g)`` and (forward, left) the acceleration in the heading
        frame, both clipped to ``max_tilt``.  With tilted thrust (a tricopter's tail) the
        trim attitude that cancels the mixer's side force is added first."""
        yaw = state.ang_pos[2]
        cy, sy = math.cos(yaw), math.sin(yaw)
        forward = cy * ax + sy * ay
        left = -sy * ax + cy * ay
        lift = GRAVITY + az
        lift = _MIN_LIFT if _MIN_LIFT > lift else lift  # max(g + az, 0.1 g)
        pitch = math.atan2(forward, lift)
        roll = math.atan2(-left * math.cos(pitch), lift)
        if self._trim is not None:
            roll, pitch = roll + self._trim[0], pitch + self._trim[1]
        limit = self._max_tilt
        return (
            limit if roll > limit else -limit if roll < -limit else roll,  # _clamp(roll, limit)
            limit if pitch > limit else -limit if pitch < -limit else pitch,
        )

    # ------------------------------------------------------------------ laws

    def _motors(self, state: KinematicState, setpoint: Sequence[float]) -> list[float]:
        return [float(s) for s in setpoint]

    def _rates_thrust(self, state: KinematicState, setpoint: Sequence[float]) -> list[float]:
        """[p, q, r, thrust fraction]: the rate loop, thrust as a fraction of the full collective."""
        a, b, c, d = setpoint
        return self.mixer.throttles(d * self.mixer.max_collective, *self._rate_loop(state, (a, b, c)))

    def _rates_z(self, state: KinematicState, setpoint: Sequence[float]) -> list[float]:
        """[p, q, r, z]: the rate loop, and the altitude through the vertical velocity loop."""
        a, b, c, d = setpoint
        az = self._velocity_loop(state, (None, None, self._climb(state, d)))[2]
        torques = self._rate_loop(state, (a, b, c))
        return self.mixer.throttles(self._thrust_for(state, az), *torques)

    def _attitude(self, state: KinematicState, setpoint: Sequence[float]) -> list[float]:
        """[roll, pitch, yaw, vz or z]: attitude and rate loops, the vertical velocity loop."""
        a, b, c, d = setpoint
        vz = d if self.mode.name == "attitude_vz" else self._climb(state, d)
        az = self._velocity_loop(state, (None, None, vz))[2]
        torques = self._rate_loop(state, self._attitude_rates(state, a, b, c, 0.0))
        return self.mixer.throttles(self._thrust_for(state, az), *torques)

    def _translate(self, state: KinematicState, setpoint: Sequence[float]) -> list[float]:
        """Translational modes: a ground velocity setpoint (from a heading-frame velocity, a
        position or given), a yaw target or rate, and a climb rate or altitude, through the
        velocity, tilt, attitude and rate loops.  Position to velocity: ``clip(kp (x_sp - x))``."""
        rates, thrust = self._translate_command(state, setpoint)
        return self.mixer.throttles(thrust, *self._rate_loop(state, rates))

    def hover_command(
        self, state: KinematicState, position: Sequence[float], yaw: float
    ) -> tuple[tuple[float, float, float], float, float]:
        """What the translational loops ask to hold ``position`` [m] at ``yaw`` [rad]:
        (body-rate setpoint [rad/s], collective thrust [N], climb rate [m/s]).  Runs the
        velocity loop (its integrator advances): call it on a controller of its own, once
        per control period, as :func:`pyflyt_engine.flight.fly` does to steer the default
        setpoint of modes that hold no position themselves."""
        x, y, z = position
        rates, thrust = self._translate_command(state, (x, y, yaw, z))
        return rates, thrust, self._climb(state, z)

    def _translate_command(
        self, state: KinematicState, setpoint: Sequence[float]
    ) -> tuple[tuple[float, float, float], float]:
        """The body-rate setpoint and collective thrust of :meth:`_translate`."""
        yaw_is_rate, heading_frame, position, altitude = self._translational  # type: ignore[misc]
        a, b, c, d = setpoint
        x, y, z = state.lin_pos
        (kx, ky, kz), (lx, ly, lz) = self._position_kp, self._max_velocity
        if heading_frame:
            heading = state.ang_pos[2]
            ch, sh = math.cos(heading), math.sin(heading)
            vx, vy = ch * a - sh * b, sh * a + ch * b
        elif position:
            vx, vy = kx * (a - x), ky * (b - y)
            vx = lx if vx > lx else -lx if vx < -lx else vx  # _clamp(vx, lx)
            vy = ly if vy > ly else -ly if vy < -ly else vy
        else:
            vx, vy = a, b
        if altitude:
            vz = kz * (d - z)
            vz = lz if vz > lz else -lz if vz < -lz else vz
        else:
            vz = d
        ax, ay, az = self._velocity_loop(state, (vx, vy, vz))
        roll, pitch = self._tilt_for(state, ax, ay, az)
        yaw, yaw_rate = (None, c) if yaw_is_rate else (c, 0.0)
        return self._attitude_rates(state, roll, pitch, yaw, yaw_rate), self._thrust_for(state, az)
