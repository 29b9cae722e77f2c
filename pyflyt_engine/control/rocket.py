"""Rocket autopilot: attitude and velocity hold over a gimballed booster and grid fins.

Offered on any airframe with a booster whose thrust a gimbal vectors (lifting surfaces
driven by channels, e.g. grid fins, are used when present).  Every gain comes from the
airframe: mass and inertia (dry plus the fuel left, at every control tick), the boosters'
thrust range and lag, the gimbals' range and lag, and the fins' geometry, lift slope,
deflection range and lag.  Nothing is tuned per airframe file.

Modes (setpoint layouts; the ground frame is ENU, the body's long axis is body z):

| name | setpoint | meaning |
|---|---|---|
| ``channels`` | the airframe's channels | raw channels (the paper's action) |
| ``attitude_thrust`` | tilt_x, tilt_y, roll_rate, throttle, ignition | lean the long axis by ``hypot(tilt_x, tilt_y)`` [rad] toward the ground direction (tilt_x, tilt_y); roll rate about the long axis [rad/s]; booster throttle [0, 1] (min to max thrust); ignition > 0.5 lights the booster |
| ``velocity`` | vx, vy, vz, ignition | hold a ground velocity [m/s]; ignition > 0.5 lets the autopilot light the booster (the rule below), <= 0.5 keeps it out |
| ``descent`` | vx, vy, descent, ignition | hold a ground velocity horizontally [m/s] and descend on a braking envelope of ``descent`` times the full-thrust deceleration (below); the autopilot lights the booster for the vertical loop and pulses it to aim (the rule below) |

**Attitude loop** (both modes).  The attitude error is the rotation that takes the long
axis ``u`` onto the target axis ``t``: about ``u x t`` (in the body frame) by the angle
between them.  Per body axis x, y the rate setpoint is

    w_sp = sign(e) min(k_att |e|, sqrt(alpha_avail |e|))

(the second term is the braking curve of half the available angular acceleration,
``sqrt(2 (alpha_avail / 2) |e|)``, so a large error is met at a rate the actuators can
stop), and about z it is the roll-rate setpoint.  The rate loop asks for the moment
``M = J k_rate (w_sp - w)`` (J: the inertia with the fuel left).

**Allocation.**  Each control channel has a moment per unit command, evaluated at this
tick: a gimbal axis ``max_angle T r x (a x t)`` (thrust T of its booster, thrust point r
from the centre of mass, rotation axis a, thrust axis t; the small-angle form of the
nozzle's turn), a fin channel ``sum_s w_s max_deflection_s Q_s S_s dC_L/d(delta)_s
(p_s x n_s)`` over the surfaces it drives (weight w_s, position p_s, normal n_s, area S_s,
lift per radian of deflection ``C_La tau_f eta`` as in
:mod:`pyflyt_engine.components.lifting_surface`, dynamic pressure ``Q_s`` of the flow
along its chord, zero in reverse flow).  With these columns as ``B`` (3 x k) the commands
are the damped least-squares solution ``B^T (B B^T + lambda I)^-1 M`` (lambda = 1 N^2 m^2,
so an axis without authority, e.g. roll at rest, asks nothing), clipped to the channels'
ranges.  ``alpha_avail`` per axis is ``sum_j |B_ij| / J_i``.

**Gains** from the actuators' lags: with ``tau_eff`` the authority-weighted mean lag of the
channels in use (``sum_j |B_j| tau_j / sum_j |B_j|``) plus one control period,
``k_rate = 1 / (2 tau_eff)`` (crossover well below the lag's corner) and
``k_att = k_rate / 4``.  For the shipped Rocket: gimbal and booster lag 0.01 s, fins
0.05 s, so ``k_rate`` runs from 8.6 /s (fins only) to 27 /s (gimbal only).

**Velocity loop** (mode ``velocity``): ``a = (k_h (vx_sp - vx), k_h (vy_sp - vy), k_v (vz_sp - vz)) - d / m``
with ``k_h = k_att,slow / 6`` (a sixth of the slowest attitude loop, that of the slowest
actuator: 0.36 /s for the shipped Rocket; a third of it limit-cycles with a full tank,
whose gimbal gives only 0.36 rad/s^2), ``k_v = 1 / (4 (tau_booster + dt))`` (the
booster's thrust follows its command through its own lag only; 13.6 /s) and ``d`` the
body drag at the current velocity (feed-forward; still air).  The specific force
``f = a + g z_hat`` (its
vertical part at least 0.1 g, its lean at most :data:`MAX_TILT`) sets the target axis,
and the thrust asked is ``T = m f_z / max(u_z, 0.5)`` (the vertical part held as the
long axis tilts), throttle ``(T - T_min) / (T_max - T_min)`` clipped to [0, 1].

**Ignition rule** (mode ``velocity``): the booster is lit when the setpoint's ignition is
above 0.5, there is fuel, and the thrust asked is at least half the minimum thrust: the
booster gives either nothing or at least ``T_min``, and this picks the nearer.  Where
``T_min`` exceeds the weight (the shipped Rocket with little fuel) holding a speed
becomes pulsing at the control rate; with more fuel than ``T_min / g`` it hovers on
continuous thrust, the throttle falling as the fuel burns.

**Descent mode** (``descent``): the velocity loop above with a vertical setpoint that
scales with the height, so a constant command lands:

    vz_sp = -max(v_floor, sqrt(2 descent a_max max(h - h_floor, 0)))

the descent speed from which braking at ``descent`` times ``a_max = T_max / m - g`` (the
deceleration the boosters give at full thrust with the fuel left: 43.7 m/s^2 for the
shipped Rocket with 1 % fuel) stops at ``h_floor`` = :data:`FLOOR_HEIGHT`, below which it
is ``v_floor`` = :data:`TOUCHDOWN_SPEED`.  ``h`` is the height of the airframe's lowest
collision point above the ground plane (z = 0) when upright (the centre of mass's height
for mesh or URDF geometry).  ``descent`` in (0, 1]: any constant value lands (fuel
permitting) at ``v_floor``; 2/3 brakes at 29 m/s^2 leaving a third of the thrust for the
lean and the lag, 1 leaves none; 0 descends at ``v_floor`` all the way.
Horizontal velocity changes need thrust, and in a fall above the envelope the vertical
loop asks for none: there the autopilot **pulses to aim**.  While the ignition is
permitted, the vehicle falls faster than :data:`AIM_FALL` and the vertical loop leaves the
booster out, one control period at minimum thrust is fired whenever the horizontal
velocity error exceeds :data:`AIM_ERROR` and the long axis (which the attitude loop leans
toward that error) leans its way by more than :data:`AIM_LEAN` (the sine of the lean
along the error).

All of it is Python floats (``math``), no NumPy on the per-tick path.
"""

# ruff: noqa: FURB136

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from pyflyt_engine.assembly import Assembly
from pyflyt_engine.components.booster import Boosters
from pyflyt_engine.constants import AIR_DENSITY, GRAVITY
from pyflyt_engine.control.modes import FlightMode
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.frames import quaternion_to_rows
from pyflyt_engine.state import KinematicState

#: largest lean of the long axis from vertical the velocity mode asks [rad] (20 deg): the
#: attitude modes take any lean up to 90 deg
MAX_TILT = 0.35
#: Tikhonov damping of the allocation [N^2 m^2] (see the module docstring)
_DAMPING = 1.0
_MIN_LIFT = 0.1 * GRAVITY
#: mode ``descent``: the envelope's floor [m/s] (well under the landing task's 1 m/s limit:
#: with minimum thrust above the weight, holding it is pulsing, ~0.1 m/s of ripple)
TOUCHDOWN_SPEED = 0.4
#: mode ``descent``: the height above the ground [m] below which the envelope is its floor
FLOOR_HEIGHT = 1.0
#: mode ``descent``, aim pulses: the horizontal velocity error [m/s], the sine of the lean
#: along it and the fall speed [m/s] above which a pulse is fired
AIM_ERROR = 0.2
AIM_LEAN = 0.15
AIM_FALL = 5.0

ROCKET_MODES: dict[str, FlightMode] = {
    m.name: m
    for m in (
        FlightMode("channels", None, ("channels",), "raw control channels (the paper's action)"),
        FlightMode(
            "attitude_thrust",
            None,
            ("tilt_x", "tilt_y", "roll_rate", "throttle", "ignition"),
            "rocket: lean of the long axis [rad], roll rate [rad/s], booster throttle and ignition",
        ),
        FlightMode(
            "velocity",
            None,
            ("vx", "vy", "vz", "ignition"),
            "rocket: ground velocity [m/s] by thrust vectoring and fins; ignition > 0.5 lets the autopilot light the booster",
        ),
        FlightMode(
            "descent",
            None,
            ("vx", "vy", "descent", "ignition"),
            "rocket: ground velocity [m/s] sideways, descent on a braking envelope at this fraction of the "
            "full-thrust deceleration; the autopilot pulses the booster to aim",
        ),
    )
}


def _cross(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, float]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _solve3(m: list[list[float]], v: Sequence[float]) -> tuple[float, float, float]:
    """``m^-1 v`` for a symmetric positive definite 3 x 3 ``m`` (Cramer's rule, floats)."""
    (a, b, c), (d, e, f), (g, h, i) = m
    co0, co1, co2 = e * i - f * h, f * g - d * i, d * h - e * g
    det = a * co0 + b * co1 + c * co2
    x, y, z = v
    return (
        (x * co0 + y * (c * h - b * i) + z * (b * f - c * e)) / det,
        (x * co1 + y * (a * i - c * g) + z * (c * d - a * f)) / det,
        (x * co2 + y * (b * g - a * h) + z * (a * e - b * d)) / det,
    )


def has_rocket_modes(parts: Assembly) -> bool:
    """Whether the airframe has a booster a gimbal vectors (what the rocket modes need)."""
    return parts.boosters is not None and any(kind == "booster" for kind, _ in parts.gimbal_targets)


class RocketAutopilot:
    """Maps a rocket-mode setpoint to the channel vector (see the module docstring).

    Args:
        parts: the airframe's :class:`~pyflyt_engine.assembly.Assembly`.
        boosters: the vehicle's booster group (fuel and duty are read at every tick).
        dt: control period [s].
        drag_factors: the body drag's ``1/2 rho C_d A`` per body axis [kg/m] (zeros without
            drag), for the velocity loop's feed-forward.
    """

    def __init__(
        self, parts: Assembly, boosters: Boosters, dt: float, drag_factors: Sequence[float] = (0.0, 0.0, 0.0)
    ) -> None:
        if not has_rocket_modes(parts):
            raise ConfigError("the rocket modes need a booster vectored by a gimbal ('gimbals: target: booster:<i>')")
        b = parts.boosters
        assert b is not None and parts.gimbals is not None
        self.dt, self.boosters, self.n = dt, boosters, len(parts.channels)
        self.drag_factors = tuple(float(k) for k in drag_factors)
        self.low, self.high = parts.channel_low.tolist(), parts.channel_high.tolist()
        self._dry_mass = float(parts.mass)
        self._dry_inertia = [float(parts.inertia[i][i]) for i in range(3)]
        self._tanks = [tuple(r) for r in b.fuel_tank_positions.tolist()]
        self._total_fuel = b.total_fuel.tolist()
        self._inertia_full = [tuple(j) for j in b.inertia_full.tolist()]
        self._min_thrust, self._max_thrust = b.min_thrust.tolist(), b.max_thrust.tolist()
        self.min_thrust, self.max_thrust = math.fsum(self._min_thrust), math.fsum(self._max_thrust)
        self._ignition = parts.ignition_index.tolist()
        self._throttle = parts.throttle_index.tolist()
        booster_lag = max(b.tau.tolist())
        # gimbal channels: (channel, booster, moment per newton of that booster's thrust at full command, lag)
        g = parts.gimbals
        gimbal_columns = []
        used = set(self._ignition) | set(self._throttle)
        for k, (kind, index) in enumerate(parts.gimbal_targets):
            if kind != "booster":
                continue
            r, t = b.positions[index].tolist(), b.thrust_axes[index].tolist()
            for axis, limit, channel in (
                (g.axis_a[k], g.max_angle_a[k], parts.gimbal_channels[k][0]),
                (g.axis_b[k], g.max_angle_b[k], parts.gimbal_channels[k][1]),
            ):
                if channel < 0 or float(limit) == 0.0:
                    continue
                arm = _cross(r, _cross(axis.tolist(), t))
                gimbal_columns.append((int(channel), index, tuple(float(limit) * x for x in arm), float(g.tau[k])))
                used.add(int(channel))
        self._gimbal_columns = tuple(gimbal_columns)
        # fin channels: (channel, per surface (weight x max deflection x S x dC_L/d delta x (p x n), chord axis), lag)
        fin_columns = []
        for c in range(self.n):
            if c in used:
                continue
            terms, lag = [], 0.0
            for s, surface in enumerate(parts.surfaces):
                weight = float(parts.surface_mix[s][c])
                if weight == 0.0:
                    continue
                sc = surface.constants
                arm = _cross((sc.px, sc.py, sc.pz), (sc.nx, sc.ny, sc.nz))
                gain = weight * sc.max_deflection * sc.area * sc.delta_cl_per_rad * 0.5 * AIR_DENSITY
                terms.append((tuple(gain * x for x in arm), (sc.cx, sc.cy, sc.cz)))
                lag = max(lag, surface.tau)
            if terms:
                fin_columns.append((c, tuple(terms), lag))
        self._fin_columns = tuple(fin_columns)
        lags = [lag for *_, lag in self._gimbal_columns] + [lag for *_, lag in self._fin_columns]
        slowest = max(lags) + dt
        #: velocity-loop gains [1/s]: horizontal (a sixth of the slowest attitude loop), vertical
        self.k_horizontal = 1.0 / (2.0 * slowest) / 4.0 / 6.0
        self.k_vertical = 1.0 / (4.0 * (booster_lag + dt))
        #: the lowest collision point below the centre of mass [m] (mode descent's height)
        self.lowest_point = float(parts.lowest_point) if parts.lowest_point is not None else 0.0
        self._mode = "channels"
        self.reset()

    def reset(self) -> None:
        """Nothing to clear: the laws hold no integrators."""

    # ---------------------------------------------------------------- helpers

    def mass_properties(self) -> tuple[float, tuple[float, float, float]]:
        """Mass [kg] and inertia diagonal [kg m^2] with the fuel left: the dry airframe, each
        tank's fuel, its inertia scaled by the fuel fraction and the parallel-axis terms
        (as the vehicle sets them, :meth:`pyflyt_engine.vehicle.Vehicle.update_mass`)."""
        mass = self._dry_mass
        jx, jy, jz = self._dry_inertia
        for fuel, total, (rx, ry, rz), (fx, fy, fz) in zip(
            self.boosters.fuel, self._total_fuel, self._tanks, self._inertia_full
        ):
            share = fuel / total
            mass += fuel
            jx += share * fx + fuel * (ry * ry + rz * rz)
            jy += share * fy + fuel * (rx * rx + rz * rz)
            jz += share * fz + fuel * (rx * rx + ry * ry)
        return mass, (jx, jy, jz)

    def throttle_for(self, thrust: float) -> float:
        """The throttle in [0, 1] at which the lit boosters give ``thrust`` [N] in all."""
        span = self.max_thrust - self.min_thrust
        if span <= 0.0:
            return 1.0
        x = (thrust - self.min_thrust) / span
        return 0.0 if x < 0.0 else 1.0 if x > 1.0 else x

    def _channels(
        self,
        state: KinematicState,
        target: Sequence[float],
        roll_rate: float,
        lit: bool,
        throttle: float,
        inertia: Sequence[float],
    ) -> list[float]:
        """The channel vector: the booster commands, and the attitude loop's gimbal and fin
        commands that turn the long axis onto ``target`` (ground frame, unit)."""
        out = [0.0] * self.n
        for i in self._ignition:
            out[i] = 1.0 if lit else 0.0
        for i in self._throttle:
            out[i] = throttle if lit else 0.0
        rows = quaternion_to_rows(state.quaternion)
        up = (rows[0][2], rows[1][2], rows[2][2])
        # error axis u x t in the body frame, scaled to the angle between u and t
        cx, cy, cz = _cross(up, target)
        ex = rows[0][0] * cx + rows[1][0] * cy + rows[2][0] * cz
        ey = rows[0][1] * cx + rows[1][1] * cy + rows[2][1] * cz
        sine = math.sqrt(ex * ex + ey * ey)
        cosine = up[0] * target[0] + up[1] * target[1] + up[2] * target[2]
        angle = math.atan2(sine, cosine)
        if sine > 0.0:
            ex, ey = ex * angle / sine, ey * angle / sine
        # moment columns of this tick: gimbals by their booster's thrust, fins by the flow along their chord
        duty, ignited = self.boosters.duty, self.boosters.ignited
        columns = []
        for channel, index, (mx, my, mz), lag in self._gimbal_columns:
            thrust = duty[index] * self._max_thrust[index]
            if lit and self.boosters.fuel[index] > 0.0:
                commanded = self._min_thrust[index] + throttle * (self._max_thrust[index] - self._min_thrust[index])
                thrust = commanded if commanded > thrust else thrust
            elif not ignited[index]:
                thrust = 0.0
            columns.append((channel, (thrust * mx, thrust * my, thrust * mz), lag))
        u, v, w = state.lin_vel
        for channel, terms, lag in self._fin_columns:
            mx = my = mz = 0.0
            for (gx, gy, gz), (ax, ay, az) in terms:
                along = u * ax + v * ay + w * az
                if along > 0.0:
                    q = along * along
                    mx, my, mz = mx + q * gx, my + q * gy, mz + q * gz
            columns.append((channel, (mx, my, mz), lag))
        # gains from the authority-weighted lag, available angular acceleration per axis, and
        # the allocation's Gram matrix B B^T + lambda I (its six distinct entries)
        total = weighted = ax = ay = 0.0
        gxx = gyy = gzz = _DAMPING
        gxy = gxz = gyz = 0.0
        for _, (mx, my, mz), lag in columns:
            size = math.sqrt(mx * mx + my * my + mz * mz)
            total += size
            weighted += size * lag
            ax += abs(mx)
            ay += abs(my)
            gxx, gyy, gzz = gxx + mx * mx, gyy + my * my, gzz + mz * mz
            gxy, gxz, gyz = gxy + mx * my, gxz + mx * mz, gyz + my * mz
        if total == 0.0:
            return out
        jx, jy, jz = inertia
        k_rate = 1.0 / (2.0 * (weighted / total + self.dt))
        k_att = k_rate / 4.0
        p, q, r = state.ang_vel
        rates = []
        for e, a, j in ((ex, ax, jx), (ey, ay, jy)):
            linear = k_att * abs(e)
            braking = math.sqrt(a / j * abs(e))
            rate = linear if linear < braking else braking
            rates.append(rate if e >= 0.0 else -rate)
        moment = (jx * k_rate * (rates[0] - p), jy * k_rate * (rates[1] - q), jz * k_rate * (roll_rate - r))
        y0, y1, y2 = _solve3([[gxx, gxy, gxz], [gxy, gyy, gyz], [gxz, gyz, gzz]], moment)
        low, high = self.low, self.high
        for channel, (mx, my, mz), _ in columns:
            value = mx * y0 + my * y1 + mz * y2
            lo, hi = low[channel], high[channel]
            out[channel] = lo if value < lo else hi if value > hi else value
        return out

    # ------------------------------------------------------------------- laws

    def attitude_thrust(self, state: KinematicState, setpoint: Sequence[float]) -> list[float]:
        """[tilt_x, tilt_y, roll_rate, throttle, ignition]: the target axis leans by
        ``theta = min(hypot(tilt_x, tilt_y), pi/2)`` toward (tilt_x, tilt_y)."""
        tx, ty, roll_rate, throttle, ignition = setpoint
        lean = math.sqrt(tx * tx + ty * ty)
        theta = lean if lean < 0.5 * math.pi else 0.5 * math.pi
        s = math.sin(theta) / lean if lean > 0.0 else 0.0
        target = (tx * s, ty * s, math.cos(theta))
        throttle = 0.0 if throttle < 0.0 else 1.0 if throttle > 1.0 else throttle
        return self._channels(state, target, roll_rate, ignition > 0.5, throttle, self.mass_properties()[1])

    def velocity_command(
        self, state: KinematicState, setpoint: Sequence[float]
    ) -> tuple[tuple[float, float, float], float, bool]:
        """What mode ``velocity`` asks: (target axis, ground frame; thrust [N]; lit)."""
        vx_sp, vy_sp, vz_sp, ignition = setpoint
        vx, vy, vz = state.lin_vel_ground
        mass, _ = self.mass_properties()
        # the body drag's acceleration, cancelled by feed-forward (still air; wind is a disturbance)
        kx, ky, kz = self.drag_factors
        u, v, w = state.lin_vel
        dx, dy, dz = -kx * u * abs(u), -ky * v * abs(v), -kz * w * abs(w)
        rows = quaternion_to_rows(state.quaternion)
        drag = [(r[0] * dx + r[1] * dy + r[2] * dz) / mass for r in rows]
        kh = self.k_horizontal
        ax, ay = kh * (vx_sp - vx) - drag[0], kh * (vy_sp - vy) - drag[1]
        fz = GRAVITY + self.k_vertical * (vz_sp - vz) - drag[2]
        fz = _MIN_LIFT if fz < _MIN_LIFT else fz
        # the lean at most MAX_TILT: the horizontal part at most fz tan(MAX_TILT)
        horizontal = math.sqrt(ax * ax + ay * ay)
        limit = fz * math.tan(MAX_TILT)
        if horizontal > limit:
            ax, ay = ax * limit / horizontal, ay * limit / horizontal
        size = math.sqrt(ax * ax + ay * ay + fz * fz)
        target = (ax / size, ay / size, fz / size)
        x, y = state.quaternion[0], state.quaternion[1]
        uz = 1.0 - 2.0 * (x * x + y * y)  # the long axis's vertical component
        thrust = mass * fz / (uz if uz > 0.5 else 0.5)
        fuel = any(f > 0.0 for f in self.boosters.fuel)
        lit = ignition > 0.5 and fuel and thrust >= 0.5 * self.min_thrust
        return target, thrust, lit

    def velocity(self, state: KinematicState, setpoint: Sequence[float]) -> list[float]:
        """[vx, vy, vz, ignition]: the velocity loop, the ignition rule, the attitude loop."""
        target, thrust, lit = self.velocity_command(state, setpoint)
        return self._channels(state, target, 0.0, lit, self.throttle_for(thrust), self.mass_properties()[1])

    def envelope_speed(self, state: KinematicState, descent: float) -> float:
        """Mode ``descent``'s braking envelope at this state: the descent speed [m/s] the
        setpoint ``descent`` asks (the module docstring)."""
        mass, _ = self.mass_properties()
        a = descent * (self.max_thrust / mass - GRAVITY)
        h = state.lin_pos[2] + self.lowest_point - FLOOR_HEIGHT
        speed = math.sqrt(2.0 * a * h) if h > 0.0 and a > 0.0 else 0.0
        return speed if speed > TOUCHDOWN_SPEED else TOUCHDOWN_SPEED

    def descent(self, state: KinematicState, setpoint: Sequence[float]) -> list[float]:
        """[vx, vy, descent, ignition]: the velocity loop on the envelope, aim pulses in the fall."""
        vx_sp, vy_sp, descent, ignition = setpoint
        vz_sp = -self.envelope_speed(state, descent)
        target, thrust, lit = self.velocity_command(state, (vx_sp, vy_sp, vz_sp, ignition))
        vx, vy, vz = state.lin_vel_ground
        if not lit and ignition > 0.5 and vz < -AIM_FALL and any(f > 0.0 for f in self.boosters.fuel):
            mx, my = vx_sp - vx, vy_sp - vy
            miss = math.sqrt(mx * mx + my * my)
            if miss > AIM_ERROR:
                x, y, z, w = state.quaternion
                up_x, up_y = 2.0 * (x * z + w * y), 2.0 * (y * z - w * x)  # the long axis, ground x and y
                if (up_x * mx + up_y * my) / miss > AIM_LEAN:
                    lit, thrust = True, self.min_thrust
        return self._channels(state, target, 0.0, lit, self.throttle_for(thrust), self.mass_properties()[1])

    def __call__(self, state: KinematicState, setpoint: Sequence[float], mode: str) -> np.ndarray:
        """The channel vector for ``mode`` (``attitude_thrust``, ``velocity`` or ``descent``)."""
        law = self.velocity if mode == "velocity" else self.descent if mode == "descent" else self.attitude_thrust
        return np.array(law(state, setpoint), dtype=np.float64)
