"""A battery driving the motors: internal-resistance (Rint) equivalent circuit.

The pack is an ideal voltage source, its open-circuit voltage ``V_oc(q)`` a function of
the state of charge ``q`` (a table, linearly interpolated), in series with a resistance
``R`` (the "Rint" model: Johnson, "Battery performance models in ADVISOR", Journal of
Power Sources 110, 2002; He, Xiong & Fan, "Evaluation of lithium-ion battery equivalent
circuit models for state of charge estimation", Energies 4, 2011, section 2.1)::

    V = V_oc(q) - R I

The load is a power, not a current: the motors' speed controllers draw whatever current
delivers the shaft power ``P_shaft = sum_i Q_i Omega_i`` (reaction torque times rotor
speed, the power a rotor absorbs) at efficiency ``eta``, plus the avionics' constant
``P_av``; power is voltage times current (``P = V I``, the constant-power load on an
equivalent-circuit source, e.g. Chen & Rincon-Mora, "Accurate electrical battery model
capable of predicting runtime and I-V performance", IEEE Trans. Energy Conversion 21(2),
2006).  For a fixed power ``P = P_shaft / eta + P_av`` the terminal voltage is the
high root of ``V^2 - V_oc V + R P = 0``::

    V = (V_oc + sqrt(V_oc^2 - 4 R P)) / 2,      I = P / V

(:func:`terminal_voltage`).  Here the rotors turn at a speed proportional to ``V`` (below),
so their shaft power at given throttles goes as ``V^3``: with ``P_1`` the shaft power at
full voltage, ``P(V) = P_1 (V / V_full)^3 / eta + P_av``, and ``V = V_oc - R P(V) / V``
is solved as a cubic every physics step (:func:`supply`).  Solving for the voltage
consistent with its own load, rather than feeding one step's voltage into the next
step's power, keeps the loop stable: the explicit form oscillates between two voltages
once ``R`` times the power's sensitivity to the voltage is large (a 1S pack at 4 A).
A demand above the most the pack can deliver is met at that maximum.  The charge falls
by Coulomb counting, ``dq/dt = -I / C`` (``C`` in coulombs), one forward-Euler step per
physics step, and stops at 0.

A brushed or brushless motor's speed at a given duty is proportional to its supply
voltage (back-EMF ``k_e Omega`` balances the applied voltage, less the winding's drop;
e.g. Bangura & Mahony, "Thrust control for multirotor aerial vehicles", IEEE Trans.
Robotics 33(2), 2017, section III), so the motors turn at ``x * max_rpm * V / V_full``
with ``V_full = V_oc(1)``: thrust and torque scale with ``(V / V_full)^2``.  The loads of
a physics step use the voltage the previous step solved (they are computed before this
step's power is known): a lag of one physics step, 4 ms at 240 Hz.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from pyflyt_engine.components import AirVelocity
from pyflyt_engine.components.kinds import BuildContext, register
from pyflyt_engine.spec import BatterySpec


@dataclass(frozen=True)
class BatteryParams:
    """Parameters of a battery (see the module docstring).

    Attributes:
        capacity_mah: charge when full [mAh].
        internal_resistance: R [ohm].
        open_circuit_voltage: ((q, V_oc), ...) with q rising from 0 to 1 [-, V].
        efficiency: eta, shaft power over electrical power, in (0, 1].
        avionics_power: P_av [W].
        initial_charge: q at spawn, in (0, 1].
    """

    capacity_mah: float
    internal_resistance: float
    open_circuit_voltage: tuple[tuple[float, float], ...]
    efficiency: float = 1.0
    avionics_power: float = 0.0
    initial_charge: float = 1.0

    @property
    def full_voltage(self) -> float:
        """V_full = V_oc(1) [V]: the supply at which the motors reach ``max_rpm``."""
        return self.open_circuit_voltage[-1][1]


def open_circuit_voltage(table: Sequence[tuple[float, float]], charge: float) -> float:
    """V_oc at state of charge ``charge`` [V]: the table linearly interpolated (held at its ends)."""
    q0, v0 = table[0]
    if charge <= q0:
        return v0
    for q1, v1 in table[1:]:
        if charge <= q1:
            return v0 + (v1 - v0) * (charge - q0) / (q1 - q0)
        q0, v0 = q1, v1
    return v0


def terminal_voltage(ocv: float, resistance: float, power: float) -> float:
    """V for a constant-power load ``power`` [W] on ``ocv`` [V] behind ``resistance`` [ohm]
    (the high root of V^2 - V_oc V + R P = 0; V_oc / 2 beyond the pack's maximum power)."""
    if resistance <= 0.0 or power <= 0.0:
        return ocv
    disc = ocv * ocv - 4.0 * resistance * power
    return 0.5 * (ocv + math.sqrt(disc)) if disc > 0.0 else 0.5 * ocv


class Battery:
    """The state of one vehicle's battery: charge, terminal voltage, current.

    Attributes:
        charge: state of charge q in [0, 1].
        voltage: terminal voltage V [V] after the latest step (V_oc at a reset).
        current: current I [A] of the latest step (0 at a reset).
        speed_ratio: V / V_full, the factor on every rotor's speed at the next step.
    """

    def __init__(self, params: BatteryParams, physics_dt: float) -> None:
        self.physics_dt = physics_dt
        self.set_params(params)
        self.reset()

    def set_params(self, params: BatteryParams) -> None:
        """Use new parameters (e.g. sampled by domain randomisation); the state is kept."""
        self.params = params
        self._table = tuple((float(q), float(v)) for q, v in params.open_circuit_voltage)
        self._full = float(params.full_voltage)
        self._coulombs = params.capacity_mah * 3.6  # 1 mAh = 3.6 C
        self._resistance = float(params.internal_resistance)
        self._efficiency = float(params.efficiency)
        self._avionics = float(params.avionics_power)
        #: what the shaft power at full voltage is divided by to give the load's cubic
        #: coefficient, eta V_full^3 (computed once: the batched backend reads it)
        self._load_divisor = self._efficiency * self._full**3

    def reset(self) -> None:
        """Charge back to ``initial_charge``, no load."""
        self.charge = float(self.params.initial_charge)
        self.voltage = open_circuit_voltage(self._table, self.charge)
        self.current = 0.0
        self.speed_ratio = self.voltage / self._full

    def step(self, full_power: float) -> None:
        """One physics step of the motors' draw: ``full_power`` [W] is the rotors' shaft power
        at the throttles of this step and full voltage (speed ratio 1); it scales with
        ``(V / V_full)^3``.  Sets the voltage, current and charge (the module docstring)."""
        ocv = open_circuit_voltage(self._table, self.charge)
        v, current = supply(ocv, self._resistance, full_power / self._load_divisor, self._avionics)
        charge = self.charge - current * self.physics_dt / self._coulombs
        self.charge = charge if charge > 0.0 else 0.0
        self.voltage = v
        self.current = current
        self.speed_ratio = v / self._full


def supply(ocv: float, resistance: float, cubic: float, constant: float) -> tuple[float, float]:
    """Terminal voltage and current [V, A] of ``ocv`` behind ``resistance`` feeding the load
    ``P(V) = cubic * V^3 + constant`` [W] (the rotors turn at a speed proportional to ``V``).

    ``V = V_oc - R P(V) / V`` is the largest root of ``g(V) = R c V^3 + V^2 - V_oc V + R P_0``,
    found by Newton's method from ``V_oc`` (``g`` is convex for ``V > 0`` and positive at
    ``V_oc``, so the iterates fall monotonically onto that root).  Without a root the load
    asks more than the pack can give: the voltage is then where ``g`` is smallest (``g' = 0``).
    """
    if resistance <= 0.0:
        return ocv, (cubic * ocv**3 + constant) / ocv
    c = resistance * cubic
    r0 = resistance * constant
    v = ocv
    for _ in range(60):
        g = (c * v + 1.0) * v * v - ocv * v + r0
        slope = (3.0 * c * v + 2.0) * v - ocv
        if slope <= 0.0:  # past the minimum of g: no root
            break
        step = g / slope
        v -= step
        if step <= 1e-15 * v:
            return v, (cubic * v**3 + constant) / v
    # no root: the most the pack delivers under this load, at g' = 0
    v = (math.sqrt(4.0 + 12.0 * c * ocv) - 2.0) / (6.0 * c) if c > 0.0 else 0.5 * ocv
    return v, (ocv - v) / resistance


class BatteryGauge:
    """The battery as a group of its vehicle: it reads the pack's state of charge out last
    in the auxiliary state.  The motors own the pack (they draw on it at every physics
    step and reset it with theirs); the gauge commands, steps and resets nothing."""

    needs_air = False
    commanded = False

    def __init__(self, battery: Battery) -> None:
        self.battery = battery

    def route(self, channels: Sequence[float], outputs: Sequence[float] | None = None) -> None:
        """Nothing commands the pack."""

    def step(self, air: AirVelocity, thrust_ratio: Sequence[float] | None = None) -> None:
        """Not stepped (``step_order`` None): the motors step the pack."""

    def reset(self) -> None:
        """The motors reset the pack."""

    def reseed(self) -> None:
        """No noise: nothing to do."""

    def aux(self) -> list[float]:
        """The state of charge, in [0, 1]."""
        return [self.battery.charge]


def build_battery_gauge(ctx: BuildContext) -> BatteryGauge | None:
    """The gauge of the pack the motors' group built (None for an ideal supply)."""
    battery = getattr(ctx.groups.get("motors"), "battery", None)
    return BatteryGauge(battery) if battery is not None else None


# the last group: the charge closes the auxiliary state
register("battery", section="battery", spec=BatterySpec, build=build_battery_gauge, order=70, step_order=None)
