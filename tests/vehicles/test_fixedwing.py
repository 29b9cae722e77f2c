"""The paper's Fixedwing (conf/uav/fixedwing.yaml) in flight, against static oracles.

The oracles (tests/vehicles/aero.py) sum the same pure component models the vehicle
uses, without PyBullet: the glide ratio of a steady glide must equal the airframe's
lift-to-drag ratio at the angle of attack it glides at, and the pitch attitude for
level flight comes from the static force and moment balance.
"""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest

from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.spec import load_uav_spec
from pyflyt_engine.world import VehicleConfig, World
from tests.vehicles.aero import glide_ratio, level_trim, straight_trim

CRUISE = 14.0  # m/s: the airframe's level-flight design speed (fixedwing.yaml)


def launch(uav, mode: str, altitude: float = 200.0, speed: float = CRUISE, pitch: float = 0.0) -> World:
    """A world with one airframe flying along +x at ``speed`` (its body x along the velocity)."""
    world = World([VehicleConfig(uav, (0.0, 0.0, altitude), (0.0, pitch, 0.0), mode=mode)], seed=0)
    vehicle = world.vehicles[0]
    p.resetBaseVelocity(vehicle.body_id, [speed, 0.0, 0.0], [0.0, 0.0, 0.0], physicsClientId=world.client)
    vehicle.read_state()
    return world


def fly(world: World, seconds: float) -> list:
    states = []
    for _ in range(round(seconds * world.agent_hz)):
        world.step()
        states.append(world.state(0))
    return states


def test_fixedwing_matches_the_paper_figures():
    spec = load_uav_spec("fixedwing")
    # mass from the parts: fuselage 1.0, wing 0.5, ailerons 0.2 each, base 0.3, tails 0.1 + 0.05
    assert spec.body.mass is None and spec.body.inertia is None  # computed from geometry
    assert sorted(s.mass for s in spec.body.shapes) == sorted([1.0, 0.5, 0.2, 0.2, 0.3, 0.1, 0.05])
    assert spec.total_mass() == pytest.approx(2.35)
    # 2.4 m wingspan, 1.55 m nose to tail (paper)
    lo = np.min([np.subtract(s.position, np.divide(s.size, 2)) for s in spec.body.shapes], axis=0)
    hi = np.max([np.add(s.position, np.divide(s.size, 2)) for s in spec.body.shapes], axis=0)
    assert hi[1] - lo[1] == pytest.approx(2.4)
    assert hi[0] - lo[0] == pytest.approx(1.55)
    # one motor, 18 N static thrust: T/W 0.78 (paper: 0.8)
    thrust = spec.motors.kf * spec.motors.max_rpm**2
    assert thrust == pytest.approx(18.0, rel=1e-4)
    assert thrust / (2.35 * GRAVITY) == pytest.approx(0.78, abs=0.01)
    # the paper's action: aileron, elevator, rudder, thrust
    assert list(spec.channels) == ["roll", "pitch", "yaw", "thrust"]
    table = {s.name: (s.chord, s.span, s.max_deflection_deg) for s in spec.surfaces}
    assert table == {
        "main_wing": (0.3, 1.6, 0.0),
        "left_aileron": (0.3, 0.3, 30.0),
        "right_aileron": (0.3, 0.3, 30.0),
        "horizontal_tail": (0.2, 0.625, 20.0),
        "vertical_tail": (0.2, 0.312, 20.0),
    }


@pytest.mark.parametrize(
    "channel, axis",
    [(0, 0), (1, 1), (2, 2)],
    ids=["roll->p", "pitch->q", "yaw->r"],
)
def test_each_control_channel_turns_the_airframe_its_documented_way(channel, axis):
    """+roll: right wing down (+p); +pitch: nose down (+q); +yaw: nose left (+r)."""
    rates = {}
    for command in (0.0, 0.3):
        world = launch("fixedwing", "channels")
        setpoint = np.zeros(4)
        setpoint[channel] = command
        world.set_setpoint(0, setpoint)
        state = fly(world, 0.3)[-1]
        rates[command] = np.asarray(state.ang_vel)
        world.close()
    response = rates[0.3] - rates[0.0]
    assert response[axis] > 0.05, f"channel {channel} moved body rate {axis} by {response[axis]:.3f} rad/s"
    others = [i for i in range(3) if i != axis]
    assert np.abs(response[others]).max() < 0.5 * response[axis]


def test_thrust_channel_accelerates_forward():
    speeds = {}
    for command in (0.0, 1.0):
        world = launch("fixedwing", "channels")
        world.set_setpoint(0, [0.0, 0.0, 0.0, command])
        speeds[command] = fly(world, 1.0)[-1].lin_vel[0]
        world.close()
    # 18 N on 2.35 kg for 1 s would add 7.7 m/s without drag; drag and the 10 ms motor lag take some
    assert speeds[1.0] - speeds[0.0] > 4.0


def test_power_off_glide_ratio_is_plausible_and_equals_the_lift_to_drag_ratio():
    """Motor off and controls neutral from cruise speed: the airframe settles into its trim
    glide.  Glide ratio = horizontal distance / height lost, with the height corrected for
    the change of kinetic energy (V^2 / 2g) so residual phugoid motion does not bias it.

    Plausible band 4-20: the wing's own polar bounds it from above (C_D0 0.01, aspect
    ratio 5.3: (L/D)max = 0.5 sqrt(pi AR / C_D0) ~ 20 without fuselage drag); below 4 a
    powered model aircraft of this size does not glide (small UAVs of this class reach
    about 6-12).  And in a steady glide L/D = cot(glide angle) exactly, so the measured
    ratio must equal the static L/D of the airframe at the angle of attack it glides at.
    """
    spec = load_uav_spec("fixedwing")
    world = launch(spec, "channels", altitude=300.0)
    world.set_setpoint(0, [0.0, 0.0, 0.0, 0.0])
    states = fly(world, 45.0)
    world.close()
    segment = states[int(25 * 30) :]  # after the phugoid has died down
    pos = np.array([s.lin_pos for s in segment])
    vel = np.array([s.lin_vel_ground for s in segment])
    distance = np.sum(np.linalg.norm(np.diff(pos[:, :2], axis=0), axis=1))
    speed_sq = np.sum(vel**2, axis=1)
    energy_height = (pos[0, 2] - pos[-1, 2]) + (speed_sq[0] - speed_sq[-1]) / (2 * GRAVITY)
    ratio = distance / energy_height

    body = np.array([s.lin_vel for s in segment])
    alpha = float(np.mean(np.arctan2(-body[:, 2], body[:, 0])))
    airspeed = float(np.mean(np.sqrt(speed_sq)))
    oracle = glide_ratio(spec, alpha, airspeed)

    assert 4.0 < ratio < 20.0, f"glide ratio {ratio:.2f}"
    assert ratio == pytest.approx(oracle, rel=0.03), (
        f"glide ratio {ratio:.2f} vs L/D {oracle:.2f} at alpha {math.degrees(alpha):.2f} deg"
    )
    assert max(abs(s.ang_pos[0]) for s in segment) < math.radians(3.0)  # wings stay level


def test_autopilot_holds_level_flight_at_the_trim_attitude():
    """attitude_airspeed with wings level and the pitch from the static trim: the altitude
    stays within +-1 m and the airspeed within +-0.5 m/s of the setpoint for 15 s."""
    spec = load_uav_spec("fixedwing")
    trim = level_trim(spec, CRUISE)
    world = launch(spec, "attitude_airspeed", altitude=100.0, pitch=trim["pitch"])
    world.set_setpoint(0, [0.0, trim["pitch"], 0.0, CRUISE])
    states = fly(world, 18.0)
    world.close()
    held = states[3 * 30 :]
    z = np.array([s.lin_pos[2] for s in held])
    u = np.array([s.lin_vel[0] for s in held])
    assert np.abs(z - 100.0).max() < 1.0, f"altitude {z.min():.2f}..{z.max():.2f} m"
    assert np.abs(u - CRUISE).max() < 0.5
    assert max(abs(s.ang_pos[0]) for s in held) < math.radians(1.0)
    assert abs(np.mean([s.ang_pos[1] for s in held]) - trim["pitch"]) < math.radians(0.2)


def test_autopilot_holds_a_commanded_bank_and_turns_at_the_coordinated_rate():
    """A 20 deg bank (right wing down) with the coordinated yaw rate r = -(g / V) sin(phi):
    the bank holds within 3 deg after 3 s and the heading turns right at the level-turn
    rate psi_dot = -g tan(phi) / V (within 10 %; the turn is not quite level)."""
    bank = math.radians(20.0)
    spec = load_uav_spec("fixedwing")
    trim = level_trim(spec, CRUISE)
    world = launch(spec, "attitude_airspeed", altitude=100.0, pitch=trim["pitch"])
    world.set_setpoint(0, [bank, trim["pitch"], -GRAVITY / CRUISE * math.sin(bank), CRUISE])
    states = fly(world, 12.0)
    world.close()
    held = states[3 * 30 :]
    roll = np.array([s.ang_pos[0] for s in held])
    heading = np.unwrap([s.ang_pos[2] for s in held])
    error = np.abs(roll - bank).max()
    assert error < math.radians(3.0), f"bank error {math.degrees(error):.2f} deg"
    turn_rate = (heading[-1] - heading[0]) / (len(held) - 1) * 30.0
    assert turn_rate == pytest.approx(-GRAVITY * math.tan(bank) / CRUISE, rel=0.1)
    assert heading[-1] - heading[0] < -math.radians(90.0)


def with_motor(spec, **changes):
    """``spec`` with its motor fields replaced (e.g. ``kt=0.0``: no reaction torque)."""
    return spec.model_copy(update={"motors": spec.motors.model_copy(update=changes)})


def fly_from(spec, pitch: float, velocity_body, setpoint, seconds: float) -> list:
    """Fly ``setpoint`` for ``seconds`` from wings level at Euler ``pitch``, 200 m up, with the
    body velocity ``velocity_body`` (World, seed 0)."""
    world = World([VehicleConfig(spec, (0.0, 0.0, 200.0), (0.0, pitch, 0.0), mode="channels")], seed=0)
    world.vehicles[0].reset(lin_vel=velocity_body)
    world.set_setpoint(0, setpoint)
    states = fly(world, seconds)
    world.close()
    return states


def trim_setpoint(trim: dict, roll: bool = True, yaw: bool = True) -> list[float]:
    return [
        trim["roll_channel"] if roll else 0.0,
        trim["pitch_channel"],
        trim["yaw_channel"] if yaw else 0.0,
        trim["thrust_channel"],
    ]


def test_trimmed_straight_flight_holds_its_heading():
    """From the static six-equation trim at 14 m/s (tests/vehicles/aero.py: forces and
    moments zero, the propeller's reaction torque included), the flown airframe holds
    wings level within 1 deg, its heading within 3 deg and its height within 0.5 m for
    10 s (what is left is the 0.05 s flap and 0.01 s motor lags from idle at the start).
    The same flight with the aileron and rudder at neutral -- the neutral stick -- turns
    by more than 45 deg in 10 s, banked over 10 deg: the torque roll of the puller
    propeller, left for ``spin: [1]`` (reaction -k_T w^2 about +x rolls the left wing
    down), with body rates below 0.3 rad/s."""
    spec = load_uav_spec("fixedwing")
    trim = straight_trim(spec, CRUISE)
    # a small trim: the reaction torque is 0.09 N m at 3.6 N of thrust
    assert 0.0 < trim["roll_channel"] < 0.05 and abs(trim["yaw_channel"]) < 0.15
    states = fly_from(spec, trim["pitch"], trim["velocity_body"], trim_setpoint(trim), 10.0)
    roll = np.array([s.ang_pos[0] for s in states])
    heading = np.unwrap([s.ang_pos[2] for s in states])
    z = np.array([s.lin_pos[2] for s in states])
    rates = np.array([s.ang_vel for s in states])
    assert np.abs(roll).max() < math.radians(1.0), f"roll up to {math.degrees(np.abs(roll).max()):.2f} deg"
    assert abs(heading[-1]) < math.radians(3.0), f"heading moved {math.degrees(heading[-1]):.2f} deg"
    assert np.abs(z - 200.0).max() < 0.5
    assert np.abs(rates).max() < 0.05

    states = fly_from(spec, trim["pitch"], trim["velocity_body"], trim_setpoint(trim, roll=False, yaw=False), 10.0)
    roll = np.array([s.ang_pos[0] for s in states])
    heading = np.unwrap([s.ang_pos[2] for s in states])
    rates = np.array([s.ang_vel for s in states])
    assert roll.min() < -math.radians(10.0) and roll.max() < math.radians(0.5), "rolls left, not right"
    assert heading[-1] > math.radians(45.0), f"turned {math.degrees(heading[-1]):.1f} deg left"
    assert np.abs(rates).max() < 0.3, "a slow torque-roll turn, not a spin"


def test_the_propeller_torque_is_the_only_lateral_asymmetry():
    """Without the reaction torque (k_T = 0) the straight trim needs no aileron, rudder or
    sideslip, and the neutral stick at the trim thrust flies 10 s with roll and yaw rates
    of zero (to 1e-12: the airframe is mirror-symmetric); the propeller turned the other
    way (spin -1) needs the mirrored trim."""
    spec = load_uav_spec("fixedwing")
    still = straight_trim(with_motor(spec, kt=0.0), CRUISE)
    assert max(abs(still["roll_channel"]), abs(still["yaw_channel"]), abs(still["beta"])) < 1e-12
    states = fly_from(with_motor(spec, kt=0.0), still["pitch"], still["velocity_body"], trim_setpoint(still), 10.0)
    rates = np.array([s.ang_vel for s in states])
    attitude = np.array([s.ang_pos for s in states])
    assert np.abs(rates[:, [0, 2]]).max() < 1e-12
    assert np.abs(attitude[:, [0, 2]]).max() < 1e-12

    mirrored = with_motor(spec, spin=[-s for s in spec.motors.spin])
    left, right = straight_trim(spec, CRUISE), straight_trim(mirrored, CRUISE)
    for key in ("roll_channel", "yaw_channel", "beta"):
        assert right[key] == pytest.approx(-left[key], rel=1e-4), key
    for key in ("pitch", "pitch_channel", "thrust"):
        assert right[key] == pytest.approx(left[key], rel=1e-6), key


@pytest.mark.parametrize("channel", [0, 2], ids=["aileron", "rudder"])
def test_mirrored_lateral_commands_give_mirrored_rates(channel):
    """Gliding (no propeller torque) from the pitch trim at 14 m/s, +0.2 and -0.2 on the
    aileron (rudder) for 1 s: the roll and yaw rates are each other's negatives and the
    pitch rates equal, within 0.2 % of the response (an off-centre surface or a sign
    slip in one surface's mix would break this by the size of the response)."""
    spec = load_uav_spec("fixedwing")
    trim = level_trim(spec, CRUISE)
    rates = {}
    for sign in (1.0, -1.0):
        setpoint = [0.0, trim["pitch_channel"], 0.0, 0.0]
        setpoint[channel] = 0.2 * sign
        velocity = [CRUISE * math.cos(trim["pitch"]), 0.0, CRUISE * math.sin(trim["pitch"])]
        states = fly_from(spec, trim["pitch"], velocity, setpoint, 1.0)
        rates[sign] = np.array([s.ang_vel for s in states])
    response = np.abs(rates[1.0] - rates[-1.0]).max() / 2
    assert response > 0.05
    assert np.abs(rates[1.0][:, [0, 2]] + rates[-1.0][:, [0, 2]]).max() < 2e-3 * response
    assert np.abs(rates[1.0][:, 1] - rates[-1.0][:, 1]).max() < 2e-3 * response
