"""Ground effect (Cheeseman-Bennett) and downwash between vehicles, against their formulas."""

from __future__ import annotations

import math

import pytest

from pyflyt_engine.atmosphere.rotors import JET_DECAY, JET_SPREAD, downwash_velocity, ground_effect_ratio
from pyflyt_engine.constants import AIR_DENSITY, GRAVITY
from pyflyt_engine.world import VehicleConfig, World

R_CF2X = 0.0225  # conf/uav/quadx_cf2x.yaml prop_radius


def test_ground_effect_ratio_is_cheeseman_bennett_with_its_clamp():
    # z = R: 1 / (1 - 1/16) = 16/15
    assert ground_effect_ratio(0.1, 0.1) == pytest.approx(16 / 15)
    assert ground_effect_ratio(0.2, 0.1) == pytest.approx(1 / (1 - (1 / 8) ** 2))
    assert ground_effect_ratio(100.0, 0.1) == pytest.approx(1.0, abs=1e-6)
    # at and below half a radius: the clamp, 1 / (1 - 1/4) = 4/3, never the divergence at R/4
    assert ground_effect_ratio(0.05, 0.1) == pytest.approx(4 / 3)
    assert ground_effect_ratio(0.0, 0.1) == pytest.approx(4 / 3)
    assert ground_effect_ratio(-1.0, 0.1) == pytest.approx(4 / 3)
    assert ground_effect_ratio(0.0, 0.1, min_height=1.0) == pytest.approx(16 / 15)


def _acceleration(z: float, ground_effect: bool) -> tuple[float, float, list[float]]:
    """Vertical acceleration of a level cf2x at height z whose motors give exactly its weight
    out of ground effect (noise off), over one physics step from rest; and the scales used."""
    world = World(
        [VehicleConfig("quadx_cf2x", (0, 0, z), mode="motors")], seed=0, ground_effect=ground_effect, drag=False
    )
    vehicle = world.vehicles[0]
    motors = vehicle.actuators.motors
    motors._noisy = False  # an exact weight balance for the oracle
    hover = vehicle.hover_throttle()
    motors.throttle = [hover] * 4
    motors.command = [hover] * 4
    vehicle.read_state()
    air, ratio = world.atmosphere.at_state(0, vehicle)  # what the world hands the loads
    vehicle.apply_loads(air, ratio)
    import pybullet as p

    p.stepSimulation(physicsClientId=world.client)
    vz = p.getBaseVelocity(vehicle.body_id, physicsClientId=world.client)[0][2]
    scale = list(ratio or [1.0] * 4)
    world.close()
    return vz / world.physics_dt, hover, scale


@pytest.mark.parametrize("z", [0.02, 0.03, 0.06])
def test_a_rotorcraft_near_the_ground_gains_the_thrust_ratio(z):
    """a = g (T_IGE / T_OGE - 1) at the hub height: the thrust ratio, through the physics."""
    a, _, scale = _acceleration(z, True)
    ratio = ground_effect_ratio(z, R_CF2X)  # hubs at the CoM height for this airframe
    assert scale == pytest.approx([ratio] * 4)
    assert a == pytest.approx(GRAVITY * (ratio - 1.0), rel=1e-3, abs=1e-6)
    still, _, _ = _acceleration(z, False)
    assert abs(still) < 1e-6  # without ground effect the same throttle balances the weight


def test_downwash_formula_evaluated_by_hand():
    thrust, area = 0.265, 4 * math.pi * R_CF2X**2
    v_h = math.sqrt(thrust / (2 * AIR_DENSITY * area))
    d = math.sqrt(2 * area / math.pi)
    dz = 0.5
    centre = 2 * v_h * JET_DECAY * d / (dz + JET_DECAY * d)
    assert downwash_velocity(dz, 0.0, thrust, area) == pytest.approx(centre)
    half = JET_SPREAD * (dz + JET_DECAY * d)
    assert downwash_velocity(dz, half, thrust, area) == pytest.approx(centre / 2)  # half-width: half speed
    assert downwash_velocity(0.0, 0.0, thrust, area) == 0.0 and downwash_velocity(-0.2, 0.0, thrust, area) == 0.0
    assert downwash_velocity(1e-9, 0.0, thrust, area) == pytest.approx(2 * v_h)  # the fully developed wake


def test_the_vehicle_below_feels_the_wake_and_the_one_above_does_not():
    world = World(
        [
            VehicleConfig("quadx_cf2x", (0.0, 0.0, 2.0), mode="position_yaw"),
            VehicleConfig("quadx_cf2x", (0.02, 0.0, 1.5), mode="position_yaw"),
            VehicleConfig("quadx_cf2x", (3.0, 0.0, 1.0), mode="position_yaw"),
        ],
        seed=0,
        downwash=True,
    )
    world.set_all_setpoints([[0, 0, 0, 2.0], [0.02, 0, 0, 1.5], [3, 0, 0, 1.0]])
    for _ in range(30):
        world.step()
    interactions = world.rotor_interactions
    top, low, far = (world.state(i).lin_pos for i in range(3))
    thrust = interactions.thrust(0, world.vehicles[0].actuators.motors.throttle)
    expected = downwash_velocity(
        top[2] - low[2], math.hypot(low[0] - top[0], low[1] - top[1]), thrust, 4 * math.pi * R_CF2X**2
    )
    assert expected > 0.5  # a wake of the order of metres per second
    assert world.wind_at(1)[2] == pytest.approx(-expected)
    assert world.wind_at(0) == (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    assert abs(world.wind_at(2)[2]) < 1e-6
    # through the body drag, the wake pushes the lower vehicle: it needs more thrust to hold
    assert sum(world.vehicles[1].motor_throttle) > sum(world.vehicles[2].motor_throttle)
    world.close()


def test_a_wake_is_as_strong_as_its_vehicles_own_motors():
    """A randomiser scales a vehicle's thrust coefficient by f (``randomize.motor_kf``): from the
    world's next step its wake is that of a rotorcraft with f times the full thrust, so at the
    same throttles the wake speed below it is sqrt(f) times the nominal one (the jet speed goes
    as the square root of the thrust, ``downwash_velocity``)."""
    import dataclasses

    world = World(
        [VehicleConfig("quadx_cf2x", (0.0, 0.0, 2.0), mode="motors"), VehicleConfig("quadx_cf2x", (0.0, 0.0, 1.0))],
        seed=0,
        downwash=True,
    )
    rotors = world.rotor_interactions
    assert rotors is not None
    motors = world.vehicles[0].actuators.motors
    nominal = list(rotors.vehicles[0].max_thrust)
    throttle = [0.5] * 4
    below, above = [0.0, 0.0, 1.0], [0.0, 0.0, 2.0]
    before = rotors.downwash_at(1, below, [above, below], [throttle, throttle])
    motors.set_params(dataclasses.replace(motors.params, kf=motors.params.kf * 1.21))
    assert rotors.vehicles[0].max_thrust == nominal  # taken when the world steps next
    world.step()
    assert rotors.vehicles[0].max_thrust == (motors.params.kf * motors.params.max_rpm**2).tolist()
    assert rotors.vehicles[0].max_thrust == pytest.approx([1.21 * t for t in nominal], rel=1e-15)
    assert rotors.vehicles[1].max_thrust == nominal  # the other vehicle keeps its own
    after = rotors.downwash_at(1, below, [above, below], [throttle, throttle])
    assert before < -0.1 and after == pytest.approx(1.1 * before, rel=1e-12)
    world.close()


def test_off_by_default_and_bit_identical():
    import numpy as np

    def run(**kwargs) -> bytes:
        w = World([VehicleConfig("quadx_cf2x", (0, 0, 0.05), mode="position_yaw")], seed=0, **kwargs)
        w.set_setpoint(0, [0, 0, 0, 0.3])
        rows = []
        for _ in range(20):
            w.step()
            rows.append(w.state(0).as_array())
        w.close()
        return np.array(rows).tobytes()

    plain = run()
    assert run(ground_effect=False, downwash=False) == plain
    assert run(ground_effect=True) != plain


def test_switched_from_env_config_and_cli():
    import gymnasium
    from typer.testing import CliRunner

    import pyflyt_engine.envs  # noqa: F401
    from pyflyt_cli.main import app

    env = gymnasium.make("PyFlyt/QuadX-Hover-v0", ground_effect=True, downwash=True)
    assert env.unwrapped.world.rotor_interactions.ground_effect
    env.close()
    assert gymnasium.make("PyFlyt/QuadX-Hover-v0").unwrapped.world.rotor_interactions is None
    result = CliRunner().invoke(app, ["fly", "ground_effect=maybe", "duration=0.1"])
    assert result.exit_code == 2 and "ground_effect" in result.output


def test_prop_radius_is_validated_with_the_airframe():
    import yaml

    from pyflyt_engine.errors import SpecError
    from pyflyt_engine.paths import uav_dir
    from pyflyt_engine.spec import parse_uav_spec

    data = yaml.safe_load((uav_dir() / "quadx_cf2x.yaml").read_text())
    data["motors"]["prop_radius"] = -0.02
    with pytest.raises(SpecError, match="prop_radius"):
        parse_uav_spec(data)
    data["motors"]["prop_radius"] = [0.02, 0.02]
    with pytest.raises(SpecError, match="prop_radius"):
        parse_uav_spec(data)


def test_thrust_ratio_scales_the_thrust_and_its_moment_not_the_reaction_torque():
    import numpy as np

    from pyflyt_engine.components.motor import MotorParams, Motors
    from pyflyt_engine.components.noise import NoiseSource

    params = MotorParams(
        positions=[[0.1, 0.2, 0.0]], thrust_axes=[[0.0, 0.0, 1.0]], spin=[1], tau=[1e-6], max_rpm=[1000.0],
        kf=[1e-6], kt=[1e-8], noise_ratio=[0.0],
    )  # fmt: skip
    motors = Motors(params, 1 / 240, NoiseSource(np.random.default_rng(0)))
    motors.command = [1.0]
    plain = np.array(motors.step())
    scaled = np.array(motors.step(None, [1.5]))
    thrust, reaction = 1e-6 * 1000.0**2, -1e-8 * 1000.0**2
    x2 = motors.throttle[0] ** 2  # the lag has settled: the same throttle both steps
    assert plain == pytest.approx([0, 0, thrust * x2, 0.2 * thrust * x2, -0.1 * thrust * x2, reaction * x2], rel=1e-6)
    assert scaled == pytest.approx(
        [0, 0, 1.5 * thrust * x2, 1.5 * 0.2 * thrust * x2, -1.5 * 0.1 * thrust * x2, reaction * x2], rel=1e-6
    )
