"""The hot-path forms (compiled physics step, one-pass mixer, unrolled controller, lazy
state read) agree bit for bit with the plain forms they replace."""

from __future__ import annotations

import hashlib
import math

import numpy as np
import pybullet as p
import pytest

from pyflyt_engine.components.drag import drag_wrench
from pyflyt_engine.components.motor import motor_step_wrench
from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.control.mixer import Mixer
from pyflyt_engine.control.modes import MULTIROTOR_MODES
from pyflyt_engine.control.multirotor import MultirotorController
from pyflyt_engine.frames import euler_to_quaternion, wrap_angle
from pyflyt_engine.fused import physics_step_source
from pyflyt_engine.state import KinematicState
from pyflyt_engine.world import VehicleConfig, World
from tests.conftest import spec_variant

MULTIROTORS = ["quadx_cf2x", "quadx_f450", "hexacopter"]


# ------------------------------------------------------------ compiled physics step


class _FakeVehicle:
    def __init__(self, throttle, command, noise_rows, velocity_body):
        self._throttle, self._command = list(throttle), list(command)
        self._noise_rows = iter(noise_rows)
        self._velocity_body = velocity_body

    def _refill_noise(self):
        raise AssertionError("the test supplies enough noise rows")


def _run_compiled(lag, columns, noise, drag, vehicle, quat, lin, ang, between_ticks):
    namespace: dict = {}
    exec(physics_step_source(lag, columns, noise, drag), namespace)  # noqa: S102 - the module's own source
    applied = {}

    def apply_force(body, link, force, position, frame, cid):
        applied["force"] = force

    def apply_torque(body, link, torque, frame, cid):
        applied["torque"] = torque

    apply_loads, substep = namespace["factory"](
        vehicle, 7, 0, (0.0, 0.0, 0.0), p.LINK_FRAME,
        lambda body, cid: ((1.0, 2.0, 3.0), quat), lambda body, cid: (lin, ang),
        lambda q, cid: p.getMatrixFromQuaternion(q), apply_force, apply_torque,
    )  # fmt: skip
    (substep if between_ticks else apply_loads)()
    return applied["force"] + applied["torque"]


@pytest.mark.parametrize("n", [1, 4, 6])
@pytest.mark.parametrize("noise", [True, False])
@pytest.mark.parametrize("with_drag", [True, False])
@pytest.mark.parametrize("between_ticks", [True, False])
def test_compiled_step_equals_motor_step_wrench_plus_drag(n, noise, with_drag, between_ticks):
    rng = np.random.default_rng(n + 10 * noise + 100 * with_drag)
    lag = rng.uniform(0.1, 0.9, n).tolist()
    columns = [tuple(c) for c in rng.normal(0, 1, (n, 6)).tolist()]
    if n > 1:  # zero entries are left out of the source: results must not change
        columns[0] = (0.0, 0.0, columns[0][2], 0.0, columns[0][4], 0.0)
        columns[1] = (0.0,) * 6
    factors, damping = tuple(rng.uniform(1e-4, 1e-2, 3).tolist()), 3e-4
    drag = [-factors[0], 0.0, -factors[2], -damping, -damping, -damping] if with_drag else None
    used_factors = (factors[0], 0.0, factors[2])
    for trial in range(20):
        throttle = rng.uniform(-1, 1, n).tolist()
        command = rng.uniform(-1, 1, n).tolist()
        noise_row = (1.0 + 0.05 * rng.standard_normal(n)).tolist() if noise else [1.0] * n
        q = rng.normal(0, 1, 4)
        quat = tuple((q / np.linalg.norm(q)).tolist())
        lin, ang = tuple(rng.normal(0, 5, 3).tolist()), tuple(rng.normal(0, 5, 3).tolist())
        if trial == 0:
            lin, throttle[0] = (0.0, -0.0, 0.0), 0.0
        # the reference: the general path's arithmetic (Vehicle.read_velocity, _apply_loads)
        r = p.getMatrixFromQuaternion(quat)
        lx, ly, lz = lin
        ax, ay, az = ang
        stored = (tuple(rng.normal(0, 5, 3).tolist()), tuple(rng.normal(0, 5, 3).tolist()))
        velocity = stored
        if between_ticks:
            velocity = (
                (
                    r[0] * lx + r[3] * ly + r[6] * lz,
                    r[1] * lx + r[4] * ly + r[7] * lz,
                    r[2] * lx + r[5] * ly + r[8] * lz,
                ),
                (
                    r[0] * ax + r[3] * ay + r[6] * az,
                    r[1] * ax + r[4] * ay + r[7] * az,
                    r[2] * ax + r[5] * ay + r[8] * az,
                ),
            )
        new, wrench = motor_step_wrench(throttle, command, lag, noise_row, columns)
        expected = list(wrench)
        if with_drag:
            d = drag_wrench(used_factors, damping, *velocity)
            expected = [w + dk for w, dk in zip(wrench, d)]

        vehicle = _FakeVehicle(throttle, command, [noise_row], stored)
        got = _run_compiled(lag, columns, noise, drag, vehicle, quat, lin, ang, between_ticks)
        assert vehicle._throttle == new
        assert [float(v) for v in got] == expected  # == on floats: bit for bit (up to the sign of 0)


def _trajectory(uav: str, mode: str, setpoint, fused: bool, steps: int = 40) -> str:
    world = World([VehicleConfig(uav, (0.0, 0.0, 1.0), (0.1, -0.2, 0.3), mode=mode)], seed=4)
    vehicle = world.vehicles[0]
    assert vehicle._fused is not None
    if not fused:  # the general path: motor_step_wrench + drag_wrench
        vehicle._fused = None
        vehicle.step_functions = (vehicle._apply_loads, vehicle.substep)
    world.set_setpoint(0, setpoint)
    rows = []
    for i in range(steps):
        world.step()
        if i == 25:
            world.reset()
            world.set_setpoint(0, setpoint)
        s = world.state(0)
        rows.append(np.concatenate([np.ravel(s.as_array()), s.quaternion, world.aux_state(0)]))
    world.close()
    return hashlib.sha256(np.array(rows).tobytes()).hexdigest()


@pytest.mark.parametrize("uav", MULTIROTORS)
def test_compiled_step_flies_the_same_trajectory_as_the_general_path(uav):
    sp = [1.0, -0.5, 0.4, 1.5]
    assert _trajectory(uav, "position_yaw", sp, fused=True) == _trajectory(uav, "position_yaw", sp, fused=False)


def test_vehicles_with_components_take_the_general_path():
    world = World([VehicleConfig("fixedwing", (0, 0, 10)), VehicleConfig("rocket", (5, 0, 1))], seed=0)
    assert all(v._fused is None for v in world.vehicles)
    world.step()
    world.close()


# ----------------------------------------------------------------------- mixer


@pytest.mark.parametrize("uav", MULTIROTORS + ["quadplane"])
def test_one_pass_mixer_equals_the_staged_one(uav):
    vehicle = World([VehicleConfig(uav)], seed=0).vehicles[0]
    mixer: Mixer = vehicle.mixer
    staged = mixer._throttles_limited
    handed_over = []
    mixer._throttles_limited = lambda *args: (handed_over.append(args), staged(*args))[1]
    rng = np.random.default_rng(0)
    for i in range(3000):
        thrust = float(rng.uniform(-0.2, 1.3) * mixer.max_collective)
        torques = [float(rng.normal(0, 1) * 10 ** rng.uniform(-4, 0)) if rng.random() < 0.8 else 0.0 for _ in range(3)]
        fast = mixer.throttles(thrust, *torques)
        assert fast == staged(thrust, *torques)
        assert all(0.0 <= t <= 1.0 for t in fast)  # what Vehicle.control_step relies on
    assert 100 < len(handed_over) < 2900  # both the one-pass and the limiting cases were exercised


# ------------------------------------------------------------------- controller


class _ReferenceController:
    """The cascade written the plain way (one helper per loop, lists, min/max)."""

    def __init__(self, gains, mass, inertia, mixer, dt, mode):
        self.g, self.mass, self.inertia, self.mixer, self.dt, self.mode = gains, mass, inertia, mixer, dt, mode
        self.rate_i, self.prev, self.vel_i = [0.0, 0.0, 0.0], None, [0.0, 0.0, 0.0]

    @staticmethod
    def _clip(v, lim):
        return lim if v > lim else -lim if v < -lim else v  # noqa: FURB136 - as the original _clip

    def rate(self, s, sp):
        g, dt = self.g.rate, self.dt
        w = s.ang_vel
        prev = self.prev or w
        self.prev = w
        out = []
        for i in range(3):
            e = sp[i] - w[i]
            lim = g.integral_limit[i] / g.ki[i] if g.ki[i] > 0 else 0.0
            self.rate_i[i] = self._clip(self.rate_i[i] + e * dt, lim)
            out.append(g.kp[i] * e + g.ki[i] * self.rate_i[i] - g.kd[i] * (w[i] - prev[i]) / dt)
        jx, jy, jz = self.inertia
        wx, wy, wz = w
        return (jx * out[0] + (jz - jy) * wy * wz, jy * out[1] + (jx - jz) * wz * wx, jz * out[2] + (jy - jx) * wx * wy)

    def velocity(self, s, sp):
        g, out = self.g.velocity, [0.0, 0.0, 0.0]
        for i, v in enumerate(sp):
            if v is None:
                continue
            e = v - s.lin_vel_ground[i]
            if -g.integral_window < e < g.integral_window:
                lim = g.integral_limit[i] / g.ki[i] if g.ki[i] > 0 else 0.0
                self.vel_i[i] = self._clip(self.vel_i[i] + e * self.dt, lim)
            out[i] = g.kp[i] * e + g.ki[i] * self.vel_i[i]
        return out

    def attitude(self, s, roll, pitch, yaw, yaw_rate):
        g, cur = self.g.attitude, s.ang_pos
        r = yaw_rate if yaw is None else g.kp[2] * wrap_angle(yaw - cur[2])
        p_sp = self._clip(g.kp[0] * (roll - cur[0]), g.max_rate[0])
        q_sp = self._clip(g.kp[1] * (pitch - cur[1]), g.max_rate[1])
        return p_sp, q_sp, self._clip(r, g.max_rate[2])

    def thrust(self, s, az):
        tilt = max(math.cos(s.ang_pos[0]) * math.cos(s.ang_pos[1]), 0.5)
        return max(self.mass * (GRAVITY + az) / tilt, 0.0)

    def climb(self, s, z):
        return self._clip(self.g.position.kp[2] * (z - s.lin_pos[2]), self.g.position.max_velocity[2])

    def __call__(self, s, sp):
        name, (a, b, c, d) = self.mode, sp
        if name == "rates_thrust":
            return self.mixer.throttles(d * self.mixer.max_collective, *self.rate(s, (a, b, c)))
        if name == "rates_z":
            az = self.velocity(s, (None, None, self.climb(s, d)))[2]
            return self.mixer.throttles(self.thrust(s, az), *self.rate(s, (a, b, c)))
        if name in ("attitude_vz", "attitude_z"):
            az = self.velocity(s, (None, None, d if name == "attitude_vz" else self.climb(s, d)))[2]
            rates = self.attitude(s, a, b, c, 0.0)
            return self.mixer.throttles(self.thrust(s, az), *self.rate(s, rates))
        yaw_rate_modes = ("heading_velocity_z", "heading_velocity_vz", "velocity_yawrate", "position_yawrate")
        yaw, yaw_rate = (None, c) if name in yaw_rate_modes else (c, 0.0)
        if name.startswith("heading"):
            h = s.ang_pos[2]
            vx, vy = math.cos(h) * a - math.sin(h) * b, math.sin(h) * a + math.cos(h) * b
        elif name.startswith("velocity"):
            vx, vy = a, b
        else:
            pg, pos = self.g.position, s.lin_pos
            vx = self._clip(pg.kp[0] * (a - pos[0]), pg.max_velocity[0])
            vy = self._clip(pg.kp[1] * (b - pos[1]), pg.max_velocity[1])
        vz = self.climb(s, d) if name in ("heading_velocity_z", "position_yaw", "position_yawrate") else d
        ax, ay, az = self.velocity(s, (vx, vy, vz))
        cy, sy = math.cos(s.ang_pos[2]), math.sin(s.ang_pos[2])
        forward, left = cy * ax + sy * ay, -sy * ax + cy * ay
        lift = max(GRAVITY + az, 0.1 * GRAVITY)
        pitch = math.atan2(forward, lift)
        roll = math.atan2(-left * math.cos(pitch), lift)
        tilt = self.g.velocity.max_tilt
        rates = self.attitude(s, self._clip(roll, tilt), self._clip(pitch, tilt), yaw, yaw_rate)
        return self.mixer.throttles(self.thrust(s, az), *self.rate(s, rates))


def _random_state(rng) -> KinematicState:
    quat = euler_to_quaternion(*rng.uniform([-0.8, -0.8, -math.pi], [0.8, 0.8, math.pi]).tolist())
    euler = p.getEulerFromQuaternion(quat)

    def v3(scale: float) -> tuple[float, float, float]:
        return tuple(rng.normal(0, scale, 3).tolist())

    return KinematicState(v3(2.0), euler, v3(2.0), v3(3.0), quat, v3(2.0), v3(2.0))


@pytest.mark.parametrize("mode", [m for m in MULTIROTOR_MODES if m != "motors"])
def test_controller_equals_the_plain_cascade(mode):
    # non-zero derivative gains and an asymmetric inertia exercise every term
    spec = spec_variant("quadx_f450", **{"control.rate.kd": [0.02, 0.03, 0.01], "body.inertia": [0.011, 0.009, 0.016]})
    vehicle = World([VehicleConfig(spec)], seed=0).vehicles[0]
    args = (spec.control, vehicle.parts.mass, np.diag(vehicle.parts.inertia), vehicle.mixer, 1 / 120)
    controller = MultirotorController(*args)
    controller.set_mode(MULTIROTOR_MODES[mode])
    reference = _ReferenceController(*args[:2], tuple(float(i) for i in args[2]), *args[3:], mode)
    rng = np.random.default_rng(len(mode))
    for _ in range(300):  # integrators and derivative memory carry over between calls
        state = _random_state(rng)
        setpoint = rng.normal(0, 1, 4).tolist()
        if mode == "rates_thrust":
            setpoint[3] = float(rng.uniform(0, 1))
        assert controller(state, setpoint) == reference(state, setpoint)


def test_motors_mode_limits_the_command():
    world = World([VehicleConfig("quadx_cf2x", (0, 0, 1), mode="motors")], seed=0)
    world.set_setpoint(0, [1.5, -2.0, 0.25, -0.5])
    world.vehicles[0].control_step()
    assert world.vehicles[0].motor_command.tolist() == [1.0, -1.0, 0.25, -0.5]


# -------------------------------------------------------------------- lazy state


def test_state_after_a_step_is_read_when_asked_and_reading_it_changes_nothing():
    def run(read_every_step: bool) -> str:
        world = World([VehicleConfig("quadx_cf2x", (0, 0, 1), mode="position_yaw")], seed=1)
        world.set_setpoint(0, [0.5, 0.2, 0.1, 1.4])
        out = []
        for i in range(20):
            world.step()
            if read_every_step or i % 7 == 0:
                out.append((world.state(0), world.aux_state(0).tolist()))
        out.append((world.state(0), world.aux_state(0).tolist()))
        world.close()
        return hashlib.sha256(repr(out[-1]).encode()).hexdigest()

    assert run(True) == run(False)
    world = World([VehicleConfig("quadx_cf2x", (0, 0, 1), mode="motors")], seed=0)
    vehicle = world.vehicles[0]
    world.step()
    lazily = vehicle.state
    assert lazily == vehicle.read_state()
    assert vehicle.state is vehicle.state  # read once, then kept until the next step
    # a pose set directly in PyBullet between steps shows in the state read after it
    world.step()
    p.resetBasePositionAndOrientation(vehicle.body_id, [5.0, 0.0, 1.0], [0, 0, 0, 1], physicsClientId=world.client)
    assert vehicle.state.lin_pos[0] == 5.0
    world.close()
