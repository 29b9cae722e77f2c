"""Position hold removes a steady disturbance: every shipped multirotor, constant wind up to its limit.

The wind limit of an airframe (``docs/atmosphere.md``, "Wind limits of the shipped
multirotors") is where the body drag of a level airframe, ``1/2 rho C_d A V^2``, equals
the horizontal acceleration its thrust margin allows times its mass
(:func:`pyflyt_engine.control.multirotor.velocity_authority`)::

    V_lim = sqrt(m a_h / (1/2 rho C_d A))

Below it the velocity loop's integral can carry the whole drag, so the position error
must vanish: here, below 5 cm from 10 s on.  The quadplane's lifting surfaces put
moments on it that its lift motors cannot hold in a tail or side wind above about
3.5 m/s (measured), well below its drag limit; its test uses that documented figure.
"""

from __future__ import annotations

import math

import pytest

from pyflyt_engine.constants import AIR_DENSITY
from pyflyt_engine.spec import load_uav_spec
from pyflyt_engine.world import VehicleConfig, World

HOLD = 0.05  # [m] steady-state position error allowed
SETTLE, END = 10.0, 14.0  # [s] the error is measured from SETTLE to END
#: the limits docs/atmosphere.md states, per airframe: (drag limit along x, along y) [m/s]
DOCUMENTED = {
    "quadx_f450": (8.3, 8.3),
    "quadx_cf2x": (15.7, 15.7),
    "hexacopter": (9.1, 9.1),
    "tricopter": (8.6, 8.6),
    "quadplane": (35.5, 6.5),
}
QUADPLANE_SURFACE_LIMIT = 3.5  # [m/s] measured, tail and side wind (docs/atmosphere.md)


def drag_limits(uav: str) -> tuple[float, float]:
    """(V_lim along body x, along body y) [m/s] from the spec and the controller's authority."""
    spec = load_uav_spec(uav)
    world = World([VehicleConfig(spec, mode="position_yaw")], seed=0)
    vehicle = world.vehicles[0]
    horizontal = vehicle.controller.authority[0]
    mass = vehicle.parts.mass
    world.close()
    k = [0.5 * AIR_DENSITY * c * a for c, a in zip(spec.drag.coefficients, spec.drag.areas)]
    return math.sqrt(mass * horizontal / k[0]), math.sqrt(mass * horizontal / k[1])


def hold_error(uav: str, speed: float, direction: float, *, downwash_above: float | None = None) -> tuple[float, float]:
    """(largest distance from the setpoint, largest from SETTLE to END) [m] in position_yaw at
    (0, 0, 2) m in a uniform wind ``speed`` toward ``direction`` [deg], or with a second
    vehicle of the same type ``downwash_above`` metres overhead (downwash on)."""
    vehicles = [VehicleConfig(uav, (0.0, 0.0, 2.0), mode="position_yaw")]
    if downwash_above is not None:
        vehicles.append(VehicleConfig(uav, (0.0, 0.0, 2.0 + downwash_above), mode="position_yaw"))
    wind = {"mean": {"speed": speed, "direction": direction}} if speed else None
    world = World(vehicles, seed=0, wind=wind, downwash=downwash_above is not None)
    extra = [0.0] * len(world.vehicles[0].parts.channels)
    world.set_all_setpoints([[0.0, 0.0, 0.0, 2.0 + (v.position[2] - 2.0), *extra] for v in vehicles])
    worst = late = 0.0
    for step in range(int(END * world.agent_hz)):
        world.step()
        x, y, z = world.vehicles[0].state.lin_pos
        error = math.sqrt(x * x + y * y + (z - 2.0) ** 2)
        worst = error if error > worst else worst
        if step / world.agent_hz >= SETTLE:
            late = error if error > late else late
    world.close()
    return worst, late


@pytest.mark.parametrize("uav", sorted(DOCUMENTED))
def test_the_documented_limit_is_the_thrust_margin_against_drag(uav):
    vx, vy = drag_limits(uav)
    assert (round(vx, 1), round(vy, 1)) == DOCUMENTED[uav]


CASES = [
    ("quadx_f450", 5.0, 0.0),
    ("quadx_f450", 7.0, 0.0),
    ("quadx_f450", 8.2, 90.0),  # just below its 8.3 m/s limit
    ("quadx_cf2x", 7.0, 0.0),
    ("quadx_cf2x", 15.5, 90.0),
    ("hexacopter", 5.0, 0.0),
    ("hexacopter", 9.0, 90.0),
    ("tricopter", 5.0, 0.0),
    ("tricopter", 8.5, 90.0),
    ("quadplane", 3.5, 0.0),  # tail wind, its surface limit
    ("quadplane", 3.5, 90.0),  # side wind
    ("quadplane", 6.4, 180.0),  # head wind, below its 6.5 m/s side-drag limit
]


@pytest.mark.parametrize(("uav", "speed", "direction"), CASES)
def test_position_hold_removes_a_constant_wind_within_10_s(uav, speed, direction):
    vx, vy = DOCUMENTED[uav]
    limit = min(vx, vy) if uav != "quadplane" or direction != 180.0 else vy
    if uav == "quadplane" and direction != 180.0:
        limit = QUADPLANE_SURFACE_LIMIT
    assert speed <= limit  # the case is inside the airframe's documented envelope
    worst, late = hold_error(uav, speed, direction)
    assert worst > 2 * HOLD or uav == "quadplane"  # the wind does push it away first
    assert late < HOLD, f"{uav} in {speed} m/s toward {direction} deg: {late:.3f} m off from {SETTLE} s on"


@pytest.mark.parametrize(("uav", "gap"), [("quadx_f450", 1.0), ("quadx_cf2x", 0.5)])
def test_position_hold_removes_the_downwash_of_a_vehicle_overhead(uav, gap):
    worst, late = hold_error(uav, 0.0, 0.0, downwash_above=gap)
    assert late < HOLD, f"{uav} {gap} m under another: {late:.3f} m off from {SETTLE} s on"


def test_the_integrator_does_not_freeze_at_the_issue_case():
    """The F450 at 5 m/s ended 0.50 m downwind with the integrator frozen outside a 0.5 m/s
    window; the drag it must carry is 1/2 rho C_d A V^2 / m = 2.45 m/s^2."""
    world = World(
        [VehicleConfig("quadx_f450", (0.0, 0.0, 2.0), mode="position_yaw")], seed=0, wind={"mean": {"speed": 5.0}}
    )
    world.set_all_setpoints([[0.0, 0.0, 0.0, 2.0]])
    for _ in range(int(END * world.agent_hz)):
        world.step()
    controller = world.vehicles[0].controller
    ki = world.vehicles[0].spec.control.velocity.ki[0]
    drag = 0.5 * AIR_DENSITY * 2.0 * 0.08 * 5.0**2 / 1.0
    # the integral term carries the drag on the tilted body (less than on the level one)
    assert -drag < ki * controller._vel_integral[0] < -0.6 * drag
    world.close()
