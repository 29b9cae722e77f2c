"""Motor mixer derived from the motor geometry.

Each motor i pushes with thrust f_i [N] along its unit axis a_i from its position p_i,
and reacts with torque -s_i (k_T / k_F) f_i a_i.  The allocation matrix ``A`` (4 x n)
maps motor thrusts to [collective thrust along body z, roll, pitch, yaw torque]::

    A[:, i] = [a_i,z, (p_i x a_i - s_i kappa_i a_i)]       kappa_i = k_T,i / k_F,i

(:func:`pyflyt_engine.allocation.allocation_matrix`, where it is defined for the spec's
check too).  The mixer is its pseudo-inverse ``A^T (A A^T)^-1`` (``A`` has full row rank:
checked by :func:`~pyflyt_engine.allocation.require_controllable`),
so any airframe whose motors can produce all four outputs independently (quad, hexa,
octo, Y6, ...) needs no hand-written mixing table.  It is computed in Python floats
(:func:`pyflyt_engine.exact.pinv`), not by LAPACK, whose last bits depend on the CPU.

**Tilting motors** (a tricopter's tail servo, tilt-rotors): a motor whose thrust axis
a gimbal turns by an angle delta about an axis ``c`` perpendicular to its nominal axis
``n`` pushes ``f R(c, delta) n = (f cos delta) n + (f sin delta) (c x n)``.  Its two
components are taken as two virtual inputs, one along ``n`` and one along ``c x n``,
both from the motor's position and with its reaction torque: the allocation stays
linear, one more column per tilting motor, and is inverted as above.  The motor's
thrust and the servo angle are recovered as ``delta = atan2(f_lateral, f_nominal)``,
``f = f_nominal / cos(delta)``.  This change of variables is the allocation of
tiltable-rotor vehicles in M. Kamel et al., "The Voliro Omniorientational Hexacopter:
An Agile and Maneuverable Tiltable-Rotor Aerial Vehicle", IEEE Robotics & Automation
Magazine 25(4), 2018 (section "Control allocation"); the same decomposition appears in
M. Ryll, H. H. Bülthoff, P. R. Giordano, IEEE Trans. Control Systems Technology 23(2), 2015.
"""

from __future__ import annotations

from collections.abc import Sequence
from math import atan2, cos, sqrt
from typing import TYPE_CHECKING

import numpy as np

from pyflyt_engine import exact
from pyflyt_engine.allocation import Tilt, require_controllable, tilted_allocation
from pyflyt_engine.components.motor import MotorParams, motor_subset

if TYPE_CHECKING:
    from pyflyt_engine.assembly import Assembly


def _lower(current: float, candidate: float) -> float:
    """The smaller of ``current`` and ``candidate`` (negative candidates count as 0)."""
    candidate = candidate if candidate > 0.0 else 0.0
    return candidate if candidate < current else current


def _throttle(force: float, full: float) -> float:
    """Throttle ``sqrt(force / full)`` for a thrust ``force`` [N], clipped to [0, 1] (thrust goes as throttle squared)."""
    return 0.0 if force <= 0.0 else 1.0 if force >= full else sqrt(force / full)


class Mixer:
    """Maps [thrust, tau_x, tau_y, tau_z] (N, N m; body frame) to motor throttles (and,
    with ``tilts``, then one normalised servo command per tilting motor)."""

    def __init__(self, motors: MotorParams, tilts: Sequence[Tilt] = ()) -> None:
        axes = motors.thrust_axes
        self.tilts = tuple(tilts)
        self.allocation = tilted_allocation(motors.positions, axes, motors.spin, motors.kf, motors.kt, self.tilts)
        require_controllable(self.allocation, range(len(axes)), tilted=bool(self.tilts))
        self._inverse_rows = exact.pinv(self.allocation)
        self.inverse = np.array(self._inverse_rows, dtype=np.float64)
        self.max_thrust = motors.max_thrust.tolist()
        #: Collective thrust along body z with every motor at full throttle [N].
        self.max_collective = exact.dot(axes[:, 2].tolist(), self.max_thrust)
        n = len(self.max_thrust)
        # per motor: its row of the pseudo-inverse and its full thrust, as plain floats
        self._rows = tuple((r[0], r[1], r[2], r[3], fm) for r, fm in zip(self._inverse_rows[:n], self.max_thrust))
        self._full = tuple(self.max_thrust)
        # per tilting motor: (motor, max angle, its lateral row of the pseudo-inverse)
        self._lateral = tuple((t.motor, t.max_angle, tuple(r)) for t, r in zip(self.tilts, self._inverse_rows[n:]))
        #: Body-frame (x, y) force per newton of collective thrust, no torque requested: the
        #: side force of tilted thrust axes (a tricopter's tail trimming the yaw reaction).
        self.side_force = (0.0, 0.0)
        if self.tilts:
            lateral_axes = np.cross(np.asarray([t.axis for t in self.tilts]), axes[[t.motor for t in self.tilts]])
            directions = np.vstack([axes, lateral_axes])
            thrust_column = self.inverse[:, 0].tolist()
            self.side_force = (exact.dot(thrust_column, directions[:, 0]), exact.dot(thrust_column, directions[:, 1]))

    @property
    def outputs(self) -> int:
        """Length of :meth:`throttles`: one throttle per motor, one command per tilting motor."""
        return len(self._full) + len(self.tilts)

    def throttles(self, thrust: float, tx: float, ty: float, tz: float) -> list[float]:
        """Throttle per motor (in [0, 1]) that best produces the requested wrench; with
        tilting motors, followed by each servo's command (angle / max angle, in [-1, 1]).

        When the request does not fit in the motors' range, it is given up in order of
        importance: first the yaw torque is scaled down until every motor is within
        [0, full thrust], then the collective thrust (so roll and pitch, which keep the
        vehicle upright, have the last word).  What still does not fit is clipped.

        Per motor ``i`` (row ``r`` of the pseudo-inverse, full thrust ``fm``)::

            from_thrust = r[0] thrust
            base        = from_thrust + r[1] tx + r[2] ty
            yaw         = r[3] tz
            from_torque = base - from_thrust + yaw_scale * yaw
            f           = scale * from_thrust + from_torque

        with ``yaw_scale`` the largest in [0, 1] that keeps every ``base + yaw_scale * yaw``
        in [0, fm], then ``scale`` the largest in [0, 1] that keeps every ``f <= fm``; the
        throttle is ``sqrt(f / fm)`` clipped to [0, 1].  A tilting motor's lateral input
        is ``scale r[0] thrust + r[1] tx + r[2] ty + yaw_scale r[3] tz`` (its lateral row
        ``r``); its servo angle ``delta = atan2(lateral, f)`` is clipped to the servo's
        limit and its thrust becomes ``f / cos(delta)``.  Plain float arithmetic (this
        runs at the control rate for every vehicle).

        The first pass also evaluates ``f`` at ``yaw_scale = scale = 1`` (the same
        expressions: ``1.0 * v == v``): when no motor asks for a smaller scale, that is
        the answer for a mixer without tilting motors, and the second and third passes,
        which would change nothing, are skipped -- the usual case in flight.
        """
        yaw_scale, fits = 1.0, True
        parts, out = [], []
        for r0, r1, r2, r3, fm in self._rows:
            ft = r0 * thrust
            b = ft + r1 * tx + r2 * ty
            y = r3 * tz
            if y > 0.0 and b + y > fm:  # yaw would push this motor past full thrust
                yaw_scale = _lower(yaw_scale, (fm - b) / y)
            elif y < 0.0 and b + y < 0.0:  # or below zero
                yaw_scale = _lower(yaw_scale, -b / y)
            from_roll_pitch = b - ft
            f = ft + (from_roll_pitch + y)
            if f > fm and ft > 0.0:  # the collective would have to give way
                fits = False
            parts.append((ft, from_roll_pitch, y, fm))
            out.append(0.0 if f <= 0.0 else 1.0 if f >= fm else sqrt(f / fm))  # _throttle, inlined
        if fits and yaw_scale == 1.0 and not self._lateral:
            return out
        from_torque = [(ft, fr + yaw_scale * y, fm) for ft, fr, y, fm in parts]
        scale = 1.0
        for ft, fq, fm in from_torque:
            if ft + fq > fm and ft > 0.0:
                scale = _lower(scale, (fm - fq) / ft)
        forces = [scale * ft + fq for ft, fq, _ in from_torque]
        if not self._lateral:
            return [_throttle(f, fm) for f, (_, _, fm) in zip(forces, from_torque)]
        commands = []
        for motor, limit, (r0, r1, r2, r3) in self._lateral:
            lateral = scale * r0 * thrust + r1 * tx + r2 * ty + yaw_scale * r3 * tz
            nominal = forces[motor]
            angle = atan2(lateral, nominal) if nominal > 0.0 else 0.0
            angle = limit if angle > limit else -limit if angle < -limit else angle
            forces[motor] = nominal / cos(angle)
            commands.append(angle / limit)
        return [_throttle(f, fm) for f, fm in zip(forces, self._full)] + commands


def flight_mixer(parts: Assembly) -> Mixer:
    """The mixer a multirotor's controller flies: the assembly's mixer motors
    (``mixer_motors``), with the tilting motors of the gimbals it flies (``mixer_tilts``)."""
    assert parts.motors is not None  # a multirotor controller needs motors (spec validator)
    return Mixer(motor_subset(parts.motors, parts.mixer_motors), [tilt for _, tilt in parts.mixer_tilts])
