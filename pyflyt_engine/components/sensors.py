"""Onboard sensors with noise: an IMU (gyroscope, accelerometer), a position fix and a
barometric altimeter (docs/engine.md, "Sensors").

The sensors read the body at every physics step (the vehicle hands them its pose and
velocity at the start of the step) and take a new sample at each of their own sample
instants ``k / rate_hz``: the first physics step at or after an instant takes it, and the
reading is held until the next one.  A sensor faster than the physics keeps the last of
the samples due in one physics step (its bias walks over all of them).

Models, per axis, ``eta`` ~ N(0, 1) from the sensors' own seeded stream (apart from the
physics' streams: adding a sensor leaves the flight unchanged):

* IMU triad (gyro: body rates [rad/s]; accel: specific force [m/s^2]), sample period
  ``T = 1 / rate_hz``::

      b <- b + K sqrt(n T) eta                 (n samples since the last one taken)
      y  = clip(s x + b + N / sqrt(T) eta, -range, range)

  with ``N`` the white noise density, ``K`` the bias random walk, ``s`` the scale factor,
  and ``b`` starting at ``bias + bias_initial_std eta`` at each reset.  This is the
  discrete form of rate noise of density ``N`` and a bias driven by white noise of density
  ``K``: the Allan deviation is ``N / sqrt(tau)`` at short ``tau`` and ``K sqrt(tau / 3)``
  at long ``tau`` (IEEE Std 952-1997, Annex C; El-Sheimy, Hou and Niu, "Analysis and
  Modeling of Inertial Sensors Using Allan Variance", IEEE TIM 57(1), 2008).
* Specific force is derived from velocity differences at physics resolution:
  ``a = (v_n - v_{n-1}) / dt`` (ground frame, the acceleration over the previous physics
  step, contact forces included), ``f = R^T (a - g)`` with ``g = (0, 0, -gravity)``: at rest
  on the ground it reads ``(0, 0, +gravity)``.  The first step after a reset takes ``a = 0``.
* Position: ``p + sigma eta`` per axis at each fix; with probability ``dropout`` a fix is
  lost: the last reading is held and ``valid`` is 0 (1 after a fix that arrived).  Before
  the first fix arrives the reading is the spawn position, valid 0.
* Barometer: ``z + b + sigma eta``, ``b`` = ``bias + bias_initial_std eta`` per episode.
* An optional state estimator (:mod:`pyflyt_engine.components.estimator`,
  :meth:`SensorSuite.attach_estimator`) takes every gyro sample (one update per sample:
  a sensor faster than the physics gives its held reading to each of the samples due in
  one physics step; the sample at time 0 only starts it) and then every valid position
  fix of the step.

Everything on the simulated path is Python floats and :mod:`math` (bit-identical across
processes and CPUs); random numbers are drawn one by one in a fixed order, every draw
whether or not its standard deviation is zero, so a parameter's value never shifts
another sensor's stream.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from pyflyt_engine.components.estimator import ComplementaryEstimator

#: names and sizes of the readings, in the order of :meth:`SensorSuite.values`
READING_SIZES = {"gyro": 3, "accel": 3, "position": 3, "position_valid": 1, "altitude": 1}


def check_rates(spec: Any, physics_hz: float) -> None:
    """Refuse a position fix or barometer faster than the physics: each sample is one draw,
    so at most one a physics step (an IMU faster than the physics keeps the last sample of
    each step, its bias walking over all of them)."""
    from pyflyt_engine.errors import ConfigError

    for where, part in (("position", spec.position), ("barometer", spec.barometer)):
        if part is not None and part.rate_hz > physics_hz * (1.0 + 1e-12):
            raise ConfigError(
                f"sensors.{where}.rate_hz: {part.rate_hz:g} Hz is faster than the physics ({physics_hz:g} Hz); "
                "give at most physics_hz"
            )


class InertialTriad:
    """A three-axis inertial sensor (gyroscope or accelerometer); see the module docstring."""

    def __init__(self, spec: Any) -> None:
        self.noise_density = float(spec.noise_density)
        self.bias_random_walk = float(spec.bias_random_walk)
        self.bias0 = float(spec.bias)
        self.bias_initial_std = float(spec.bias_initial_std)
        self.scale = float(spec.scale)
        self.range = float(spec.range)
        self.rate_hz = float(spec.rate_hz)
        self.bias = [self.bias0] * 3
        self.reading = (0.0, 0.0, 0.0)
        self._taken = 0  # samples taken since the reset (index of the next one)

    def reset(self, rng: np.random.Generator) -> None:
        self.bias = [self.bias0 + self.bias_initial_std * eta for eta in rng.standard_normal(3).tolist()]
        self._taken = 0
        self.reading = (0.0, 0.0, 0.0)

    def due(self, time: float) -> int:
        """Samples due at simulated time ``time`` [s] and not yet taken."""
        return max(0, math.floor(time * self.rate_hz + 1e-9) + 1 - self._taken)

    def sample(self, value: tuple[float, float, float], n: int, rng: np.random.Generator) -> None:
        """Take the last of ``n`` due samples of the true ``value``."""
        # six draws in one call (walk x, y, z, then white x, y, z), as Python floats
        wx, wy, wz, ex, ey, ez = rng.standard_normal(6).tolist()
        period = 1.0 / self.rate_hz
        walk = self.bias_random_walk * math.sqrt(n * period)
        white = self.noise_density / math.sqrt(period)
        s, r, bias = self.scale, self.range, self.bias
        bx, by, bz = bias[0] + walk * wx, bias[1] + walk * wy, bias[2] + walk * wz
        self.bias = [bx, by, bz]
        x, y, z = s * value[0] + bx + white * ex, s * value[1] + by + white * ey, s * value[2] + bz + white * ez
        self.reading = (
            r if x > r else -r if x < -r else x,
            r if y > r else -r if y < -r else y,
            r if z > r else -r if z < -r else z,
        )
        self._taken += n


class SensorSuite:
    """A vehicle's noisy sensors, built from its :class:`~pyflyt_engine.spec.SensorsSpec`.

    Args:
        spec: the airframe's ``sensors`` section.
        physics_dt: the physics step [s].
        gravity: the world's gravitational acceleration [m/s^2] (positive, along -z).
        rng: the sensors' noise stream (the world reseeds it, :meth:`reseed`).
    """

    def __init__(self, spec: Any, physics_dt: float, gravity: float, rng: np.random.Generator) -> None:
        self.spec = spec
        self.physics_dt = float(physics_dt)
        self.gravity = float(gravity)
        self.rng = rng
        imu = spec.imu
        self.gyro = InertialTriad(imu.gyro) if imu is not None else None
        self.accel = InertialTriad(imu.accel) if imu is not None else None
        pos = spec.position
        #: the position sensor's noise [m] per axis (None without one; domain randomisation may scale it)
        self.position_noise_std = tuple(float(v) for v in pos.noise_std) if pos is not None else None
        self._pos_rate = float(pos.rate_hz) if pos is not None else 0.0
        self._dropout = float(pos.dropout) if pos is not None else 0.0
        baro = spec.barometer
        self._baro = baro
        self._baro_rate = float(baro.rate_hz) if baro is not None else 0.0
        self.position = (0.0, 0.0, 0.0)
        self.position_valid = 0.0
        self.altitude = 0.0
        self.baro_bias = 0.0
        self._steps = 0
        self._last_velocity = (0.0, 0.0, 0.0)
        self._pos_taken = self._baro_taken = 0
        #: fixes lost and fixes due since the reset (for the dropout statistics)
        self.fixes_lost = self.fixes = 0
        #: the state estimator fed by these sensors (None: none, :meth:`attach_estimator`)
        self.estimator: ComplementaryEstimator | None = None
        self._quaternion: tuple[float, ...] = (0.0, 0.0, 0.0, 1.0)

    def attach_estimator(self, spec: Any) -> ComplementaryEstimator:
        """Feed a :class:`ComplementaryEstimator` with the gains of ``spec`` (``k_p``, ``k_i``,
        ``alpha``, ``beta``) from now on; it needs the IMU and the position fix.  It starts
        at the pose and velocity of the last reset."""
        if self.gyro is None or self.position_noise_std is None:
            missing = "imu" if self.gyro is None else "position"
            raise ValueError(f"the estimator needs sensors.{missing}")
        self.estimator = ComplementaryEstimator(spec, self.gyro.rate_hz, self._pos_rate, self.gravity)
        self.estimator.reset(self._quaternion, self.position, self._last_velocity)
        return self.estimator

    @property
    def names(self) -> tuple[str, ...]:
        """The readings this suite has, in the order of :meth:`values`."""
        out: tuple[str, ...] = ()
        if self.gyro is not None:
            out += ("gyro", "accel")
        if self.position_noise_std is not None:
            out += ("position", "position_valid")
        if self._baro is not None:
            out += ("altitude",)
        return out

    def reseed(self, rng: np.random.Generator) -> None:
        self.rng = rng

    def reset(
        self,
        position: tuple[float, ...],
        velocity: tuple[float, ...],
        quaternion: tuple[float, ...] = (0.0, 0.0, 0.0, 1.0),
    ) -> None:
        """Time 0: new initial biases (IMU, then barometer), readings at the spawn; the
        estimator (if any) at the spawn's pose (``quaternion``, body to ground) and velocity."""
        rng = self.rng
        self._quaternion = tuple(quaternion)
        self._steps = 0
        self._last_velocity = tuple(velocity)  # type: ignore[assignment]
        if self.gyro is not None and self.accel is not None:
            self.gyro.reset(rng)
            self.accel.reset(rng)
        self.position = tuple(float(v) for v in position)  # type: ignore[assignment]
        self.position_valid = 0.0
        self._pos_taken = self._baro_taken = 0
        self.fixes_lost = self.fixes = 0
        if self._baro is not None:
            self.baro_bias = float(self._baro.bias) + float(self._baro.bias_initial_std) * float(rng.standard_normal())
            self.altitude = float(position[2]) + self.baro_bias
        if self.estimator is not None:
            self.estimator.reset(quaternion, position, velocity)

    def step(
        self,
        position: tuple[float, ...],
        rotation: tuple[float, ...],
        velocity: tuple[float, ...],
        angular_velocity: tuple[float, ...],
    ) -> None:
        """Sample what is due at the start of this physics step, given the body's position,
        body-to-ground rotation (row-major), and velocities (ground frame)."""
        rng = self.rng
        time = self._steps * self.physics_dt
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = rotation
        updates = 0  # gyro samples that move the estimator on
        fix = False  # a valid position fix arrived
        if self.gyro is not None and self.accel is not None:
            lx, ly, lz = velocity
            px, py, pz = self._last_velocity
            inv = 1.0 / self.physics_dt
            ax, ay, az = (lx - px) * inv, (ly - py) * inv, (lz - pz) * inv + self.gravity
            self._last_velocity = (lx, ly, lz)
            n = self.gyro.due(time)
            if n:
                updates = n if self.gyro._taken else n - 1  # the sample at time 0 only starts the estimator
                wx, wy, wz = angular_velocity
                body = (r0 * wx + r3 * wy + r6 * wz, r1 * wx + r4 * wy + r7 * wz, r2 * wx + r5 * wy + r8 * wz)
                self.gyro.sample(body, n, rng)
            n = self.accel.due(time)
            if n:
                body = (r0 * ax + r3 * ay + r6 * az, r1 * ax + r4 * ay + r7 * az, r2 * ax + r5 * ay + r8 * az)
                self.accel.sample(body, n, rng)
        sigma = self.position_noise_std
        if sigma is not None:
            due = math.floor(time * self._pos_rate + 1e-9) + 1
            if due > self._pos_taken:
                self.fixes += due - self._pos_taken
                self._pos_taken = due
                lost = float(rng.random()) < self._dropout
                noise = rng.standard_normal(3).tolist()
                if lost:
                    self.fixes_lost += 1
                    self.position_valid = 0.0
                else:
                    self.position = (
                        position[0] + sigma[0] * noise[0],
                        position[1] + sigma[1] * noise[1],
                        position[2] + sigma[2] * noise[2],
                    )
                    self.position_valid = 1.0
                    fix = True
        if self._baro is not None:
            due = math.floor(time * self._baro_rate + 1e-9) + 1
            if due > self._baro_taken:
                self._baro_taken = due
                eta = float(rng.standard_normal())
                self.altitude = position[2] + self.baro_bias + float(self._baro.noise_std) * eta
        estimator = self.estimator
        if estimator is not None:
            gyro, accel = self.gyro.reading, self.accel.reading  # type: ignore[union-attr]
            for _ in range(updates):
                estimator.imu(gyro, accel)
            if fix:
                estimator.fix(self.position)
        self._steps += 1

    def values(self) -> list[float]:
        """The readings, flat, in the order of :attr:`names` (sizes :data:`READING_SIZES`)."""
        out: list[float] = []
        if self.gyro is not None and self.accel is not None:
            out += self.gyro.reading
            out += self.accel.reading
        if self.position_noise_std is not None:
            out += self.position
            out.append(self.position_valid)
        if self._baro is not None:
            out.append(self.altitude)
        return out

    def readings(self) -> dict[str, np.ndarray]:
        """The readings by name (float64 arrays, copies)."""
        flat, out, i = self.values(), {}, 0
        for name in self.names:
            k = READING_SIZES[name]
            out[name] = np.array(flat[i : i + k], dtype=np.float64)
            i += k
        return out
