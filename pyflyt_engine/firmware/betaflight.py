"""Betaflight's own firmware as a vehicle's flight controller (docs/firmware.md).

:class:`BetaflightController` is what a multirotor with ``control.firmware`` flies instead
of the cascade (:mod:`pyflyt_engine.control.multirotor`).  At every control tick it sends
the firmware the vehicle's IMU (body rates, specific force), attitude, velocity, position
and pressure, with the sticks and switches as RC channels, in one lockstep datagram
(:mod:`pyflyt_engine.firmware.packets`), and waits for the firmware's four motor outputs,
which drive the mixer motors.  The firmware's gyro and PID loop run at the world's control
rate: its clock is the tick count over that rate, so a run does not depend on the
machine's speed or load.

Setpoint (modes ``acro`` and ``angle``): ``[roll, pitch, yaw, throttle]`` sticks, roll,
pitch and yaw in [-1, 1] with the body-rate signs of ``rates_thrust`` (roll right, nose
down and yaw left positive), throttle in [0, 1].  In ``acro`` a stick gives Betaflight's
rate curve (:func:`actual_rate`); in ``angle`` it gives a tilt of ``angle_limit`` times the
rate curve's share of its full-stick rate (src/main/flight/pid.c lines 556-568), yaw a rate.

Channels (AETR, Betaflight's default map): 1 roll, 2 pitch, 3 throttle, 4 yaw, 1000-2000
us; AUX1 (channel 5) arms above 1700, AUX2 (channel 6) selects ANGLE above 1700.  The
vehicle's ``armed`` flag is the arm switch.  A reset restarts the firmware from its saved
configuration and feeds it the vehicle at rest until it arms (its gyro calibration, 0.5 s
of firmware time), so every episode starts from the same firmware state.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

from pyflyt_engine.components.motor import MotorParams
from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.control.modes import FlightMode
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.firmware import packets
from pyflyt_engine.firmware.sitl import FirmwareError, FirmwareHungError, LockstepSITL
from pyflyt_engine.spec import BetaflightSpec, MultirotorControlSpec, UAVSpec
from pyflyt_engine.state import KinematicState

if TYPE_CHECKING:
    from pyflyt_engine.control.mixer import Mixer
    from pyflyt_engine.vehicle import Vehicle

STICKS = ("roll", "pitch", "yaw", "throttle")
#: the firmware's flight modes: sticks in, motors out
BETAFLIGHT_MODES: dict[str, FlightMode] = {
    "acro": FlightMode("acro", None, STICKS, "Betaflight ACRO: sticks -> body rates (its rate curve)"),
    "angle": FlightMode("angle", None, STICKS, "Betaflight ANGLE: sticks -> tilt, yaw stick -> yaw rate"),
    # the cascade's rates_thrust layout, flown as ACRO sticks (the rate curve and the throttle
    # map inverted): a policy trained on the project's own controller flies the firmware unchanged
    "rates_thrust": FlightMode(
        "rates_thrust", 0, ("p", "q", "r", "thrust"), "body rates [rad/s] + thrust fraction, as Betaflight ACRO sticks"
    ),
}

ARM_ON, ARM_OFF = 2000, 1000
#: the most firmware time a reset feeds the vehicle at rest waiting for the firmware to arm [s]
ARM_WITHIN_S = 5.0
#: how long the arm switch stays in each position while a reset waits for the firmware to arm [s]
ARM_FLIP_S = 0.1
#: where the virtual GPS puts the world's origin (latitude, longitude [deg]); any point will do
ORIGIN_LAT_LON = (47.3977, 8.5456)
EARTH_RADIUS = 6378137.0  # WGS-84 equatorial radius [m]

#: Betaflight's QUADX motors (mixer_init.c lines 76-81: REAR_R, FRONT_R, REAR_L, FRONT_L) as
#: (forward sign, left sign) of their positions, and the spin its default (props in)
#: layout has them turn, +1 counter-clockwise seen from above
QUADX = ((-1, -1), (1, -1), (-1, 1), (1, 1))
QUADX_SPIN = (-1, 1, 1, -1)


def actual_rate(stick: float, rc_rate: int, super_rate: int, expo: int) -> float:
    """Betaflight's ACTUAL rate curve [deg/s] at a stick deflection in [-1, 1].

    ``applyActualRates``, src/main/fc/rc.c lines 226-236 (Betaflight 4.6.0): with x the
    deflection, centre = 10 rc_rate, e = expo / 100,
    rate = x centre + max(0, 10 super_rate - centre) |x| (x^5 e + x (1 - e)).
    """
    x = max(-1.0, min(1.0, float(stick)))
    centre = rc_rate * 10.0
    movement = max(0.0, super_rate * 10.0 - centre)
    e = expo / 100.0
    return x * centre + movement * abs(x) * (x**5 * e + x * (1.0 - e))


def motor_map(motors: MotorParams, mixer_motors: Sequence[int]) -> tuple[tuple[int, ...], bool]:
    """Which mixer output each Betaflight motor drives, and whether the spins are reversed.

    The mixer motors must be four, one per quadrant of an X (forward, left), with diagonal
    pairs spinning alike: Betaflight's QUADX, its spins as they are (props in) or all
    reversed (props out: ``yaw_motors_reversed``).

    Raises:
        ConfigError: the airframe is not a quad X (names what does not fit).
    """
    if len(mixer_motors) != 4:
        raise ConfigError(
            f"the Betaflight controller flies a quad X: the airframe has {len(mixer_motors)} mixer motors, not 4"
        )
    quadrant = {}
    for k, index in enumerate(mixer_motors):
        x, y = float(motors.positions[index][0]), float(motors.positions[index][1])
        if x == 0.0 or y == 0.0:
            raise ConfigError(
                f"the Betaflight controller flies a quad X: motor {index + 1} at ({x}, {y}) sits on an axis (a + frame)"
            )
        quadrant[(1 if x > 0 else -1, 1 if y > 0 else -1)] = k
    if len(quadrant) != 4:
        raise ConfigError("the Betaflight controller flies a quad X: the four motors need one quadrant each")
    order = tuple(quadrant[q] for q in QUADX)
    spins = [int(motors.spin[mixer_motors[k]]) for k in order]
    if spins == list(QUADX_SPIN):
        return order, False
    if spins == [-s for s in QUADX_SPIN]:
        return order, True
    raise ConfigError(
        "the Betaflight controller flies a quad X whose diagonal motors spin alike: this airframe's spins "
        f"{spins} (Betaflight's order: rear right, front right, rear left, front left) do not"
    )


#: Betaflight's gain scalings (src/main/flight/pid.h lines 46-48): its P, I and D terms are
#: ``P * PTERM_SCALE * e``, ``I * ITERM_SCALE * int(e) dt`` and ``-D * DTERM_SCALE * de/dt``
#: with the rate error e in deg/s, and their sum over PID_MIXER_SCALING (pid.h line 35) is
#: added to each QUADX motor's output with a mixer factor of +-1 (mixer.c lines 700-785,
#: mixer_init.c lines 76-81), in the output range above the motor idle (mixer.c line 460)
PTERM_SCALE, ITERM_SCALE, DTERM_SCALE = 0.032029, 0.244381, 0.000529
PID_MIXER_SCALING = 1000.0
#: Betaflight's largest P, I and D (PID_GAIN_MAX, src/main/flight/pid.h)
PID_GAIN_MAX = 250
#: Betaflight's default ANGLE-mode gain (the PID_LEVEL P, src/main/flight/pid.c line 136)
DEFAULT_LEVEL_GAIN = 50


def matched_pids(
    control: MultirotorControlSpec, mass: float, inertia: Sequence[float], mixer: Mixer
) -> tuple[tuple[int, int, int], ...]:
    """Betaflight rate PIDs (P, I, D per roll, pitch, yaw) that give the airframe's own rate
    loop (``control.rate``) about a level hover; ``inertia`` the body's principal moments,
    ``mixer`` the flight mixer (over the mixer motors).

    The project's rate loop commands the torque ``J (kp e + ki int(e) - kd dw/dt)`` (e in
    rad/s), which the mixer turns into motor thrusts and those into throttles
    ``sqrt(f / f_max)``: about the hover thrust f_h a torque tau changes motor i's throttle
    by ``|M_i,axis| tau / (2 sqrt(f_h f_max))`` (M the mixer's pseudo-inverse; the same for
    each motor of a quad X).  Betaflight changes each motor's output by
    ``P PTERM_SCALE (180/pi) e (1 - idle) / 1000`` for the same e; equating the two gives P,
    and I and D alike.  Rounded to Betaflight's whole numbers.

    Raises:
        ConfigError: a gain beyond Betaflight's range (names the axis and the gain).
    """
    gravity_thrust = mass * GRAVITY
    scale = math.degrees(1.0) * (1.0 - MOTOR_IDLE) / PID_MIXER_SCALING
    gains = []
    for axis, name in enumerate(("roll", "pitch", "yaw")):
        per_torque = 0.0  # throttle change per N m about the axis, averaged over the motors
        motors = range(len(mixer.max_thrust))
        for m in motors:
            hover = float(mixer.inverse[m, 0]) * gravity_thrust
            per_torque += abs(float(mixer.inverse[m, 1 + axis])) / (2.0 * math.sqrt(hover * mixer.max_thrust[m]))
        per_torque /= len(motors)
        j = float(inertia[axis]) * per_torque
        rate = control.rate
        values = (
            round(j * rate.kp[axis] / (PTERM_SCALE * scale)),
            round(j * rate.ki[axis] / (ITERM_SCALE * scale)),
            round(j * rate.kd[axis] / (DTERM_SCALE * scale)),
        )
        for term, value in zip("PID", values):
            if value > PID_GAIN_MAX:
                raise ConfigError(
                    f"the airframe's {name} rate loop needs a Betaflight {term} of {value}, beyond its {PID_GAIN_MAX}: "
                    "lower control.rate's gains, or set control.firmware.pids: firmware"
                )
        gains.append(values)
    return tuple(gains)


def matched_level_gain(control: MultirotorControlSpec) -> int:
    """Betaflight's ANGLE-mode gain (``angle_p_gain``) for the airframe's own attitude loop:
    Betaflight's rate setpoint is the tilt error times angle_p_gain / 10 (pid_init.c line 406,
    pid.c line 597), the project's ``control.attitude.kp`` times the tilt error (one gain for
    roll and pitch in Betaflight: their mean)."""
    kp = control.attitude.kp
    return round(10.0 * 0.5 * (kp[0] + kp[1]))


def pid_commands(pids: Sequence[Sequence[int]], level: int) -> list[str]:
    """The CLI commands that set the rate PIDs and the ANGLE-mode gain, and turn off what the
    project's loops do not have: feedforward (and its yaw hold, and ANGLE's), D boost (d_max),
    anti-gravity, throttle boost, TPA, I-term relax, the yaw P-term lowpass and RC smoothing
    (names: src/main/cli/settings.c, src/main/fc/parameter_names.h)."""
    commands = ["set simplified_pids_mode = OFF", f"set angle_p_gain = {level}", "set angle_feedforward = 0"]
    for (p, i, d), name in zip(pids, ("roll", "pitch", "yaw")):
        commands += [f"set p_{name} = {p}", f"set i_{name} = {i}", f"set d_{name} = {d}", f"set f_{name} = 0"]
        commands.append(f"set d_max_{name} = {d}")
    return commands + [
        "set feedforward_yaw_hold_gain = 0",
        "set anti_gravity_gain = 0",
        "set throttle_boost = 0",
        "set tpa_rate = 0",
        "set iterm_relax = OFF",
        "set yaw_lowpass_hz = 0",
        "set rc_smoothing = OFF",
    ]


def configuration(
    spec: BetaflightSpec,
    reversed_spin: bool,
    pids: Sequence[Sequence[int]] | None = None,
    level: int = DEFAULT_LEVEL_GAIN,
) -> list[str]:
    """The CLI commands that set the firmware up for the simulator (then the spec's own).

    ``pids``: rate PIDs per axis (:func:`matched_pids`) and ``level`` the ANGLE-mode gain
    (:func:`matched_level_gain`); ``pids`` None keeps Betaflight's defaults for both."""
    commands = [
        "mixer QUADX",
        # outputs as PWM microseconds: sitl.c sends (value - mincommand) / 1000, in [0, 1]
        "set motor_pwm_protocol = PWM",
        f"set yaw_motors_reversed = {'ON' if reversed_spin else 'OFF'}",
        "set pwr_on_arm_grace = 0",
        "set gyro_calib_duration = 50",
        "set acc_calibration = 0,0,0,1",
        "set blackbox_device = NONE",
        "set pid_process_denom = 1",
        "set failsafe_procedure = DROP",
        "set rates_type = ACTUAL",
        f"set angle_limit = {spec.angle_limit}",
        # AUX1 arms, AUX2 selects ANGLE (aux <slot> <mode id> <aux channel> <low> <high> <logic> <linked>)
        "aux 0 0 0 1700 2100 0 0",
        "aux 1 1 1 1700 2100 0 0",
    ]
    for axis, name in enumerate(("roll", "pitch", "yaw")):
        commands += [
            f"set {name}_rc_rate = {spec.rc_rate[axis]}",
            f"set {name}_srate = {spec.super_rate[axis]}",
            f"set {name}_expo = {spec.expo[axis]}",
        ]
    if pids is not None:
        commands += pid_commands(pids, level)
    return commands + list(spec.cli)


#: loop rates the firmware's clock can follow, in place of the paper's 240 / 120 / 30 Hz
FIRMWARE_RATES = (1000.0, 1000.0, 50.0)
#: the same, keeping the paper's 30 Hz agent (a policy trained at 30 Hz): the firmware at 500 Hz
FIRMWARE_RATES_AT_30_HZ = (1500.0, 500.0, 30.0)
PAPER_RATES = (240.0, 120.0, 30.0)
#: Betaflight's default motor idle (motor_idle 550: 5.5 % of the output range)
MOTOR_IDLE = 0.055
#: the most ticks since a firmware's start that are kept to restart it where it stopped, should
#: it hang (10 minutes at 1 kHz, ~110 MB); past them a hung firmware is an error
REPLAY_TICKS = 600_000


def with_betaflight(spec: UAVSpec, mode: str) -> UAVSpec:
    """``spec`` flown by Betaflight's firmware in ``mode`` (acro or angle) instead of its own
    cascade (``controller: betaflight`` of an env or of ``pyflyt fly``); an airframe that
    already names its firmware keeps its settings, in ``mode``.

    Raises:
        ConfigError: the airframe has no multirotor controller to replace, or ``mode`` is
            not one of the firmware's.
    """
    control = spec.control
    if not isinstance(control, MultirotorControlSpec):
        raise ConfigError(
            f"controller betaflight replaces a multirotor controller: '{spec.name}' has control type "
            f"'{control.type}'; fly a quad X airframe (quadx_cf2x, quadx_f450)"
        )
    if mode not in BETAFLIGHT_MODES:
        raise ConfigError(f"controller betaflight flies the modes {', '.join(BETAFLIGHT_MODES)}, not '{mode}'")
    firmware = (control.firmware or BetaflightSpec()).model_copy(
        update={"mode": "angle" if mode == "angle" else "acro"}
    )
    return spec.model_copy(update={"control": control.model_copy(update={"firmware": firmware})})


def stick_for_rate(rate_deg: float, spec: BetaflightSpec, axis: int) -> float:
    """The stick deflection whose ACRO rate is ``rate_deg`` [deg/s] (the rate curve, odd and
    increasing, inverted by bisection; full stick beyond its maximum rate)."""
    rc, sr, ex = spec.rc_rate[axis], spec.super_rate[axis], spec.expo[axis]
    target = min(abs(rate_deg), actual_rate(1.0, rc, sr, ex))
    lo, hi = 0.0, 1.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if actual_rate(mid, rc, sr, ex) < target:
            lo = mid
        else:
            hi = mid
    return math.copysign(0.5 * (lo + hi), rate_deg)


def throttle_stick(thrust_fraction: float) -> float:
    """The throttle stick for a fraction of the maximum collective thrust (rates_thrust's
    ``thrust``): the per-motor throttle sqrt(fraction) (thrust ~ throttle^2).  With the
    configuration here (PWM outputs, airmode off) Betaflight's motor output at a level hold
    is the throttle stick from 0.1 up (measured: 0.3 -> 0.303, 0.5 -> 0.501, 0.7 -> 0.700)
    and its idle, 0.055, below."""
    return max(0.0, min(1.0, math.sqrt(max(0.0, thrust_fraction))))


def stick_for_angle(angle_deg: float, spec: BetaflightSpec, axis: int) -> float:
    """The stick deflection whose ANGLE-mode tilt is ``angle_deg`` (the rate curve inverted
    by bisection; clipped to full stick)."""
    full = actual_rate(1.0, spec.rc_rate[axis], spec.super_rate[axis], spec.expo[axis])
    share = max(-1.0, min(1.0, angle_deg / spec.angle_limit))
    lo, hi = 0.0, 1.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if actual_rate(mid, spec.rc_rate[axis], spec.super_rate[axis], spec.expo[axis]) / full < abs(share):
            lo = mid
        else:
            hi = mid
    return math.copysign(0.5 * (lo + hi), share)


class AnglePilot:
    """Sticks that hold a vehicle flown by the firmware in ANGLE mode at a point: tilt from a
    PD law on the horizontal position (through :func:`stick_for_angle`), throttle from the
    hover throttle and a PID law on the height; yaw stick 0
    (called once per control tick)."""

    def __init__(self, vehicle: Vehicle, target: Sequence[float], max_tilt_deg: float = 15.0) -> None:
        assert vehicle.firmware is not None
        self.vehicle = vehicle
        self.spec = vehicle.firmware.spec
        self.target = tuple(float(v) for v in target)
        self.max_tilt = math.radians(max_tilt_deg)
        self.hover = vehicle.hover_throttle()  # the motor output follows the stick (throttle_stick)
        self.dt = vehicle.firmware.dt  # called once per control tick
        self._height_integral = 0.0

    def __call__(self) -> list[float]:
        s = self.vehicle.state
        yaw = s.ang_pos[2]
        ex, ey = self.target[0] - s.lin_pos[0], self.target[1] - s.lin_pos[1]
        vx, vy = s.lin_vel_ground[0], s.lin_vel_ground[1]
        ax, ay = 1.0 * ex - 1.2 * vx, 1.0 * ey - 1.2 * vy  # wanted acceleration [m/s^2]
        forward = math.cos(yaw) * ax + math.sin(yaw) * ay
        left = -math.sin(yaw) * ax + math.cos(yaw) * ay
        pitch = max(-self.max_tilt, min(self.max_tilt, math.atan2(forward, GRAVITY)))  # nose down: forward
        roll = max(-self.max_tilt, min(self.max_tilt, math.atan2(-left, GRAVITY)))  # roll right: rightward
        tilt = max(0.3, math.cos(s.ang_pos[0]) * math.cos(s.ang_pos[1]))
        ez = self.target[2] - s.lin_pos[2]
        self._height_integral = max(-0.2, min(0.2, self._height_integral + 0.5 * ez * self.dt))
        throttle = self.hover / math.sqrt(tilt) + 0.3 * ez - 0.2 * s.lin_vel_ground[2] + self._height_integral
        return [
            stick_for_angle(math.degrees(roll), self.spec, 0),
            stick_for_angle(math.degrees(pitch), self.spec, 1),
            0.0,
            max(0.0, min(1.0, throttle)),
        ]


def _channel(value: float) -> int:
    return int(round(1500.0 + 500.0 * max(-1.0, min(1.0, value))))


def sticks_to_channels(setpoint: Sequence[float], armed: bool, angle: bool) -> list[int]:
    """The 16 RC channels for ``[roll, pitch, yaw, throttle]`` sticks and the two switches."""
    roll, pitch, yaw, throttle = (float(v) for v in setpoint[:4])
    channels = [1000] * packets.RC_CHANNELS
    channels[0] = _channel(roll)  # aileron: right is roll right
    channels[1] = _channel(pitch)  # elevator: forward is nose down
    channels[2] = int(round(1000.0 + 1000.0 * max(0.0, min(1.0, throttle))))
    channels[3] = _channel(-yaw)  # rudder: right is yaw right, the setpoint's yaw is left-positive
    channels[4] = ARM_ON if armed else ARM_OFF
    channels[5] = 2000 if angle else 1000
    return channels


class BetaflightController:
    """The firmware in lockstep behind one vehicle.

    Args:
        spec: the airframe's ``control.firmware``.
        motors: the airframe's motors; mixer_motors: the four it flies.
        control_dt: the world's control period [s]: the firmware's gyro and PID period
            (a whole number of Hz).
        pids: the rate PIDs to set (:func:`matched_pids`) and level the ANGLE-mode gain
            (:func:`matched_level_gain`); pids None keeps Betaflight's for both.
    """

    def __init__(
        self,
        spec: BetaflightSpec,
        motors: MotorParams,
        mixer_motors: Sequence[int],
        control_dt: float,
        pids: Sequence[Sequence[int]] | None = None,
        level: int = DEFAULT_LEVEL_GAIN,
    ):
        hz = round(1.0 / control_dt)
        if hz < 100 or abs(hz * control_dt - 1.0) > 1e-9 or 1_000_000 % hz:
            raise ConfigError(
                f"the Betaflight controller runs its gyro and PID loop at the control rate, whose period must be a "
                f"whole number of microseconds (the firmware's clock): {1.0 / control_dt:g} Hz is not one of at "
                "least 100 Hz; set the world's control_hz (and physics_hz) to e.g. 1000, 800 or 500"
            )
        self.spec = spec
        self.gyro_hz = int(hz)
        self.period_us = 1_000_000 // hz
        self.dt = self.period_us * 1e-6
        self.order, reversed_spin = motor_map(motors, mixer_motors)
        #: the rate PIDs set (P, I, D per roll, pitch, yaw), None: Betaflight's defaults
        self.pids = None if pids is None else tuple(tuple(int(v) for v in axis) for axis in pids)
        self.level = int(level)
        self.commands = configuration(spec, reversed_spin, self.pids, self.level)
        self.angle = spec.mode == "angle"
        self.rates = False  # the setpoint is rates_thrust's, turned into sticks
        self._sitl: LockstepSITL | None = None
        self._ticks = 0
        self._last_velocity: tuple[float, ...] | None = None
        #: whether the radio link carries the sticks (False: ticks without RC, as a lost
        #: link; the firmware's failsafe lands or drops the vehicle after its delay)
        self.radio = True
        self._outputs: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
        #: the vehicle's state and arm flag at the last reset, while the firmware that reset
        #: asks for has not been started: it starts when first needed, so that a reset followed
        #: by another (a world's reset, then the episode's spawn) starts one firmware, not two
        self._start_at: tuple[KinematicState, bool] | None = None
        #: every datagram this firmware was sent since its start (up to REPLAY_TICKS)
        self._sent: list[bytes] | None = []
        #: how many hung firmwares were replaced by a fresh one replayed to where it stopped
        self.restarts = 0

    # ------------------------------------------------------------ lifecycle

    def set_mode(self, mode: FlightMode) -> None:
        self.angle = mode.name == "angle"
        self.rates = mode.name == "rates_thrust"

    @property
    def outputs(self) -> tuple[float, float, float, float]:
        """The firmware's last motor outputs, Betaflight's motors 1-4 (after a reset: at its idle
        once armed)."""
        if self._start_at is not None:
            self._start(*self._start_at)
        return self._outputs

    def reset(self, state: KinematicState, armed: bool = True) -> None:
        """Restart the firmware and feed it the vehicle at rest (in ``state``) until it arms
        (when ``armed``); done when the firmware is next needed, a tick or :attr:`outputs`."""
        self.close()
        self.radio = True
        self._start_at = (state, armed)

    def _start(self, state: KinematicState, armed: bool) -> None:
        self._start_at = None
        self._sitl = LockstepSITL(self.commands, self.gyro_hz)
        self._sent = []
        self._ticks = 0
        self._last_velocity = None
        self._outputs = (0.0, 0.0, 0.0, 0.0)
        if not armed:
            return
        # Betaflight arms on a switch moved to ON once arming is allowed (after its gyro
        # calibration): the switch is flipped every ARM_FLIP_S until the motors idle
        rest = [0.0, 0.0, 0.0, 0.0]
        flip = max(1, int(ARM_FLIP_S * self.gyro_hz))
        for tick in range(int(ARM_WITHIN_S * self.gyro_hz)):
            self._tick(state, rest, (tick // flip) % 2 == 1, at_rest=True)
            if max(self._outputs) > 0.0:  # armed: the motors idle
                self._last_velocity = None
                return
        log = self._sitl.process.log()[-300:]
        self.close()  # nothing left running
        raise FirmwareError(
            f"Betaflight did not arm within {ARM_WITHIN_S:g} s of firmware time with the vehicle at rest, "
            f"throttle low and AUX1 switched: check the spec's cli commands (firmware output: {log!r})"
        )

    def close(self) -> None:
        """Stop the firmware (a later :meth:`reset` starts it again)."""
        self._start_at = None
        if self._sitl is not None:
            self._sitl.close()
            self._sitl = None

    def __del__(self) -> None:
        if getattr(self, "_sitl", None) is not None:
            self.close()

    # ------------------------------------------------------------- stepping

    def datagram(
        self, state: KinematicState, setpoint: Sequence[float] | None, armed: bool, at_rest: bool = False
    ) -> bytes:
        """This tick's datagram: the state as the firmware's IMU sees it, and the sticks
        (None: no RC this tick, the radio link is silent)."""
        qx, qy, qz, qw = state.quaternion
        velocity: tuple[float, ...]
        if at_rest:
            p = q = r = 0.0
            velocity = (0.0, 0.0, 0.0)
        else:
            p, q, r = state.ang_vel
            velocity = tuple(state.lin_vel_ground)
        # specific force: the acceleration over the last tick minus gravity, in the body frame
        last = self._last_velocity
        if last is None or at_rest:
            ax = ay = 0.0
            az = 0.0
        else:
            ax, ay, az = ((velocity[i] - last[i]) / self.dt for i in range(3))
        self._last_velocity = velocity
        fx, fy, fz = ax, ay, az + GRAVITY  # ground frame
        # body = R^T ground, R = body-to-ground from the quaternion
        xx, yy, zz = qx * qx, qy * qy, qz * qz
        xy, xz, yz, wx, wy, wz = qx * qy, qx * qz, qy * qz, qw * qx, qw * qy, qw * qz
        r00, r01, r02 = 1 - 2 * (yy + zz), 2 * (xy - wz), 2 * (xz + wy)
        r10, r11, r12 = 2 * (xy + wz), 1 - 2 * (xx + zz), 2 * (yz - wx)
        r20, r21, r22 = 2 * (xz - wy), 2 * (yz + wx), 1 - 2 * (xx + yy)
        bx = r00 * fx + r10 * fy + r20 * fz
        by = r01 * fx + r11 * fy + r21 * fz
        bz = r02 * fx + r12 * fy + r22 * fz
        x, y, z = state.lin_pos
        lat0, lon0 = ORIGIN_LAT_LON
        lat = lat0 + math.degrees(y / EARTH_RADIUS)
        lon = lon0 + math.degrees(x / (EARTH_RADIUS * math.cos(math.radians(lat0))))
        pressure = 101325.0 * (1.0 - 2.25577e-5 * z) ** 5.25588  # ISA troposphere
        channels = None if setpoint is None else sticks_to_channels(setpoint, armed, self.angle)
        self._ticks += 1
        return packets.tick_datagram(
            self._ticks * self.period_us * 1e-6,  # whole microseconds: one gyro period a tick
            (p, -q, -r),  # FLU body rates -> forward-right-down
            (-bx, -by, -bz),  # sitl.c negates it back: the firmware sees +1 g up at rest
            (qw, qx, -qy, -qz),  # FLU/ENU -> FRD: the same rotation seen with y and z flipped
            velocity,  # ENU, as the virtual GPS takes it
            (lon, lat, z),  # the virtual GPS's longitude, latitude, altitude
            pressure,
            channels,
        )

    def _tick(self, state: KinematicState, setpoint: Sequence[float] | None, armed: bool, at_rest: bool = False):
        if self._start_at is not None:
            self._start(*self._start_at)
        elif self._sitl is None:
            self._start(state, armed)
        assert self._sitl is not None
        datagram = self.datagram(state, setpoint, armed, at_rest)
        if self._sent is not None:
            self._sent.append(datagram)
            if len(self._sent) > REPLAY_TICKS:
                self._sent = None  # too long a flight to replay: a hang is an error from here
        try:
            self._outputs = self._sitl.tick(datagram)
        except FirmwareHungError:
            if self._sent is None:
                raise
            self._outputs = self._replay()
        return self._outputs

    def _replay(self) -> tuple[float, float, float, float]:
        """A fresh firmware in place of a hung one, sent every datagram the hung one was: in
        lockstep its state follows from them alone, so it goes on where the hung one stopped
        with the same numbers.  Its answer to the last datagram is returned; a second hang is
        an error."""
        assert self._sitl is not None and self._sent is not None
        self._sitl.close()
        self._sitl = LockstepSITL(self.commands, self.gyro_hz)
        self.restarts += 1
        outputs = self._outputs
        for datagram in self._sent:
            outputs = self._sitl.tick(datagram)
        return outputs

    def __call__(self, state: KinematicState, setpoint: Sequence[float] | None, armed: bool = True) -> list[float]:
        """One control tick: the mixer motors' throttles, in mixer order.

        ``setpoint`` None sends no RC this tick (the radio link is silent: the firmware's
        failsafe takes over after its delay)."""
        if self.rates and setpoint is not None:
            p, q, r, thrust = (float(v) for v in setpoint[:4])
            spec = self.spec
            setpoint = [
                stick_for_rate(math.degrees(p), spec, 0),
                stick_for_rate(math.degrees(q), spec, 1),
                stick_for_rate(math.degrees(r), spec, 2),
                throttle_stick(thrust),
            ]
        outputs = self._tick(state, setpoint if self.radio else None, armed)
        throttles = [0.0] * 4
        for bf_motor, mixer_index in enumerate(self.order):
            throttles[mixer_index] = float(outputs[bf_motor])
        return throttles
