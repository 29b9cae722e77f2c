"""The optional motor models (asymmetric lag, axial inflow, rotor drag) and the battery,
against oracles: exponentials, momentum theory solved independently, the stated drag law,
and the hover throttle of a sagging battery evaluated by hand."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from pyflyt_engine.components.battery import Battery, BatteryParams, open_circuit_voltage
from pyflyt_engine.components.motor import MotorParams, Motors
from pyflyt_engine.components.motor_models import ModelledMotors, RPM_TO_RAD_S
from pyflyt_engine.components.noise import NoiseSource
from pyflyt_engine.constants import AIR_DENSITY, GRAVITY
from pyflyt_engine.errors import SpecError
from pyflyt_engine.paths import uav_dir
from pyflyt_engine.spec import load_uav_spec
from pyflyt_engine.world import World
from tests.conftest import spec_dict, spec_variant
from tests.engine.vehicle_checks import NO_STAGES, shadowed_methods

DT = 1.0 / 240.0
EXAMPLE = uav_dir() / "examples" / "quadx_cf2x_battery.yaml"


def _params(**extra) -> MotorParams:
    angles = np.arange(4) * math.pi / 2 + math.pi / 4
    values = dict(
        positions=np.stack([np.cos(angles), np.sin(angles), np.zeros(4)], axis=1) * 0.04,
        thrust_axes=np.tile([0.0, 0.0, 1.0], (4, 1)),
        spin=np.array([1.0, -1.0, 1.0, -1.0]),
        tau=0.01,
        max_rpm=40000.0,
        kf=3.16e-10,
        kt=7.94e-12,
        noise_ratio=0.0,
    )
    return MotorParams(**{**values, **extra})


def _group(params: MotorParams, throttle: float, command: float, battery: Battery | None = None) -> ModelledMotors:
    motors = ModelledMotors(params, DT, NoiseSource(np.random.default_rng(0)), battery=battery)
    motors.throttle = [throttle] * params.count
    motors.command = [command] * params.count
    return motors


# ------------------------------------------------------------------ asymmetric lag


def test_rise_and_fall_follow_their_own_exponentials():
    tau_up, tau_down = 12 * DT, 30 * DT
    motors = _group(_params(tau=tau_up, tau_fall=tau_down), 0.0, 0.8)
    rise = []
    for _ in range(40):
        motors.step()
        rise.append(motors.throttle[0])
    t = DT * np.arange(1, 41)
    np.testing.assert_allclose(rise, 0.8 * (1 - np.exp(-t / tau_up)), rtol=1e-12)
    motors.throttle, motors.command = [0.8] * 4, [0.2] * 4
    fall = []
    for _ in range(40):
        motors.step()
        fall.append(motors.throttle[0])
    np.testing.assert_allclose(fall, 0.2 + 0.6 * np.exp(-t / tau_down), rtol=1e-12)


def test_a_reversed_rotor_speeding_up_uses_the_rise_constant():
    motors = _group(_params(tau=12 * DT, tau_fall=30 * DT), -0.2, -0.9)
    motors.step()
    assert motors.throttle[0] == pytest.approx(-0.9 + 0.7 * math.exp(-1 / 12), rel=1e-12)
    motors.command = [-0.1] * 4  # now slowing down (towards zero)
    x = motors.throttle[0]
    motors.step()
    assert motors.throttle[0] == pytest.approx(-0.1 + (x + 0.1) * math.exp(-1 / 30), rel=1e-12)


def test_without_tau_fall_the_lag_is_the_plain_one():
    plain = Motors(_params(), DT, NoiseSource(np.random.default_rng(0)))
    modelled = _group(_params(rotor_drag=0.0), 0.0, 0.0)
    for motors in (plain, modelled):
        motors.command = [0.7, 0.1, -0.4, 0.9]
    for _ in range(10):
        a, b = plain.step(), modelled.step()
        assert plain.throttle == modelled.throttle
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-18)


# ------------------------------------------------------------------ rotor drag


@pytest.mark.parametrize("velocity", [(3.0, -2.0, 1.5), (-0.4, 0.9, -2.0)])
def test_rotor_drag_opposes_the_in_plane_air_speed_with_the_stated_coefficient(velocity):
    k, x = 4e-3, 0.6
    static = _group(_params(rotor_drag=0.0), x, x).step()
    motors = _group(_params(rotor_drag=k), x, x)
    motors.set_air((velocity, (0.0, 0.0, 0.0)))
    wrench = motors.step()
    u, v, _ = velocity
    # four rotors, each -k |x| v_inplane; the thrust along z and every moment unchanged
    expected = (static[0] - 4 * k * x * u, static[1] - 4 * k * x * v, static[2], *static[3:])
    np.testing.assert_allclose(wrench, expected, rtol=1e-12, atol=1e-15)


def test_rotor_drag_of_a_yawing_vehicle_damps_the_yaw():
    """Yaw rate r moves hub i at r (-p_y, p_x, 0): the drag's moment is -k |x| r sum(p_x^2 + p_y^2)."""
    k, x, r = 4e-3, 0.5, 2.0
    params = _params(rotor_drag=k)
    static = _group(_params(rotor_drag=0.0), x, x).step()
    motors = _group(params, x, x)
    motors.set_air(((0.0, 0.0, 0.0), (0.0, 0.0, r)))
    wrench = motors.step()
    arm2 = float(np.sum(params.positions[:, :2] ** 2))
    assert wrench[5] - static[5] == pytest.approx(-k * x * r * arm2, rel=1e-12)
    np.testing.assert_allclose(wrench[:5], static[:5], atol=1e-15)


# ------------------------------------------------------------------ inflow


def _momentum_oracle(kf: float, radius: float, solidity: float, slope: float, omega: float, climb: float) -> float:
    """Thrust [N] of a rotor at ``omega`` [rad/s] climbing at ``climb`` [m/s], solved here
    independently: find v_i where the blade-element thrust equals the momentum thrust
    T = 2 rho A (V_c + v_i) v_i (Leishman 2006, eq. 2.x climb), by bisection."""
    area = math.pi * radius**2
    tip = omega * radius
    static = kf * (omega / RPM_TO_RAD_S) ** 2
    v_h = math.sqrt(static / (2 * AIR_DENSITY * area))  # hover induced velocity
    s = solidity * slope / 4
    ct0 = static / (AIR_DENSITY * area * tip**2)
    theta = ct0 / s + v_h / tip

    def blade(vi: float) -> float:  # C_T = s (theta - (V_c + v_i) / (Omega R))
        return s * (theta - (climb + vi) / tip) * AIR_DENSITY * area * tip**2

    def momentum(vi: float) -> float:
        return 2 * AIR_DENSITY * area * (climb + vi) * vi

    lo, hi = 0.0, 10 * v_h
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if blade(mid) > momentum(mid) else (lo, mid)
    return momentum(0.5 * (lo + hi))


@pytest.mark.parametrize("climb", [0.0, 0.5, 1.5, 4.0])
def test_a_climbing_rotor_loses_thrust_as_momentum_theory_says(climb):
    x, radius, solidity, slope = 0.6, 0.0225, 0.17, 5.73
    params = _params(prop_radius=radius, inflow=(solidity, slope))
    motors = _group(params, x, x)
    motors.set_air(((0.0, 0.0, climb), (0.0, 0.0, 0.0)))
    thrust = motors.step()[2] / 4
    omega = x * 40000.0 * RPM_TO_RAD_S
    assert thrust == pytest.approx(_momentum_oracle(3.16e-10, radius, solidity, slope, omega, climb), rel=1e-9)
    static = 3.16e-10 * (x * 40000.0) ** 2
    if climb == 0.0:
        assert thrust == pytest.approx(static, rel=1e-12)
    else:
        assert thrust < static


def test_descent_raises_thrust_until_the_vortex_ring_limit():
    x = 0.6
    params = _params(prop_radius=0.0225, inflow=(0.17, 5.73))
    omega = x * 40000.0 * RPM_TO_RAD_S
    v_h = math.sqrt(3.16e-10 * (x * 40000.0) ** 2 / (2 * AIR_DENSITY * math.pi * 0.0225**2))
    thrusts = []
    for climb in (0.0, -0.25 * v_h, -0.5 * v_h, -1.5 * v_h, -3.0 * v_h):
        motors = _group(params, x, x)
        motors.set_air(((0.0, 0.0, climb), (0.0, 0.0, 0.0)))
        thrusts.append(motors.step()[2])
    assert thrusts[0] < thrusts[1] < thrusts[2]
    assert thrusts[3] == pytest.approx(thrusts[2], rel=1e-12)  # held at V_c = -v_h / 2
    assert thrusts[4] == thrusts[3]
    assert thrusts[2] == pytest.approx(4 * _momentum_oracle(3.16e-10, 0.0225, 0.17, 5.73, omega, -0.5 * v_h), rel=1e-9)


def test_a_climbing_rotor_needs_more_torque_per_thrust():
    """C_Q = C_Q0 + lambda C_T: climb power adds torque while the thrust falls."""
    x = 0.6
    params = _params(prop_radius=0.0225, inflow=(0.17, 5.73))
    hover, climb = _group(params, x, x), _group(params, x, x)
    climb.set_air(((0.0, 0.0, 2.0), (0.0, 0.0, 0.0)))
    # one motor only: zero the others' command and throttle
    for motors in (hover, climb):
        motors.throttle = [x, 0.0, 0.0, 0.0]
        motors.command = [x, 0.0, 0.0, 0.0]
    h, c = hover.step(), climb.step()
    assert c[2] < h[2]
    assert abs(c[5]) / c[2] > abs(h[5]) / h[2]


# ------------------------------------------------------------------ battery


def _battery(**changes) -> BatteryParams:
    values = dict(
        capacity_mah=250.0,
        internal_resistance=0.15,
        open_circuit_voltage=((0.0, 3.0), (0.1, 3.6), (0.5, 3.8), (0.9, 4.05), (1.0, 4.2)),
        efficiency=0.6,
        avionics_power=0.3,
        initial_charge=1.0,
    )
    values.update(changes)
    return BatteryParams(**values)


def test_battery_voltage_current_and_charge_by_hand():
    battery = Battery(_battery(initial_charge=0.7), DT)
    ocv = 3.925  # 3.8 + (4.05 - 3.8) * (0.7 - 0.5) / (0.9 - 0.5)
    assert battery.voltage == pytest.approx(ocv, rel=1e-12)
    full = 9.0  # shaft power at full voltage [W]
    battery.step(full)
    v = battery.voltage
    power = full * (v / 4.2) ** 3 / 0.6 + 0.3  # the load at this voltage
    assert v == pytest.approx((ocv + math.sqrt(ocv**2 - 4 * 0.15 * power)) / 2, rel=1e-12)  # V = V_oc - R P / V
    assert battery.current == pytest.approx(power / v, rel=1e-12)
    assert v == pytest.approx(ocv - 0.15 * battery.current, rel=1e-12)
    assert battery.charge == pytest.approx(0.7 - power / v * DT / (250 * 3.6), rel=1e-12)
    assert battery.speed_ratio == pytest.approx(v / 4.2, rel=1e-12)


def test_an_ideal_pack_holds_its_open_circuit_voltage():
    battery = Battery(_battery(internal_resistance=0.0), DT)
    battery.step(9.0)
    assert battery.voltage == 4.2 and battery.current == pytest.approx((9.0 / 0.6 + 0.3) / 4.2, rel=1e-12)


def test_a_heavy_rotor_load_settles_where_the_voltage_carries_it():
    battery = Battery(_battery(), DT)
    battery.step(1000.0)  # the rotors slow with the voltage until the pack carries them
    v = battery.voltage
    power = 1000.0 * (v / 4.2) ** 3 / 0.6 + 0.3
    assert 0.0 < v < 2.1
    assert v == pytest.approx(4.2 - 0.15 * power / v, rel=1e-12)


def test_a_demand_beyond_the_packs_maximum_power_gets_that_maximum():
    battery = Battery(_battery(avionics_power=100.0), DT)  # more than V_oc^2 / (4 R) = 29.4 W
    battery.step(5.0)
    c = 0.15 * 5.0 / (0.6 * 4.2**3)
    v = battery.voltage
    assert 0.0 < v < 4.2
    assert (3 * c * v + 2) * v - 4.2 == pytest.approx(0.0, abs=1e-12)  # the minimum of R c V^3 + V^2 - V_oc V + R P_0
    assert battery.current == pytest.approx((4.2 - v) / 0.15, rel=1e-12)


def test_the_charge_stops_at_zero():
    battery = Battery(_battery(initial_charge=1e-6, capacity_mah=1.0), DT)
    for _ in range(100):
        battery.step(5.0)
    assert battery.charge == 0.0
    assert open_circuit_voltage(battery._table, 0.0) == 3.0


def _height_after(spec, charge: float, throttle: float, seconds: float = 1.0) -> tuple[float, float]:
    """(height, charge) after ``seconds`` of all four motors held at ``throttle`` from a hover at 1 m."""
    world = World([dict(uav=spec, position=(0.0, 0.0, 1.0), mode="motors")], seed=0)
    vehicle = world.vehicles[0]
    vehicle.battery.set_params(dataclasses.replace(vehicle.battery.params, initial_charge=charge))
    world.reset(seed=0)
    vehicle.actuators.motors.throttle = [throttle] * 4  # spinning already: no spin-up transient
    m = spec.motors
    vehicle.battery.step(4 * m.kt * m.max_rpm**3 * RPM_TO_RAD_S * throttle**3)  # and the pack loaded already
    world.set_setpoint(0, [throttle] * 4)
    for _ in range(int(seconds * world.agent_hz)):
        world.step()
    height, final = vehicle.state.lin_pos[2], vehicle.battery.charge
    world.close()
    return height, final


def test_hover_throttle_rises_as_the_battery_sags_as_the_model_says():
    """The hover throttle by hand: the rotors must turn at the speed whose thrust is the
    weight, rpm_h = sqrt(m g / (4 k_F)), and draw P = 4 k_T rpm_h^2 Omega_h / eta + P_av;
    the pack then sits at V = (V_oc + sqrt(V_oc^2 - 4 R P)) / 2 and the throttle is
    rpm_h / (max_rpm V / V_full).  Held at that throttle the vehicle stays put; held at the
    ideal-supply hover throttle, it sinks."""
    data = spec_dict("quadx_cf2x")
    example = load_uav_spec(EXAMPLE)
    spec = spec_variant(**{"motors.noise_ratio": 0.0, "battery": example.battery.model_dump()})
    b = spec.battery
    rpm = math.sqrt(data["body"]["mass"] * GRAVITY / (4 * data["motors"]["kf"]))
    shaft = 4 * data["motors"]["kt"] * rpm**2 * rpm * RPM_TO_RAD_S  # Q Omega per rotor, four rotors
    power = shaft / b.efficiency + b.avionics_power
    ideal = rpm / data["motors"]["max_rpm"]
    throttles = []
    for charge in (1.0, 0.3):
        mid = charge - 0.5 * power / 3.7 / (250 * 3.6)  # about the charge half-way through the second
        ocv = open_circuit_voltage(b.open_circuit_voltage, mid)
        volts = (ocv + math.sqrt(ocv * ocv - 4 * b.internal_resistance * power)) / 2
        throttle = ideal / (volts / 4.2)
        height, final = _height_after(spec, charge, throttle)
        assert abs(height - 1.0) < 0.005, (charge, height)  # 1 % more throttle climbs 6 cm in this second
        assert final < charge
        sunk, _ = _height_after(spec, charge, ideal)
        assert sunk < 0.8, (charge, sunk)
        throttles.append(throttle)
    assert throttles[1] > throttles[0] * 1.05  # the lower battery needs visibly more throttle


# ------------------------------------------------------------------ spec


@pytest.mark.parametrize(
    ("changes", "key"),
    [
        ({"motors.tau_fall": -0.01}, "tau_fall"),
        ({"motors.rotor_drag": [0.1, 0.1, -0.1, 0.1]}, "rotor_drag"),
        ({"motors.tau_fall": [0.01, 0.02]}, "tau_fall"),
        ({"motors.inflow": {"solidity": 1.5}}, "solidity"),
        ({"motors.inflow": {"solidity": 0.1}, "motors.prop_radius": None}, "prop_radius"),
        (
            {"battery": {"capacity_mah": 0, "internal_resistance": 0.1, "open_circuit_voltage": [[0, 3], [1, 4]]}},
            "capacity_mah",
        ),
        (
            {"battery": {"capacity_mah": 250, "internal_resistance": -0.1, "open_circuit_voltage": [[0, 3], [1, 4]]}},
            "internal_resistance",
        ),
        (
            {"battery": {"capacity_mah": 250, "internal_resistance": 0.1, "open_circuit_voltage": [[0, 3], [0.5, 4]]}},
            "open_circuit_voltage",
        ),
        (
            {"battery": {"capacity_mah": 250, "internal_resistance": 0.1, "open_circuit_voltage": [[0, 4], [1, 3]]}},
            "open_circuit_voltage",
        ),
        (
            {
                "battery": {
                    "capacity_mah": 250,
                    "internal_resistance": 0.1,
                    "open_circuit_voltage": [[0, 3], [1, 4]],
                    "efficiency": 0,
                }
            },
            "efficiency",
        ),
        (
            {
                "battery": {
                    "capacity_mah": 250,
                    "internal_resistance": 0.1,
                    "open_circuit_voltage": [[0, 3], [1, 4]],
                    "initial_charge": 1.2,
                }
            },
            "initial_charge",
        ),
    ],
)
def test_impossible_values_are_refused_naming_the_key(changes, key):
    with pytest.raises(SpecError, match=key):
        spec_variant(**changes)


def test_off_by_default_the_plain_motors_fly_and_the_dump_is_unchanged():
    spec = load_uav_spec("quadx_cf2x")
    dump = spec.model_dump(mode="json")
    assert not {"tau_fall", "rotor_drag", "inflow"} & set(dump["motors"])
    assert "battery" not in dump
    world = World([dict(uav=spec, position=(0.0, 0.0, 1.0))], seed=0)
    vehicle = world.vehicles[0]
    assert type(vehicle.actuators.motors) is Motors
    assert vehicle.stages == NO_STAGES and not shadowed_methods(vehicle)  # nothing runs around the loads
    assert vehicle.battery is None and len(vehicle.aux_state) == 4
    world.close()


def test_the_example_airframe_flies_its_models_and_reports_its_charge():
    spec = load_uav_spec(EXAMPLE)
    assert spec.model_dump(mode="json")["battery"]["capacity_mah"] == 250.0
    world = World([dict(uav=spec, position=(0.0, 0.0, 1.0), mode="position_yaw")], seed=0, wind="dryden_light")
    vehicle = world.vehicles[0]
    assert isinstance(vehicle.actuators.motors, ModelledMotors) and vehicle.needs_air
    world.set_setpoint(0, [0.0, 0.0, 0.0, 1.0])
    for _ in range(60):
        world.step()
    aux = vehicle.aux_state
    assert len(aux) == 5 and 0.0 < aux[-1] < 1.0 and aux[-1] == vehicle.battery.charge
    # the controller does not know the battery: the sag costs height, but it flies
    assert 0.3 < vehicle.state.lin_pos[2] < 1.2 and not world.collided(0)
    world.close()


def test_the_models_stay_off_the_cpu_dispatched_numpy(monkeypatch):
    """The motor models, the battery, their randomisation and latency, flown with NumPy's
    CPU-dispatched kernels replaced by functions that fail (tests/engine/test_numeric_kernels.py)."""
    from tests.engine.test_numeric_kernels import _guard_numerics, _import_everything, _step_env

    _import_everything()
    spec = load_uav_spec(EXAMPLE)
    _guard_numerics(monkeypatch)
    world = World(seed=1, wind="dryden_light", ground_effect=True)
    world.add_vehicle(spec, (0.0, 0.0, 2.0), (0.0, 0.0, 0.0), mode="position_yaw")
    world.reset(seed=1)
    world.set_setpoint(0, [0.3, 0.0, 0.0, 2.0])
    for _ in range(5):
        world.step()
    assert all(math.isfinite(v) for v in world.state(0).lin_pos)
    world.close()
    _step_env(
        "PyFlyt/QuadX-Hover-v0",
        uav=str(EXAMPLE),
        wind="dryden_light",
        latency={"action_delay": 0.01, "observation_delay": 0.02},
        randomize={
            "battery_charge": {"distribution": "uniform", "low": 0.3, "high": 1.0},
            "motor_rotor_drag": {"distribution": "log_uniform", "low": 0.5, "high": 2.0},
            "motor_tau": {"distribution": "uniform", "low": 0.8, "high": 1.2},
        },
    )
