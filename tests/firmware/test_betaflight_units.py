"""The Betaflight bridge's pieces that need no firmware: packet layouts, the rate curve by
hand, stick channels, the motor map, the spec's checks and the missing-binary message."""

from __future__ import annotations

import struct

import pytest

from pyflyt_engine.errors import ConfigError
from pyflyt_engine.firmware import packets
from pyflyt_engine.firmware.betaflight import actual_rate, configuration, motor_map, sticks_to_channels
from pyflyt_engine.firmware.sitl import FirmwareError, binary_path
from pyflyt_engine.spec import BetaflightSpec, load_uav_spec


def test_packet_sizes_match_the_c_structs():
    # target.h: fdm_packet 1 + 3 + 3 + 4 + 3 + 3 + 1 doubles, rc_packet a double and 16 uint16,
    # servo_packet 4 floats
    assert packets.FDM.size == 18 * 8 == 144
    assert packets.RC.size == 8 + 16 * 2 == 40
    assert packets.SERVO.size == 16
    tick = packets.tick_datagram(0.5, (1, 2, 3), (4, 5, 6), (1, 0, 0, 0), (7, 8, 9), (10, 11, 12), 101325.0, None)
    assert len(tick) == 144 and struct.unpack("<d", tick[:8]) == (0.5,)
    with_rc = packets.tick_datagram(0.5, (0,) * 3, (0,) * 3, (1, 0, 0, 0), (0,) * 3, (0,) * 3, 0.0, [1500] * 16)
    assert len(with_rc) == 184 and struct.unpack("<16H", with_rc[152:]) == (1500,) * 16


def test_servo_order_is_sitl_cs():
    # sitl.c: motor_speed[3] = motor 1, [0] = motor 2, [1] = motor 3, [2] = motor 4
    assert packets.motors_from_servo(struct.pack("<4f", 0.25, 0.5, 0.75, 1.0)) == (1.0, 0.25, 0.5, 0.75)


@pytest.mark.parametrize(
    ("stick", "rc_rate", "super_rate", "expo", "by_hand"),
    [
        (0.0, 7, 67, 0, 0.0),
        (1.0, 7, 67, 0, 670.0),  # full stick: the max rate, 10 * super_rate
        (0.25, 7, 67, 0, 0.25 * 70 + 600 * 0.25 * 0.25),  # 55 deg/s
        (-0.25, 7, 67, 0, -55.0),  # odd in the stick
        # centre 100, movement 300, e 0.5: 0.5 * 100 + 300 * 0.5 * (0.5^5 * 0.5 + 0.5 * 0.5)
        (0.5, 10, 40, 50, 50.0 + 150.0 * (0.03125 * 0.5 + 0.25)),
        (0.5, 50, 40, 0, 250.0),  # centre above the max: no stick movement term
    ],
)
def test_actual_rate_curve_by_hand(stick, rc_rate, super_rate, expo, by_hand):
    assert actual_rate(stick, rc_rate, super_rate, expo) == pytest.approx(by_hand, rel=1e-12, abs=1e-12)


def test_sticks_to_channels():
    channels = sticks_to_channels([1.0, -0.5, 0.5, 0.25], armed=True, angle=False)
    # roll right 2000, pitch back 1250, throttle 1250, yaw left (positive) is rudder left 1250
    assert channels[:6] == [2000, 1250, 1250, 1250, 2000, 1000]
    assert sticks_to_channels([0, 0, 0, 0], armed=False, angle=True)[:6] == [1500, 1500, 1000, 1500, 1000, 2000]
    assert sticks_to_channels([9, -9, 0, 7], armed=True, angle=False)[:3] == [2000, 1000, 2000]  # clipped


def test_motor_map_of_the_shipped_quads():
    for name in ("quadx_cf2x", "quadx_f450"):
        spec = load_uav_spec(name)
        from pyflyt_engine.assembly import assemble

        parts = assemble(spec)
        order, reversed_spin = motor_map(parts.motors, parts.mixer_motors)
        # Betaflight's rear right, front right, rear left, front left: motors 4, 1, 2, 3
        assert order == (3, 0, 1, 2) and reversed_spin is False


def test_motor_map_refuses_what_is_not_a_quad_x():
    from pyflyt_engine.assembly import assemble

    parts = assemble(load_uav_spec("hexacopter"))
    with pytest.raises(ConfigError, match="quad X: the airframe has 6 mixer motors"):
        motor_map(parts.motors, parts.mixer_motors)


def test_configuration_carries_the_rates_and_the_specs_commands():
    spec = BetaflightSpec(rc_rate=[10, 11, 12], super_rate=[40, 41, 42], expo=[0, 5, 50], cli=["set p_roll = 50"])
    commands = configuration(spec, reversed_spin=True)
    for line in ("set roll_rc_rate = 10", "set pitch_srate = 41", "set yaw_expo = 50", "set yaw_motors_reversed = ON"):
        assert line in commands
    assert commands[-1] == "set p_roll = 50"


@pytest.mark.parametrize("bad", [{"rc_rate": [7, 7]}, {"expo": [0, 0, 300]}, {"cli": ["save"]}, {"cli": ["a\nb"]}])
def test_spec_refuses_bad_firmware_settings(bad):
    with pytest.raises(ValueError):
        BetaflightSpec(**bad)


def test_missing_binary_names_the_build_command(monkeypatch, tmp_path):
    monkeypatch.setenv("PYFLYT_BETAFLIGHT_SITL", str(tmp_path / "nothing"))
    with pytest.raises(FirmwareError, match="python -m pyflyt_engine.firmware.build"):
        binary_path()


@pytest.mark.parametrize("stick", [-1.0, -0.4, 0.0, 0.1, 0.25, 0.7, 1.0])
def test_stick_for_rate_inverts_the_rate_curve(stick):
    from pyflyt_engine.firmware.betaflight import stick_for_rate

    spec = BetaflightSpec(rc_rate=[10, 7, 7], super_rate=[40, 67, 67], expo=[50, 0, 0])
    for axis in range(3):
        rate = actual_rate(stick, spec.rc_rate[axis], spec.super_rate[axis], spec.expo[axis])
        assert stick_for_rate(rate, spec, axis) == pytest.approx(stick, abs=1e-9)
    assert stick_for_rate(1e4, spec, 0) == pytest.approx(1.0)  # beyond the maximum rate: full stick


def test_throttle_stick_is_the_square_root_of_the_thrust_fraction():
    from pyflyt_engine.firmware.betaflight import throttle_stick

    assert throttle_stick(0.25) == 0.5 and throttle_stick(0.0) == 0.0 and throttle_stick(4.0) == 1.0


def test_an_env_with_the_firmware_flies_sticks_at_rates_its_clock_follows():
    from pyflyt_engine.envs.config import load_env_config

    sticks = load_env_config("quadx_hover").with_overrides(controller="betaflight")
    assert (sticks.physics_hz, sticks.control_hz, sticks.agent_hz) == (1000.0, 1000.0, 50.0)
    assert sticks.action.mode == "acro" and sticks.action.names == ["roll", "pitch", "yaw", "throttle"]
    assert sticks.action.low == [-1.0, -1.0, -1.0, 0.0] and sticks.action.high == [1.0, 1.0, 1.0, 1.0]
    rates = load_env_config("quadx_hover").with_overrides(controller="betaflight", firmware_action="rates")
    assert (rates.physics_hz, rates.control_hz, rates.agent_hz) == (1500.0, 500.0, 30.0)
    assert rates.action == load_env_config("quadx_hover").action  # the own controller's space, unchanged
    own = load_env_config("quadx_hover")
    assert (own.physics_hz, own.control_hz, own.agent_hz, own.controller) == (240.0, 120.0, 30.0, "own")


def test_an_env_whose_action_the_firmware_cannot_fly_is_refused():
    from pyflyt_engine.envs.config import load_env_config

    with pytest.raises(Exception, match="controller betaflight flies the modes acro and angle"):
        load_env_config("quadx_waypoints_velocity").with_overrides(controller="betaflight")


def test_with_betaflight_refuses_what_has_no_multirotor_controller():
    from pyflyt_engine.firmware.betaflight import with_betaflight

    with pytest.raises(ConfigError, match="replaces a multirotor controller"):
        with_betaflight(load_uav_spec("fixedwing"), "acro")
    with pytest.raises(ConfigError, match="flies the modes acro, angle, rates_thrust"):
        with_betaflight(load_uav_spec("quadx_cf2x"), "position_yaw")
    flown = with_betaflight(load_uav_spec("quadx_cf2x"), "rates_thrust")
    assert flown.control.firmware.mode == "acro"


def _fake_source(root):
    (root / "src" / "platform" / "SIMULATOR").mkdir(parents=True)
    (root / "src" / "platform" / "SIMULATOR" / "sitl.c").write_text("")
    return root


def test_build_without_a_compiler_is_one_clear_error(monkeypatch, tmp_path):
    from pyflyt_engine.firmware import build

    monkeypatch.setenv("PATH", str(tmp_path))  # no gcc, make or patch on it
    with pytest.raises(FirmwareError, match="needs gcc .*not on PATH: install it"):
        build.build(source=_fake_source(tmp_path / "bf"), out=tmp_path / "sitl")


def test_build_of_a_source_that_is_not_betaflights_is_one_clear_error(tmp_path):
    from pyflyt_engine.firmware import build

    with pytest.raises(FirmwareError, match="is not Betaflight's source: it has no src/platform/SIMULATOR/sitl.c"):
        build.build(source=tmp_path, out=tmp_path / "sitl", force=True)
    assert not (tmp_path / "sitl").exists()


def test_build_command_exits_non_zero_with_one_line(tmp_path, capsys, monkeypatch):
    from pyflyt_engine.firmware import build

    monkeypatch.setenv("PATH", str(tmp_path))
    assert build.main(["--source", str(_fake_source(tmp_path / "bf")), "--out", str(tmp_path / "sitl")]) == 1
    err = capsys.readouterr().err
    assert err.startswith("error: building the Betaflight SITL needs gcc") and err.count("\n") == 1


def test_the_controller_keys_count_in_a_runs_identity_only_when_not_the_default():
    """Runs recorded before ``env.controller`` / ``env.firmware_action`` existed keep their
    identity (the airframe's own controller then), and choosing the firmware makes another run."""
    from pyflyt_cli.training.compose import compose_config
    from pyflyt_cli.training.rundir import identity

    own = identity(compose_config(overrides=["env=quadx_hover", "algo=ppo"]))
    assert "env.controller" not in own and "env.firmware_action" not in own
    firmware = identity(compose_config(overrides=["env=quadx_hover", "algo=ppo", "env.controller=betaflight"]))
    assert firmware["env.controller"] == "betaflight"


@pytest.mark.parametrize(
    ("uav", "arm", "rate_p", "rate_i", "level"),
    [
        # the cf2x: 27 g, J = 1.4e-5 / 1.4e-5 / 2.17e-5 kg m^2, arms 0.028 m (x and y),
        # kf 3.16e-10 N/rpm^2, kt 7.94e-12 N m/rpm^2, 40 943 rpm; kp 60/60/30, ki 200/200/66
        ("quadx_cf2x", 0.028, (60.0, 60.0, 30.0), (200.0, 200.0, 66.0), 80),
        # the F450: 1 kg, J = 0.01 / 0.01 / 0.016, the airframe's defaults kp 25/25/15, ki 50/50/30
        ("quadx_f450", None, (25.0, 25.0, 15.0), (50.0, 50.0, 30.0), 80),
    ],
)
def test_matched_pids_by_hand(uav, arm, rate_p, rate_i, level):
    """matched_pids equates Betaflight's per-motor output change per deg/s of rate error,
    P 0.032029 (180/pi) (1 - 0.055) / 1000 (pid.h, mixer.c), with the project's: the torque
    J kp, split over the four motors of the X (tau / (4 arm) each about roll and pitch,
    tau / (4 kt/kf) about yaw) and turned into throttle by d sqrt(f / f_max) / df =
    1 / (2 sqrt(f_h f_max)) at the hover thrust f_h = m g / 4."""
    import math

    import numpy as np

    from pyflyt_engine.assembly import assemble
    from pyflyt_engine.control.mixer import flight_mixer
    from pyflyt_engine.firmware.betaflight import matched_level_gain, matched_pids

    spec = load_uav_spec(uav)
    motors = spec.motors
    kf, kt, rpm = float(np.ravel(motors.kf)[0]), float(np.ravel(motors.kt)[0]), float(np.ravel(motors.max_rpm)[0])
    arm = arm if arm is not None else abs(float(motors.positions[0][1]))
    f_max, f_hover = kf * rpm**2, spec.body.mass * 9.80665 / 4
    inertia = spec.inertia_matrix().diagonal()
    per_newton = 1.0 / (2.0 * math.sqrt(f_hover * f_max))  # throttle per N of one motor's thrust
    per_torque = (per_newton / (4 * arm), per_newton / (4 * arm), per_newton / (4 * kt / kf))
    scale = math.degrees(1.0) * 0.945 / 1000.0
    by_hand = tuple(
        (
            round(inertia[a] * per_torque[a] * rate_p[a] / (0.032029 * scale)),
            round(inertia[a] * per_torque[a] * rate_i[a] / (0.244381 * scale)),
            0,
        )
        for a in range(3)
    )
    parts = assemble(spec)
    assert tuple(spec.control.rate.kp) == rate_p and tuple(spec.control.rate.ki) == rate_i
    assert matched_pids(spec.control, parts.mass, inertia.tolist(), flight_mixer(parts)) == by_hand
    assert matched_level_gain(spec.control) == level  # 10 x the attitude loop's 8 /s


def test_matched_pids_refuse_gains_beyond_betaflight_s_range():
    from pyflyt_engine.assembly import assemble
    from pyflyt_engine.control.mixer import flight_mixer
    from pyflyt_engine.firmware.betaflight import matched_pids

    spec = load_uav_spec("quadx_f450")
    stiff = spec.control.model_copy(update={"rate": spec.control.rate.model_copy(update={"kp": (25.0, 25.0, 60.0)})})
    parts = assemble(spec)
    with pytest.raises(ConfigError, match="yaw rate loop needs a Betaflight P of 873, beyond its 250"):
        matched_pids(stiff, parts.mass, spec.inertia_matrix().diagonal().tolist(), flight_mixer(parts))


def test_configuration_sets_matched_pids_and_turns_off_what_the_own_loop_lacks():
    commands = configuration(BetaflightSpec(), reversed_spin=False, pids=((12, 5, 0), (12, 5, 0), (10, 3, 0)), level=80)
    for line in (
        "set simplified_pids_mode = OFF",
        "set p_roll = 12",
        "set i_yaw = 3",
        "set f_pitch = 0",
        "set d_max_roll = 0",
        "set angle_p_gain = 80",
        "set anti_gravity_gain = 0",
        "set rc_smoothing = OFF",
    ):
        assert line in commands
    assert not any(c.startswith("set p_roll") for c in configuration(BetaflightSpec(), reversed_spin=False))
