"""Motors with the optional models of a real rotor: asymmetric lag, axial inflow, rotor
drag, and a battery (docs/engine.md, "Motor models").  Off by default: a vehicle whose
airframe declares none of them flies :class:`~pyflyt_engine.components.motor.Motors`
unchanged, and this group replaces it only when one is declared (chosen once, when the
vehicle is built).

**Asymmetric lag.**  The throttle lags its command with time constant ``tau`` while the
rotor speeds up and ``tau_fall`` while it slows down (a rotor speeds up on its motor's
torque and slows down on its aerodynamic drag, less any active braking, so the two
differ).  "Speeding up" is ``x (zeta - x) >= 0``: the command lies beyond the throttle,
away from zero.  Each is the exact zero-order-hold step of its first-order system
(:mod:`pyflyt_engine.components.lag`), so a step response from rest is
``zeta (1 - exp(-t / tau))`` at every physics step.

**Axial inflow** (blade-element momentum theory for a rotor with ideal twist, uniform
inflow; Leishman, "Principles of Helicopter Aerodynamics", 2nd ed., 2006, sections 2.3-2.7
and 3.3).  With ``Omega`` the rotor speed [rad/s], ``R`` its radius, ``V_c`` the hub's
velocity along the thrust axis through the air (climb > 0), and the inflow ratios
``lambda_c = V_c / (Omega R)`` and ``lambda_i`` (induced)::

    C_T = (sigma a / 4) (theta_tip - lambda_c - lambda_i)     blade elements
    C_T = 2 lambda_i (lambda_c + lambda_i)                    momentum theory
    C_Q = C_Q0 + (lambda_c + lambda_i) C_T                    profile + induced and climb power

with ``T = C_T rho pi R^2 (Omega R)^2`` and ``Q = C_Q rho pi R^2 (Omega R)^2 R``.  The
spec's ``kf`` and ``kt`` are the static (hover) values: they give ``C_T0 =
kf / (rho pi R^4 (2 pi / 60)^2)``, the hover inflow ``lambda_h = sqrt(C_T0 / 2)``, the tip
pitch ``theta_tip = C_T0 / (sigma a / 4) + lambda_h`` and the profile torque
``C_Q0 = C_T0 (kt / (kf R) - lambda_h)``.  Eliminating ``lambda_i``::

    2 lambda_i^2 + (2 lambda_c + s) lambda_i - s (theta_tip - lambda_c) = 0,   s = sigma a / 4

(its positive root), and thrust and torque are the static ones times
``C_T / C_T0`` and ``C_Q / C_Q(hover)``: in climb the thrust at a given rotor speed falls,
and in descent it rises.  Momentum theory has no valid solution in the vortex-ring state
(Leishman section 2.13: descent rates between 0 and about ``2 v_h``), so ``lambda_c`` is
held at ``-lambda_h / 2`` (``V_c = -v_h / 2``, about the onset of that state) in faster
descent.  A climb so fast that ``lambda_c >= theta_tip`` gives no thrust (the windmill
brake state is not modelled), and the torque ratio is kept >= 0.

**Rotor drag (H-force)**: a rotor moving edgewise through the air is pushed back by a
force linear in its in-plane air speed and in its rotor speed (blade flapping and the
advancing blade's extra profile drag; Mahony, Kumar & Corke, "Multirotor aerial vehicles:
modeling, estimation, and control of quadrotor", IEEE Robotics & Automation Magazine
19(3), 2012, section "Rotor drag"; Faessler, Franchi & Scaramuzza, "Differential flatness
of quadrotor dynamics subject to rotor drag for accurate tracking of high-speed
trajectories", IEEE RA-L 3(2), 2018, eq. 2)::

    H_i = -c_H,i |x_i| (v_i - (v_i . n_i) n_i)

at hub ``i``, with ``v_i = v + omega x p_i`` the hub's velocity through the air (body
frame; wind and turbulence enter through ``v``), ``n_i`` its thrust axis and ``c_H,i`` the
spec's ``rotor_drag`` at full speed (``|x|`` is the rotor speed over its top speed).  Its
moment ``p_i x H_i`` about the centre of mass is included.

**Battery** (:mod:`pyflyt_engine.components.battery`): every rotor turns at
``x * max_rpm * V / V_full``, the battery's last terminal voltage over its full one, so
thrust and torque scale with ``(V / V_full)^2``; the rotors' shaft power at full voltage,
``sum Q_i Omega_i`` with ``V = V_full``, is then handed to the battery, which solves its
voltage for the next step.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from pyflyt_engine.components import AirVelocity, Wrench
from pyflyt_engine.components.battery import Battery
from pyflyt_engine.components.kinds import BuildContext, register
from pyflyt_engine.components.lag import lag_coefficient
from pyflyt_engine.components.motor import MotorParams, Motors
from pyflyt_engine.components.noise import NoiseSource
from pyflyt_engine.components.routing import MixRow, mix_rows
from pyflyt_engine.constants import AIR_DENSITY
from pyflyt_engine.spec import MotorsSpec

RPM_TO_RAD_S = 2.0 * math.pi / 60.0  # 1 RPM in rad/s
_STILL: AirVelocity = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))


class InflowRotor:
    """The inflow model of one rotor (the module docstring): its constants from the static
    coefficients, and :meth:`ratios` at an inflow ratio.

    Args:
        kf: static thrust coefficient [N / RPM^2]; kt: static torque coefficient [N m / RPM^2].
        radius: R [m]; solidity: sigma; lift_slope: a [1/rad].
    """

    def __init__(
        self, kf: float, kt: float, radius: float, solidity: float, lift_slope: float, air_density: float = AIR_DENSITY
    ) -> None:
        self.radius = radius
        self.ct0 = kf / (air_density * math.pi * radius**4 * RPM_TO_RAD_S**2)
        self.lambda_h = math.sqrt(0.5 * self.ct0)
        self.s = 0.25 * solidity * lift_slope
        self.theta_tip = self.ct0 / self.s + self.lambda_h
        #: C_Q / C_T0 in hover: the static torque over the static thrust, per radius
        self.cq_hover = kt / (kf * radius)

    def ratios(self, climb: float, rotor_speed: float) -> tuple[float, float]:
        """(thrust ratio C_T / C_T0, torque ratio C_Q / C_Q(hover)) at axial air speed
        ``climb`` [m/s] (along the thrust) and rotor speed ``rotor_speed`` [rad/s] (> 0)."""
        lc = climb / (rotor_speed * self.radius)
        floor = -0.5 * self.lambda_h
        if lc < floor:
            lc = floor
        s, theta = self.s, self.theta_tip
        if lc >= theta:
            return 0.0, max(0.0, 1.0 - self.lambda_h / self.cq_hover)
        b = 2.0 * lc + s
        li = 0.25 * (math.sqrt(b * b + 8.0 * s * (theta - lc)) - b)
        kt = s * (theta - lc - li) / self.ct0
        if kt < 0.0:
            kt = 0.0
        kq = 1.0 + ((lc + li) * kt - self.lambda_h) / self.cq_hover
        return kt, (kq if kq > 0.0 else 0.0)


class ModelledMotors(Motors):
    """:class:`Motors` with the optional models of the module docstring.

    :meth:`step` takes the air (the body's velocity through the air, body frame) like every
    group; :meth:`set_air` sets it for a :meth:`step` called without it.

    Args:
        params: the motors (with their optional models).
        physics_dt, noise, mix, mixer_outputs: as for :class:`Motors`.
        battery: the battery that drives them (None: an ideal supply).
    """

    def __init__(
        self,
        params: MotorParams,
        physics_dt: float,
        noise: NoiseSource,
        mix: Sequence[MixRow] | None = None,
        mixer_outputs: Sequence[int | None] | None = None,
        battery: Battery | None = None,
    ) -> None:
        self.battery = battery
        super().__init__(params, physics_dt, noise, mix, mixer_outputs)
        self.air: AirVelocity = _STILL

    @property
    def needs_air(self) -> bool:
        """Whether the loads depend on the air (rotor drag or inflow)."""
        return self.params.rotor_drag is not None or self.params.inflow is not None

    def set_params(self, params: MotorParams) -> None:
        super().set_params(params)
        dt = self.physics_dt
        self.lag_fall = (
            [lag_coefficient(dt, float(t)) for t in params.tau_fall.tolist()]
            if params.tau_fall is not None
            else self.lag
        )
        self._rotor_drag = params.rotor_drag.tolist() if params.rotor_drag is not None else None
        self._axes = [tuple(a) for a in params.thrust_axes.tolist()]
        self._omega_max = (params.max_rpm * RPM_TO_RAD_S).tolist()  # [rad/s]
        self._torque_max = [abs(r) for r in self._reaction]  # k_T max_rpm^2 [N m]
        self._inflow = None
        if params.inflow is not None:
            solidity, slope = params.inflow
            assert params.prop_radius is not None  # the spec requires it with inflow
            self._inflow = [
                InflowRotor(kf, kt, r, solidity, slope)
                for kf, kt, r in zip(params.kf.tolist(), params.kt.tolist(), params.prop_radius.tolist())
            ]

    def turn(self, index: int, thrust_axis: Sequence[float]) -> None:
        super().turn(index, thrust_axis)
        self._axes[index] = tuple(float(v) for v in thrust_axis)

    def set_air(self, air: AirVelocity) -> None:
        """The body's velocity through the air for the next :meth:`step`, body frame."""
        self.air = air

    def reset(self) -> None:
        super().reset()
        if self.battery is not None:
            self.battery.reset()

    def step(self, air: AirVelocity | None = None, thrust_ratio: Sequence[float] | None = None) -> Wrench:
        """One physics step with the optional models (the module docstring) in the air
        ``air`` (None: the one last given); returns the motors' wrench about the centre of
        mass, body frame [N, N m]."""
        if air is not None:
            self.air = air
        factors = self._noise.next() if self._noisy else self._ones
        battery = self.battery
        volt = battery.speed_ratio if battery is not None else 1.0  # rotor speed per throttle, relative
        volt2 = volt * volt
        (u, v, w), (p, q, r) = self.air
        inflow, drag = self._inflow, self._rotor_drag
        ratios = thrust_ratio if thrust_ratio is not None else self._ones
        new = []
        fx = fy = fz = tx = ty = tz = 0.0
        power = 0.0
        for i, (x, c, a_up, a_down, z) in enumerate(zip(self.throttle, self.command, self.lag, self.lag_fall, factors)):
            a = a_up if x * (c - x) >= 0.0 else a_down  # speeding up (away from zero) or slowing down
            x = (x + a * (c - x)) * z
            new.append(x)
            ax_, ay_, az_ = self._axes[i]
            px, py, pz = self._positions[i]
            speed = abs(x) * volt  # rotor speed over its top speed
            kt = kq = 1.0
            if inflow is not None or drag is not None:
                # the hub's velocity through the air: v + omega x p (body frame)
                hx, hy, hz = u + q * pz - r * py, v + r * px - p * pz, w + p * py - q * px
                axial = hx * ax_ + hy * ay_ + hz * az_
                if inflow is not None and speed > 0.0:
                    kt, kq = inflow[i].ratios(axial if x >= 0.0 else -axial, speed * self._omega_max[i])
                if drag is not None:
                    k = -drag[i] * speed
                    gx, gy, gz = k * (hx - axial * ax_), k * (hy - axial * ay_), k * (hz - axial * az_)
                    fx, fy, fz = fx + gx, fy + gy, fz + gz
                    tx, ty, tz = tx + (py * gz - pz * gy), ty + (pz * gx - px * gz), tz + (px * gy - py * gx)
            f = x * abs(x) * volt2  # (rotor speed / max_rpm) squared, signed
            thrust = self._max_thrust[i] * f * kt * ratios[i]  # along the axis [N]
            reaction = self._reaction[i] * f * kq  # about the axis [N m]
            gx, gy, gz = thrust * ax_, thrust * ay_, thrust * az_
            fx, fy, fz = fx + gx, fy + gy, fz + gz
            tx += (py * gz - pz * gy) + reaction * ax_
            ty += (pz * gx - px * gz) + reaction * ay_
            tz += (px * gy - py * gx) + reaction * az_
            if battery is not None:  # Q * Omega [W] at full voltage: |x|^3 k_T max_rpm^2 omega_max
                power += self._torque_max[i] * abs(x) * x * x * kq * self._omega_max[i]
        self.throttle = new
        if battery is not None:
            battery.step(power)
        return fx, fy, fz, tx, ty, tz

    def aux(self) -> list[float]:
        """Throttles (the battery's charge is appended by the vehicle, after every group)."""
        return list(self.throttle)


def build_motors(ctx: BuildContext) -> Motors | None:
    """The motors' group of an airframe (None without ``motors``): :class:`ModelledMotors`
    when it declares any of the optional models or a battery (which it builds), else the
    plain :class:`Motors`.  A motor the mixer flies takes the mixer output of its slot."""
    parts = ctx.parts
    if parts.motors is None:
        return None
    slots = {motor: slot for slot, motor in enumerate(parts.mixer_motors)}
    outputs = [slots.get(i) for i in range(parts.motors.count)]
    if parts.motors.modelled or parts.battery is not None:
        battery = Battery(parts.battery, ctx.physics_dt) if parts.battery is not None else None
        return ModelledMotors(parts.motors, ctx.physics_dt, ctx.noise, mix_rows(parts.motor_mix), outputs, battery)
    return Motors(parts.motors, ctx.physics_dt, ctx.noise, mix_rows(parts.motor_mix), outputs)


# the motors are the first group, and the first load of the physics step
register("motors", section="motors", spec=MotorsSpec, build=build_motors, order=10, step_order=10)
