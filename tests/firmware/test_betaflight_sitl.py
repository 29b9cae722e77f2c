"""Betaflight's own firmware (SITL, lockstep) flying the simulator, against oracles.

Marked ``firmware``: they need the patched SITL binary (``python -m
pyflyt_engine.firmware.build``); CI builds it and runs ``pytest -m firmware``.  A missing
binary fails them with the build command rather than skipping them.
"""

from __future__ import annotations

import hashlib
import math
import socket
import threading

import numpy as np
import pytest

from pyflyt_engine.firmware import sitl
from pyflyt_engine.firmware.betaflight import actual_rate
from pyflyt_engine.firmware.sitl import FirmwareError
from pyflyt_engine.spec import load_uav_spec
from pyflyt_engine.world import World

pytestmark = pytest.mark.firmware

HZ = 1000  # physics, control and the firmware's gyro/PID rate
AGENT_HZ = 50


@pytest.fixture(autouse=True)
def _binary():
    try:
        sitl.binary_path()
    except FirmwareError as error:
        pytest.fail(str(error))


def _world(uav="quadx_cf2x", mode="acro", position=(0.0, 0.0, 5.0), orientation=(0.0, 0.0, 0.0), seed=1, **firmware):
    spec = load_uav_spec(uav)
    data = spec.model_dump()
    data["control"]["firmware"] = {"mode": mode, **firmware}
    world = World(physics_hz=HZ, control_hz=HZ, agent_hz=AGENT_HZ, seed=seed)
    vehicle = world.vehicles[world.add_vehicle(type(spec).model_validate(data), position, orientation)]
    world.reset(seed=seed)
    return world, vehicle


def _fly(world, vehicle, setpoint, seconds):
    states = []
    for _ in range(int(round(seconds * AGENT_HZ))):
        vehicle.set_setpoint(setpoint(vehicle.state) if callable(setpoint) else setpoint)
        world.step()
        states.append(vehicle.state)
    return states


def _own_world(uav, position, orientation=(0.0, 0.0, 0.0), seed=1, mode="rates_thrust"):
    """The same airframe flown by the project's own cascade at the firmware's loop rates."""
    world = World(physics_hz=HZ, control_hz=HZ, agent_hz=AGENT_HZ, seed=seed)
    vehicle = world.vehicles[world.add_vehicle(load_uav_spec(uav), position, orientation)]
    world.reset(seed=seed)
    vehicle.set_mode(mode)
    return world, vehicle


def test_arms_at_reset_and_idles_then_takes_off_on_throttle():
    # Betaflight's own (stiff) rate PIDs hold it level on the way up; the airframe's matched
    # ones drift as its own rate loop does (0.12-0.23 rad over this climb)
    world, vehicle = _world(position=(0.0, 0.0, 0.0), pids="firmware")
    try:
        idle = vehicle.firmware.outputs
        # armed at the reset: every motor at Betaflight's idle (motor_idle 5.5 %), none spinning up
        assert all(o == pytest.approx(0.055, abs=1e-6) for o in idle)
        _fly(world, vehicle, [0.0, 0.0, 0.0, 0.0], 0.5)
        assert vehicle.state.lin_pos[2] == pytest.approx(0.0, abs=0.02)  # idle thrust does not lift it
        states = _fly(world, vehicle, [0.0, 0.0, 0.0, 0.6], 1.0)  # above hover (0.354)
        assert states[-1].lin_pos[2] > 0.5
        assert max(abs(a) for s in states for a in s.ang_pos[:2]) < 0.1  # straight up
    finally:
        world.close()


def test_disarmed_the_motors_stop():
    world, vehicle = _world(position=(0.0, 0.0, 0.0))
    try:
        vehicle.armed = False
        _fly(world, vehicle, [0.0, 0.0, 0.0, 0.8], 0.2)
        assert vehicle.firmware.outputs == (0.0, 0.0, 0.0, 0.0)
        assert vehicle.state.lin_pos[2] == pytest.approx(0.0, abs=0.01)
    finally:
        world.close()


def _altitude_hold(hover, z_ref):
    def sticks(state, roll=0.0, pitch=0.0):
        return [roll, pitch, 0.0, hover + 0.3 * (z_ref - state.lin_pos[2]) - 0.2 * state.lin_vel_ground[2]]

    return sticks


@pytest.mark.parametrize("uav", ["quadx_cf2x", "quadx_f450"])
def test_angle_mode_levels_and_holds_attitude(uav):
    # Betaflight's default PIDs (tuned for racing quads) hold it level within 0.5 deg
    world, vehicle = _world(uav, mode="angle", orientation=(0.2, -0.15, 0.0), pids="firmware")
    try:
        hold = _altitude_hold(vehicle.hover_throttle(), 5.0)
        _fly(world, vehicle, hold, 1.0)  # levels from a 0.2 rad roll, -0.15 rad pitch
        states = _fly(world, vehicle, hold, 2.0)
        worst = max(abs(a) for s in states for a in s.ang_pos[:2])
        assert worst < math.radians(1.5), f"level within 1.5 deg, worst {math.degrees(worst):.2f} deg"
    finally:
        world.close()


@pytest.mark.parametrize("uav", ["quadx_cf2x", "quadx_f450"])
def test_matched_angle_mode_holds_attitude_as_the_project_s_attitude_loop(uav):
    """With the matched gains (the default), ANGLE levels as the airframe's own cascade in
    attitude_z does from the same start: the worst tilt over 2 s agrees within 0.1 deg
    (measured 0.00-0.02 deg; the cf2x's 2 % motor noise keeps both within ~2.3 deg)."""
    world, vehicle = _world(uav, mode="angle", orientation=(0.2, -0.15, 0.0))
    try:
        hold = _altitude_hold(vehicle.hover_throttle(), 5.0)
        _fly(world, vehicle, hold, 1.0)
        firmware = max(abs(a) for s in _fly(world, vehicle, hold, 2.0) for a in s.ang_pos[:2])
    finally:
        world.close()
    world, vehicle = _own_world(uav, (0.0, 0.0, 5.0), (0.2, -0.15, 0.0), mode="attitude_z")
    try:
        _fly(world, vehicle, [0.0, 0.0, 0.0, 5.0], 1.0)
        own = max(abs(a) for s in _fly(world, vehicle, [0.0, 0.0, 0.0, 5.0], 2.0) for a in s.ang_pos[:2])
    finally:
        world.close()
    assert math.degrees(abs(firmware - own)) < 0.1, (math.degrees(firmware), math.degrees(own))
    assert firmware < math.radians(3.0)


def _rate_step(world, vehicle, axis, rate=1.0):
    """Body rates after a step of ``rate`` [rad/s] on ``axis`` from a 0.5 s hover (rates_thrust)."""
    thrust = vehicle.hover_throttle() ** 2  # rates_thrust's thrust: a fraction of the full thrust
    _fly(world, vehicle, [0.0, 0.0, 0.0, thrust], 0.5)
    setpoint = [0.0, 0.0, 0.0, thrust]
    setpoint[axis] = rate
    return np.array([s.ang_vel[axis] for s in _fly(world, vehicle, setpoint, 0.6)])


@pytest.mark.parametrize("uav", ["quadx_cf2x", "quadx_f450"])
@pytest.mark.parametrize("axis", [0, 1, 2])
def test_matched_pids_follow_the_project_s_rate_loop(uav, axis):
    """The matched rate PIDs (``pids: matched``, the default; :func:`matched_pids`) make the
    firmware's response to a 1 rad/s rate step the project's rate loop's: within 0.05 rad/s on
    roll and pitch over 0.6 s (measured 0.013-0.029), 0.15 rad/s on yaw (0.09-0.13: whole-number
    I gains, 2.9 -> 3 on the cf2x).  Betaflight's defaults respond otherwise (0.38-1.19 rad/s)."""
    responses = {}
    for pids in ("matched", "firmware"):
        world, vehicle = _world(uav, pids=pids)
        try:
            vehicle.set_mode("rates_thrust")
            responses[pids] = _rate_step(world, vehicle, axis)
        finally:
            world.close()
    world, vehicle = _own_world(uav, (0.0, 0.0, 5.0))
    try:
        own = _rate_step(world, vehicle, axis)
    finally:
        world.close()
    bound = 0.05 if axis < 2 else 0.15
    assert np.max(np.abs(responses["matched"] - own)) < bound
    assert np.max(np.abs(responses["firmware"] - own)) > 0.3  # the matching is what makes them agree
    assert own[-10:].mean() == pytest.approx(1.0, abs=0.1)  # both settled at the step's rate


@pytest.mark.parametrize(("limit", "stick"), [(30, 0.5), (60, 0.5), (30, 1.0)])
def test_angle_mode_stick_is_a_tilt_on_the_rate_curve(limit, stick):
    world, vehicle = _world("quadx_f450", mode="angle", angle_limit=limit)
    try:
        hover = vehicle.hover_throttle()
        states = _fly(world, vehicle, lambda s: [stick, 0.0, 0.0, hover / math.sqrt(math.cos(s.ang_pos[0]))], 1.5)
        roll = math.degrees(np.mean([s.ang_pos[0] for s in states[-25:]]))
        # pid.c lines 556-568: the target is angle_limit * rate(stick) / rate(full stick)
        by_hand = limit * actual_rate(stick, 7, 67, 0) / actual_rate(1.0, 7, 67, 0)
        assert roll == pytest.approx(by_hand, abs=0.5)
    finally:
        world.close()


@pytest.mark.parametrize(
    ("axis", "stick", "rates"),
    [
        (0, 0.25, {}),
        (1, 0.25, {}),
        (2, 0.25, {}),
        (0, 0.5, {"rc_rate": [10, 10, 10], "super_rate": [40, 40, 40], "expo": [50, 50, 50]}),
    ],
)
def test_acro_rate_steps_follow_the_rate_curve(axis, stick, rates):
    # Betaflight's default PIDs: roll and pitch settle within 0.2 s
    world, vehicle = _world("quadx_f450", pids="firmware", **rates)
    try:
        hover = vehicle.hover_throttle()
        _fly(world, vehicle, [0.0, 0.0, 0.0, hover], 0.5)
        sp = [0.0, 0.0, 0.0, hover]
        sp[axis] = stick
        # roll and pitch settle within 0.2 s; the F450's yaw (Betaflight's default yaw gains on
        # a large yaw inertia) swings slowly about its rate: averaged over 2 s
        seconds, window = (0.4, 10) if axis < 2 else (3.0, 100)
        states = _fly(world, vehicle, sp, seconds)
        measured = math.degrees(np.mean([s.ang_vel[axis] for s in states[-window:]]))
        defaults = {"rc_rate": 7, "super_rate": 67, "expo": 0}
        rc, sr, ex = (rates[k][axis] if k in rates else defaults[k] for k in ("rc_rate", "super_rate", "expo"))
        expected = actual_rate(stick, rc, sr, ex)
        assert measured == pytest.approx(expected, rel=0.08), (
            f"axis {axis}: {measured:.1f} vs curve {expected:.1f} deg/s"
        )
    finally:
        world.close()


def test_failsafe_when_the_radio_stops():
    world, vehicle = _world("quadx_f450", mode="angle")
    try:
        hold = _altitude_hold(vehicle.hover_throttle(), 5.0)
        _fly(world, vehicle, hold, 1.0)
        vehicle.firmware.radio = False  # ticks without RC from here
        _fly(world, vehicle, hold, 0.2)
        # the link's loss is not declared yet: it flies on the last sticks
        assert min(vehicle.firmware.outputs) > 0.4 and vehicle.state.lin_pos[2] == pytest.approx(5.0, abs=0.05)
        _fly(world, vehicle, hold, 0.4)
        # stage 1 of failsafe_procedure DROP: "at idle" (failsafe.c line 74) for failsafe_delay
        # (1.5 s), still armed and levelling
        assert 0.0 < max(vehicle.firmware.outputs) < 0.1
        falling = _fly(world, vehicle, hold, 1.0)
        assert falling[-1].lin_pos[2] < 3.5 and max(abs(a) for s in falling for a in s.ang_pos[:2]) < 0.1
        _fly(world, vehicle, hold, 1.0)
        assert vehicle.firmware.outputs == (0.0, 0.0, 0.0, 0.0)  # stage 2: disarmed, motors off
    finally:
        world.close()


def _digest(seed=7, uav="quadx_cf2x"):
    world, vehicle = _world(uav, seed=seed)
    try:
        hover = vehicle.hover_throttle()
        h = hashlib.sha256()
        for k in range(100):
            vehicle.set_setpoint([0.2 * math.sin(k / 10), 0.05, -0.05, hover])
            world.step()
            h.update(vehicle.state.as_array().tobytes())
        return h.hexdigest()
    finally:
        world.close()


def test_runs_are_bit_identical_and_parallel_envs_do_not_interfere():
    alone = _digest()
    assert _digest() == alone
    results = {}

    def run(key, seed):
        results[key] = _digest(seed)

    threads = [threading.Thread(target=run, args=(k, 7)) for k in ("a", "b")]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert results == {"a": alone, "b": alone}


def test_a_port_in_use_is_one_clear_error_and_nothing_is_left_running(tmp_path):
    udp, tcp, servo = sitl.free_ports()
    holder = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    holder.bind(("0.0.0.0", tcp + 1))
    holder.listen()
    try:
        with pytest.raises(FirmwareError, match="could not bind its ports") as caught:
            sitl.SITLProcess(tmp_path, 1000, lockstep=True, ports=(udp, tcp, servo))
        assert "another process holds one" in str(caught.value)
    finally:
        holder.close()
    # the process is gone and its servo port free again
    assert sitl._udp_free(udp + 2)


def test_a_sitl_that_does_not_answer_is_one_clear_error(tmp_path, monkeypatch):
    hang = tmp_path / "hang"
    hang.write_text("#!/bin/sh\nexec sleep 600\n")
    hang.chmod(0o755)
    monkeypatch.setenv("PYFLYT_BETAFLIGHT_SITL", str(hang))
    monkeypatch.setattr(sitl, "START_TIMEOUT_S", 1.0)
    with pytest.raises(FirmwareError, match="did not open its ports within 1 s"):
        sitl.SITLProcess(tmp_path, 1000, lockstep=True)


def test_a_firmware_that_exits_is_one_clear_error(tmp_path, monkeypatch):
    monkeypatch.setenv("PYFLYT_BETAFLIGHT_SITL", "/bin/false")
    with pytest.raises(FirmwareError, match="exited during start-up"):
        sitl.SITLProcess(tmp_path, 1000, lockstep=True)


def test_the_env_passes_gymnasiums_checker_and_replays_bit_for_bit(tmp_path):
    from gymnasium.utils.env_checker import check_env

    from pyflyt_engine.envs import make_env
    from pyflyt_engine.telemetry import load_episode
    from pyflyt_engine.telemetry.recorder import RecordEpisode
    from pyflyt_engine.telemetry.replay import verify

    env = make_env("quadx_hover", controller="betaflight")
    try:
        check_env(env, skip_render_check=True)  # its determinism check included
    finally:
        env.close()
    recorded = RecordEpisode(make_env("quadx_hover", controller="betaflight"), tmp_path)
    try:
        recorded.reset(seed=3)
        rng = np.random.default_rng(0)
        for _ in range(60):
            action = np.array([0.05 * rng.standard_normal(), 0.05 * rng.standard_normal(), 0.0, 0.36])
            *_, terminated, truncated, _ = recorded.step(action)
            if terminated or truncated:
                break
    finally:
        recorded.close()
    result = verify(load_episode(recorded.paths[0], warn=False))
    assert result.steps > 10 and result.max_deviation == 0.0 and result.max_reward_deviation == 0.0


@pytest.mark.parametrize("uav", ["quadx_cf2x", "quadx_f450"])
def test_pyflyt_fly_with_the_firmware_hovers(uav):
    from pyflyt_engine.flight import fly

    trajectory = fly(uav, "position_yaw", None, 8.0, controller="betaflight")
    assert trajectory.mode == "angle"
    final = trajectory.position[-1]
    assert abs(final[2] - 1.0) < 0.05 and math.hypot(final[0], final[1]) < 0.05


def test_a_hung_firmware_is_replaced_and_replayed_without_changing_the_run(monkeypatch):
    """A firmware that stops answering mid-flight (here: stopped with SIGSTOP) is replaced by a
    fresh one sent every datagram since its start: the flight goes on with the same numbers,
    bit for bit, as one whose firmware never hung."""
    import os
    import signal

    monkeypatch.setattr(sitl, "TICK_TIMEOUT_S", 1.0)
    rng = np.random.default_rng(4)
    sticks = [[0.1 * rng.standard_normal(), 0.1 * rng.standard_normal(), 0.0, 0.4] for _ in range(40)]

    def flight(hang_at=None):
        world, vehicle = _world()
        try:
            states = []
            for step, setpoint in enumerate(sticks):
                if step == hang_at:
                    os.kill(vehicle.firmware._sitl.process.process.pid, signal.SIGSTOP)
                vehicle.set_setpoint(setpoint)
                world.step()
                states.append(vehicle.state.as_array())
            return np.array(states), vehicle.firmware.restarts
        finally:
            world.close()

    calm, calm_restarts = flight()
    hung, restarts = flight(hang_at=15)
    assert (calm_restarts, restarts) == (0, 1)
    assert np.array_equal(calm, hung)
