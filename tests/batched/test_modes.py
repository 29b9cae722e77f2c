"""The batched backend's outer control loops equal the multirotor controller's bit for bit.

Every multirotor flight mode above the rate loop (rates_z, the attitude modes, the
heading-velocity, velocity and position modes) is compiled in
:mod:`pyflyt_engine.batched.modes`, loop by loop as ``MultirotorController`` writes them.
Each compiled loop is held here to its scalar method on random inputs for every
multirotor the backend flies, in the airframe's shipped gains and in variants that switch
on what the shipped ones leave off (the velocity loop's integral window and integral
limit, the rate loop's derivative term): the outputs, every integrator and the rate
loop's memory, tick by tick, with the limits, saturations and floors reached along the way.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pyflyt_engine.assembly import assemble
from pyflyt_engine.batched import kernels, modes
from pyflyt_engine.batched.model import BATCHED_MODES, UnsupportedByBatched, batched_model, mode_code
from pyflyt_engine.control.mixer import flight_mixer
from pyflyt_engine.control.modes import MULTIROTOR_MODES
from pyflyt_engine.control.multirotor import MultirotorController
from pyflyt_engine.spec import load_uav_spec
from pyflyt_engine.state import KinematicState

from tests.batched.test_laws import CONTROL_DT, DT, MULTIROTORS, ROUTED
from tests.conftest import spec_variant

#: gains the shipped airframes leave at their defaults, switched on
VARIANTS = {
    "shipped": {},
    "window_and_limit": {"control.velocity.integral_window": 0.5, "control.velocity.integral_limit": [2.0, 1.5, 3.0]},
    "derivative": {"control.rate.kd": [0.02, 0.03, 0.01]},
}
#: every multirotor it flies: the tricopter's trim (its tilted tail) and tilting motor, the
#: quadplane's mixer of four of its five motors among them
AIRFRAMES = MULTIROTORS + ROUTED
CASES = [(name, variant) for name in AIRFRAMES for variant in VARIANTS]


def _spec(name: str, variant: str):
    return spec_variant(name, **VARIANTS[variant]) if VARIANTS[variant] else load_uav_spec(name)


def _controller(spec, mode: str | None = None) -> MultirotorController:
    parts = assemble(spec)
    controller = MultirotorController(spec.control, parts.mass, np.diag(parts.inertia), flight_mixer(parts), CONTROL_DT)
    if mode is not None:
        controller.set_mode(MULTIROTOR_MODES[mode])
    return controller


def _state(rng: np.random.Generator, wide: bool) -> KinematicState:
    """A random state: attitudes up to beyond the thrust's tilt floor (cos roll cos pitch < 0.5)
    when ``wide``, any heading, velocities of a few m/s."""
    tilt = 1.2 if wide else 0.3
    three = lambda s: tuple(rng.normal(0, s, 3).tolist())  # noqa: E731
    angles = (float(rng.normal(0, tilt)), float(rng.normal(0, tilt)), float(rng.uniform(-math.pi, math.pi)))
    return KinematicState(three(2.0), angles, three(2.0), three(1.5), (0.0, 0.0, 0.0, 1.0), three(2.0), three(2.0))


def test_every_multirotor_mode_of_the_engine_is_compiled():
    """The backend's mode table is the engine's: every multirotor mode has a compiled code
    (and a cascade mode its law), and a fixed-wing still refuses them by name."""
    assert set(BATCHED_MODES) == set(MULTIROTOR_MODES)
    assert set(modes.CASCADE_MODES) == set(MULTIROTOR_MODES) - {"rates_thrust", "motors"}
    assert len(set(BATCHED_MODES.values())) == len(BATCHED_MODES)
    for name, flight in MULTIROTOR_MODES.items():
        assert mode_code(name) == BATCHED_MODES[name]
        if flight.pyflyt_id is not None:
            assert mode_code(flight.pyflyt_id) == BATCHED_MODES[name]
    fixedwing = batched_model(load_uav_spec("fixedwing"), DT, CONTROL_DT)
    with pytest.raises(UnsupportedByBatched, match="flight mode velocity_yawrate"):
        mode_code("velocity_yawrate", fixedwing)


@pytest.mark.parametrize(("name", "variant"), CASES)
def test_the_parameters_are_the_controllers(name, variant):
    spec = _spec(name, variant)
    controller = _controller(spec)
    c = batched_model(spec, DT, CONTROL_DT).cascade
    assert c.mass == controller.mass and c.window == controller._window and c.max_tilt == controller._max_tilt
    assert c.trimmed == (controller._trim is not None) and c.trim == (controller._trim or (0.0, 0.0))
    assert c.trimmed == (name == "tricopter")
    assert c.table[:4].T.tolist() == [list(axis) for axis in controller._velocity_axes]
    assert c.table[4:].tolist() == [
        list(controller._position_kp),
        list(controller._max_velocity),
        list(controller._attitude_kp),
        list(controller._max_rate),
    ]
    assert (c.window == 0.5) == (variant == "window_and_limit")


@pytest.mark.parametrize(("name", "variant"), CASES)
def test_the_velocity_loop_equals_the_controllers(name, variant):
    """Per stretch of 100 ticks: errors held near where the command saturates (kp e at the
    axis's bound, either side: the integrator runs until it would pass it, then stops), large
    errors of either sign (it stops at once, or outside the window), small ones (it
    integrates), and integrals put beyond their bounds (a state from other gains: the clamp);
    axes without a setpoint (None) neither command nor integrate."""
    spec = _spec(name, variant)
    controller = _controller(spec, "velocity_yawrate")
    c = batched_model(spec, DT, CONTROL_DT).cascade
    kp, ki, lo, hi = (c.table[row] for row in range(4))
    rng = np.random.default_rng(30)
    integral = np.zeros(3)
    counts = dict.fromkeys(("integrated", "saturated", "clamped", "windowed", "none"), 0)
    for tick in range(1000):
        state = _state(rng, wide=False)
        phase = tick % 100
        if phase < 40:  # near saturation, one side per stretch
            bound = hi if (tick // 100) % 2 == 0 else lo
            error = bound / kp * rng.uniform(0.7, 1.3, 3)
        elif phase < 60:
            error = rng.normal(0.0, 6.0, 3)
        else:
            error = rng.normal(0.0, 0.2, 3)
        if phase == 60:  # beyond the bounds
            integral[:] = np.where(rng.random(3) < 0.5, hi, lo) / ki * 1.3
            controller._vel_integral = integral.tolist()
        sp = (np.asarray(state.lin_vel_ground) + error).tolist()
        axes = [v if rng.random() > 0.1 else None for v in sp]
        before = integral.copy()
        expected = controller._velocity_loop(state, axes)
        for k in range(3):
            if axes[k] is None:
                assert expected[k] == 0.0 and controller._vel_integral[k] == integral[k]
                counts["none"] += 1
                continue
            a, integral[k] = modes.velocity_axis(
                axes[k], state.lin_vel_ground[k], integral[k], kp[k], ki[k], lo[k], hi[k], c.window, CONTROL_DT
            )
            assert a == expected[k], (tick, k)
            e = axes[k] - state.lin_vel_ground[k]
            if abs(e) >= c.window:
                counts["windowed"] += 1
            elif integral[k] == before[k]:
                counts["saturated"] += 1
            elif integral[k] in (lo[k] / ki[k], hi[k] / ki[k]):
                counts["clamped"] += 1
            else:
                counts["integrated"] += 1
        assert integral.tolist() == controller._vel_integral, tick
    assert min(counts["integrated"], counts["saturated"], counts["none"]) > 50 and counts["clamped"] > 5, counts
    assert (counts["windowed"] > 50) == (variant == "window_and_limit"), counts


@pytest.mark.parametrize("name", AIRFRAMES)
def test_climb_thrust_attitude_and_tilt_equal_the_controllers(name):
    """The single-step loops on random and edge inputs: the climb rate at its limit, the
    thrust at its tilt floor and at zero, the yaw error wrapped from any angle (exact
    multiples of 2 pi, +-pi, signed zeros: Python's float ``%``, compiled), the tilt at its
    limits and the lift at its floor."""
    spec = load_uav_spec(name)
    controller = _controller(spec, "position_yaw")
    c = batched_model(spec, DT, CONTROL_DT).cascade
    rng = np.random.default_rng(31)
    counts = dict.fromkeys(("climb_limit", "thrust_floor", "thrust_zero", "rate_limit", "tilt_limit", "lift_floor"), 0)
    edges = [0.0, -0.0, math.pi, -math.pi, 2 * math.pi, -2 * math.pi, 4 * math.pi, 1e-300, -1e-300, 3 * math.pi]
    for case in range(1500):
        wide = case % 2 == 0
        state = _state(rng, wide)
        roll, pitch, yaw = state.ang_pos
        if case < len(edges) ** 2:  # yaw errors at the wrap's edges
            yaw = edges[case // len(edges)]
            state = state._replace(ang_pos=(roll, pitch, yaw))
            yaw_sp = yaw + edges[case % len(edges)] - math.pi
        else:
            yaw_sp = float(rng.uniform(-12.0, 12.0))
        z_sp = float(rng.normal(state.lin_pos[2], 2.0))
        climb = controller._climb(state, z_sp)
        assert modes.climb(c.table[4, 2], c.table[5, 2], z_sp, state.lin_pos[2]) == climb
        counts["climb_limit"] += abs(climb) == c.table[5, 2]
        az = float(rng.normal(0.0, 8.0))
        thrust = controller._thrust_for(state, az)
        assert modes.thrust_for(c.mass, roll, pitch, az) == thrust
        counts["thrust_floor"] += math.cos(roll) * math.cos(pitch) < 0.5
        counts["thrust_zero"] += thrust == 0.0
        r_sp, p_sp = float(rng.normal(0, 0.6)), float(rng.normal(0, 0.6))
        for hold in (False, True):
            yaw_rate = float(rng.normal(0, 3.0))
            expected = controller._attitude_rates(state, r_sp, p_sp, None if hold else yaw_sp, yaw_rate)
            got = modes.attitude_rates(c.table, r_sp, p_sp, yaw_sp, hold, yaw_rate, roll, pitch, yaw)
            assert got == expected, (case, hold)
            assert [math.copysign(1.0, v) for v in got] == [math.copysign(1.0, v) for v in expected]
            counts["rate_limit"] += any(abs(v) == lim for v, lim in zip(got, c.table[7].tolist()))
        ax, ay = (float(v) for v in rng.normal(0.0, 6.0, 2))
        if case % 7 == 0:
            ax, ay = (0.0, -0.0) if case % 2 else (-0.0, 0.0)
        tilt = controller._tilt_for(state, ax, ay, az)
        got = modes.tilt_for(yaw, ax, ay, az, c.max_tilt, c.trimmed, *c.trim)
        assert got == tilt and [math.copysign(1.0, v) for v in got] == [math.copysign(1.0, v) for v in tilt]
        counts["tilt_limit"] += c.max_tilt in map(abs, tilt)
        counts["lift_floor"] += 9.81 + az < 0.1 * 9.81
    assert min(counts.values()) > 20, counts


def _setpoint(rng: np.random.Generator, mode: str, state: KinematicState, scale: float) -> list[float]:
    """A random setpoint in ``mode``'s layout around the state, errors of about ``scale``."""
    x, y, z = state.lin_pos
    vx, vy, vz = state.lin_vel_ground
    a, b, c, d = rng.normal(0.0, scale, 4).tolist()
    layout = MULTIROTOR_MODES[mode].setpoint
    first = {"p": a, "roll": 0.3 * a, "u": a, "vx": vx + a, "x": x + a}[layout[0]]
    second = {"q": b, "pitch": 0.3 * b, "v": b, "vy": vy + b, "y": y + b}[layout[1]]
    third = {"r": c, "yaw": float(rng.uniform(-7.0, 7.0)), "yaw_rate": c}[layout[2]]
    fourth = {"z": z + d, "vz": vz + d}[layout[3]]
    return [first, second, third, fourth]


def _law(controller: MultirotorController):
    return modes.cascade_law(modes.CASCADE_MODES[controller.mode.name])


@pytest.mark.parametrize("mode", list(modes.CASCADE_MODES))
@pytest.mark.parametrize(("name", "variant"), CASES)
def test_each_cascade_mode_equals_the_controller(name, variant, mode):
    """The whole law of a mode, tick after tick: the compiled outer loops, rate loop and mixer
    give the controller's throttles, and its rate integral, last rates and velocity
    integral, bit for bit; stretches of large errors reach the mixer's give-way paths and the
    integrators' limits."""
    spec = _spec(name, variant)
    controller = _controller(spec, mode)
    model = batched_model(spec, DT, CONTROL_DT)
    c = model.cascade
    law, yaw_is_rate, heading_frame, position, altitude = _law(controller)
    rng = np.random.default_rng(40 + list(modes.CASCADE_MODES).index(mode))
    vel_integral, integral, previous = np.zeros(3), np.zeros(3), np.zeros(3)
    n = model.mixer_outputs  # the mixer's throttles, then the tricopter's servo command
    out, scratch, torques, rates = np.empty(n), np.empty((len(model.mixer_rows), 4)), np.empty(3), np.empty(3)
    rates_sp = np.empty(3)
    first, clipped = True, 0
    for tick in range(300):
        state = _state(rng, wide=tick % 3 == 0)
        setpoint = _setpoint(rng, mode, state, 3.0 if tick % 60 < 30 else 0.3)
        expected = controller.law(state, setpoint)
        (roll, pitch, yaw), (x, y, z), (vx, vy, vz) = state.ang_pos, state.lin_pos, state.lin_vel_ground
        p_sp, q_sp, r_sp, thrust = modes.outer_loops(
            law,
            yaw_is_rate,
            heading_frame,
            position,
            altitude,
            *setpoint,
            roll,
            pitch,
            yaw,
            x,
            y,
            z,
            vx,
            vy,
            vz,
            vel_integral,
            c.table,
            c.mass,
            c.window,
            c.max_tilt,
            CONTROL_DT,
            c.trimmed,
            *c.trim,
        )
        rates[:] = state.ang_vel
        rates_sp[:] = (p_sp, q_sp, r_sp)
        if first:
            previous[:] = rates
            first = False
        kernels.rate_loop(
            rates_sp,
            rates,
            previous,
            integral,
            model.rate_gains,
            model.rate_derivative,
            model.control_inertia,
            model.gyro,
            CONTROL_DT,
            torques,
        )
        previous[:] = rates
        kernels.mixer_outputs(thrust, *torques.tolist(), model.mixer_rows, model.lateral, scratch, out)
        assert out.tolist() == expected, tick
        assert integral.tolist() == list(controller._rate_integral), tick
        assert previous.tolist() == list(controller._prev_rate), tick
        assert vel_integral.tolist() == list(controller._vel_integral), tick
        clipped += any(v in (0.0, 1.0) for v in expected)
    assert clipped > 20  # the mixer's give-way and clipping paths ran
    if law != modes.LAW_TRANSLATE:  # only the vertical axis runs
        assert vel_integral[:2].tolist() == [0.0, 0.0] and vel_integral[2] != 0.0
    else:
        assert np.all(vel_integral != 0.0)


@pytest.mark.parametrize("mode", ["velocity_yawrate", "position_yaw", "attitude_z", "rates_z"])
@pytest.mark.parametrize("name", AIRFRAMES)
def test_the_control_tick_equals_the_controller_on_the_state_the_engine_reads(name, mode):
    """``control_tick`` over 16 vehicles at once: each one's commands and controller memory
    equal the controller's, fed the state the PyBullet engine reads (the compiled read-outs,
    held to PyBullet's functions in test_laws.py: the reported quaternion, its Euler angles and
    the body rates through its matrix)."""
    spec = load_uav_spec(name)
    model = batched_model(spec, DT, CONTROL_DT)
    c = model.cascade
    n, nm = 16, model.mixer_outputs
    controllers = [_controller(spec, mode) for _ in range(n)]
    rng = np.random.default_rng(50)
    rows = lambda a: np.ascontiguousarray(np.broadcast_to(a, (n, *np.shape(a))), dtype=np.float64)  # noqa: E731
    integral, previous, vel_integral = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
    has_previous = np.zeros(n, dtype=bool)
    command = np.empty((n, nm))
    law = _law(controllers[0])
    for tick in range(40):
        pos, vel, angvel = rng.normal(0, 1.5, (n, 3)), rng.normal(0, 2.0, (n, 3)), rng.normal(0, 2.0, (n, 3))
        quat = rng.standard_normal((n, 4))
        quat /= np.linalg.norm(quat, axis=1, keepdims=True)
        if tick % 2:  # mostly level too, where the tilt floor does not bind
            quat[:, :2] *= 0.1
            quat /= np.linalg.norm(quat, axis=1, keepdims=True)
        body_rates, euler, body_vel, reported = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 4))
        kernels.read_out(pos, quat, vel, angvel, body_rates, euler, body_vel, reported)
        read = (body_rates, euler, body_vel, pos, reported, vel, angvel)  # KinematicState's order
        states = [KinematicState(*(tuple(a[i].tolist()) for a in read)) for i in range(n)]
        setpoints = np.array([_setpoint(rng, mode, s, 1.0) for s in states])
        modes.control_tick(
            pos,
            quat,
            vel,
            angvel,
            setpoints,
            integral,
            previous,
            has_previous,
            vel_integral,
            *law,
            rows(c.table),
            rows(c.mass),
            rows(c.window),
            rows(c.max_tilt),
            rows(model.rate_gains),
            model.rate_derivative,
            rows(model.control_inertia),
            rows(model.gyro),
            rows(model.mixer_rows),
            CONTROL_DT,
            command,
            model.lateral,
            c.trimmed,
            *c.trim,
        )
        for i, (controller, state) in enumerate(zip(controllers, states)):
            assert command[i].tolist() == controller.law(state, setpoints[i].tolist()), (tick, i)
            assert integral[i].tolist() == list(controller._rate_integral)
            assert previous[i].tolist() == list(controller._prev_rate)
            assert vel_integral[i].tolist() == list(controller._vel_integral)
    assert has_previous.all()
