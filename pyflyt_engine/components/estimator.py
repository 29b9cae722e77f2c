"""A flight controller's state estimator, fed by the noisy sensors (docs/environments.md,
"Estimated state").

Two fixed-gain filters, stepped inside the physics loop at every IMU (gyroscope) sample:

* **Attitude**: the explicit complementary filter on SO(3) of Mahony, Hamel and Pflimlin
  ("Nonlinear complementary filters on the special orthogonal group", IEEE TAC 53(5),
  2008, the "explicit complementary filter" with bias correction), one vector reference:
  the accelerometer's direction taken as "up".  With ``q`` the estimated body-to-ground
  quaternion (rotation ``R``), ``b`` the estimated gyro bias, ``y`` the gyro reading and
  ``f`` the accelerometer reading (specific force)::

      v     = f / |f|                (measured "up", body frame)
      v_hat = R^T e3                 (estimated "up", body frame)
      w     = v x v_hat              (the paper's omega_mes with k_1 = 2: -vex(P_a(v v_hat^T)))
      q    <- q (x) exp(((y - b) + k_P w) T / 2)
      b    <- b - k_I w T

  ``T = 1 / gyro rate``.  For a rotation about one horizontal axis with angle error ``e``
  (true minus estimated) the correction is ``sin e`` about that axis, so with a true
  gyro ``e' = -k_P sin e``: a first-order response with time constant ``1 / k_P``
  (``tan(e / 2) = tan(e0 / 2) exp(-k_P t)``); with a constant gyro bias the linearised
  error and bias error obey ``e'' + k_P e' + k_I e = 0`` (critically damped at
  ``k_I = k_P^2 / 4``), so the bias is learnt and the steady-state error is zero.  Only the
  bias about the horizontal body axes is observable from gravity: the yaw estimate has
  no absolute reference (no magnetometer) and drifts with the gyro's bias about the
  vertical.  ``|f| = 0`` (free fall, or before the first sample) skips the correction.

* **Velocity and position**: per ground axis, a fixed-gain position-velocity filter
  (an alpha-beta filter, the steady-state Kalman filter of a double integrator driven by
  the measured acceleration).  At every IMU sample the specific force is turned to the
  ground frame with the *estimated* attitude and gravity added back,
  ``a = R f - g e3``, and integrated (``p += v T + a T^2 / 2``, ``v += a T``); at every
  position fix that arrived (valid), with ``e = z - p`` and ``T_f = 1 / fix rate``::

      p <- p + alpha e,   v <- v + (beta / T_f) e

  The error at fix instants obeys ``z^2 - (2 - alpha - beta) z + (1 - alpha) = 0``, stable
  inside ``alpha > 0, beta > 0, 2 alpha + beta < 4`` (Jury's test).  :func:`alpha_beta_gains`
  gives the steady-state Kalman gains from Kalata's tracking index
  ``lambda = sigma_a T_f^2 / sigma_p`` (Kalata, "The tracking index: a generalized parameter
  for alpha-beta and alpha-beta-gamma target trackers", IEEE TAES 20(2), 1984; Bar-Shalom,
  Li and Kirubarajan, "Estimation with Applications to Tracking and Navigation", 2001,
  section 6.5.3, the discrete white-noise-acceleration model).

The estimate starts, at each reset, at the true pose and velocity of the spawn (what an
alignment at rest with a known heading gives a flight controller) with a zero bias
estimate.  Everything is Python floats and :mod:`math`: bit-identical across processes and
CPUs; the estimator draws no random numbers.
"""

from __future__ import annotations

import math
from typing import Any


def alpha_beta_gains(tracking_index: float) -> tuple[float, float]:
    """Steady-state Kalman gains ``(alpha, beta)`` of a position-velocity filter for the
    discrete white-noise-acceleration model, from Kalata's tracking index
    ``lambda = sigma_a T^2 / sigma_p`` (acceleration noise std, fix period, position noise
    std); Bar-Shalom, Li and Kirubarajan 2001, section 6.5.3."""
    lam = float(tracking_index)
    if not lam > 0.0:
        raise ValueError(f"tracking_index must be > 0, got {lam!r}")
    root = math.sqrt(lam * lam + 8.0 * lam)
    alpha = -(lam * lam + 8.0 * lam - (lam + 4.0) * root) / 8.0
    beta = (lam * lam + 4.0 * lam - lam * root) / 4.0
    return alpha, beta


def quaternion_to_euler(q: tuple[float, float, float, float]) -> tuple[float, float, float]:
    """(roll, pitch, yaw) [rad] of a unit body-to-ground quaternion (x, y, z, w), in the
    convention of :mod:`pyflyt_engine.frames` (yaw, then pitch, then roll)."""
    x, y, z, w = q
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    s = 2.0 * (w * y - z * x)
    pitch = math.asin(1.0 if s > 1.0 else -1.0 if s < -1.0 else s)
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return roll, pitch, yaw


def rows(q: tuple[float, float, float, float]) -> tuple[float, ...]:
    """Body-to-ground rotation of a unit quaternion (x, y, z, w), row-major, flat."""
    x, y, z, w = q
    return (
        1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w),
        2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w),
        2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y),
    )  # fmt: skip


class ComplementaryEstimator:
    """Attitude, gyro bias, velocity and position from an IMU and a position fix (module
    docstring).

    Args:
        spec: the gains: ``k_p`` [rad/s], ``k_i`` [rad/s^2], ``alpha``, ``beta`` [-].
        gyro_rate_hz: the gyroscope's sample rate (one update per sample).
        fix_rate_hz: the position fix's rate (``beta / T_f`` is the velocity gain).
        gravity: the gravitational acceleration [m/s^2] the filter adds back.
    """

    def __init__(self, spec: Any, gyro_rate_hz: float, fix_rate_hz: float, gravity: float) -> None:
        self.k_p = float(spec.k_p)
        self.k_i = float(spec.k_i)
        self.alpha = float(spec.alpha)
        self.beta = float(spec.beta)
        self.dt = 1.0 / float(gyro_rate_hz)
        self.velocity_gain = self.beta * float(fix_rate_hz)
        self.gravity = float(gravity)
        #: estimated body-to-ground quaternion (x, y, z, w)
        self.quaternion: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
        #: estimated gyro bias (body frame) [rad/s]
        self.bias: tuple[float, float, float] = (0.0, 0.0, 0.0)
        #: estimated velocity and position, ground frame [m/s], [m]
        self.velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self.position: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def reset(
        self,
        quaternion: tuple[float, ...],
        position: tuple[float, ...],
        velocity: tuple[float, ...],
        bias: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> None:
        """Start from a pose and velocity (ground frame) and a bias estimate."""
        x, y, z, w = (float(v) for v in quaternion)
        n = math.sqrt(x * x + y * y + z * z + w * w)
        self.quaternion = (x / n, y / n, z / n, w / n)
        self.position = tuple(float(v) for v in position)  # type: ignore[assignment]
        self.velocity = tuple(float(v) for v in velocity)  # type: ignore[assignment]
        self.bias = tuple(float(v) for v in bias)  # type: ignore[assignment]

    def imu(self, gyro: tuple[float, float, float], accel: tuple[float, float, float]) -> None:
        """One IMU sample: propagate attitude, bias, velocity and position over ``1 / gyro rate``."""
        dt = self.dt
        qx, qy, qz, qw = self.quaternion
        bx, by, bz = self.bias
        fx, fy, fz = accel
        # estimated "up" in the body frame: the third row of R, R^T e3
        ux, uy, uz = 2.0 * (qx * qz - qy * qw), 2.0 * (qy * qz + qx * qw), 1.0 - 2.0 * (qx * qx + qy * qy)
        norm = math.sqrt(fx * fx + fy * fy + fz * fz)
        if norm > 0.0:
            vx, vy, vz = fx / norm, fy / norm, fz / norm
            cx, cy, cz = vy * uz - vz * uy, vz * ux - vx * uz, vx * uy - vy * ux  # v x v_hat
            k_i = self.k_i * dt
            bx, by, bz = bx - k_i * cx, by - k_i * cy, bz - k_i * cz
            self.bias = (bx, by, bz)
            k_p = self.k_p
            wx, wy, wz = gyro[0] - bx + k_p * cx, gyro[1] - by + k_p * cy, gyro[2] - bz + k_p * cz
        else:
            wx, wy, wz = gyro[0] - bx, gyro[1] - by, gyro[2] - bz
        # q <- q (x) exp(w dt / 2): the exact rotation by |w| dt about w (body frame)
        rate = math.sqrt(wx * wx + wy * wy + wz * wz)
        if rate > 0.0:
            half = 0.5 * rate * dt
            s = math.sin(half) / rate
            dx, dy, dz, dw = wx * s, wy * s, wz * s, math.cos(half)
            qx, qy, qz, qw = (
                qw * dx + qx * dw + qy * dz - qz * dy,
                qw * dy - qx * dz + qy * dw + qz * dx,
                qw * dz + qx * dy - qy * dx + qz * dw,
                qw * dw - qx * dx - qy * dy - qz * dz,
            )
            n = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
            qx, qy, qz, qw = qx / n, qy / n, qz / n, qw / n
            self.quaternion = (qx, qy, qz, qw)
        # specific force to the ground frame with the estimated attitude (the rows of
        # :func:`rows`, written out), gravity added back
        xx, yy, zz = qx * qx, qy * qy, qz * qz
        xy, xz, yz, xw, yw, zw = qx * qy, qx * qz, qy * qz, qx * qw, qy * qw, qz * qw
        ax = (1.0 - 2.0 * (yy + zz)) * fx + 2.0 * (xy - zw) * fy + 2.0 * (xz + yw) * fz
        ay = 2.0 * (xy + zw) * fx + (1.0 - 2.0 * (xx + zz)) * fy + 2.0 * (yz - xw) * fz
        az = 2.0 * (xz - yw) * fx + 2.0 * (yz + xw) * fy + (1.0 - 2.0 * (xx + yy)) * fz - self.gravity
        px, py, pz = self.position
        ux, uy, uz = self.velocity
        h = 0.5 * dt * dt
        self.position = (px + ux * dt + ax * h, py + uy * dt + ay * h, pz + uz * dt + az * h)
        self.velocity = (ux + ax * dt, uy + ay * dt, uz + az * dt)

    def fix(self, position: tuple[float, ...]) -> None:
        """A position fix arrived (ground frame): correct position and velocity."""
        px, py, pz = self.position
        ex, ey, ez = position[0] - px, position[1] - py, position[2] - pz
        a, g = self.alpha, self.velocity_gain
        ux, uy, uz = self.velocity
        self.position = (px + a * ex, py + a * ey, pz + a * ez)
        self.velocity = (ux + g * ex, uy + g * ey, uz + g * ez)

    @property
    def euler(self) -> tuple[float, float, float]:
        """Estimated (roll, pitch, yaw) [rad]."""
        return quaternion_to_euler(self.quaternion)

    def values(self) -> list[float]:
        """quaternion (4), Euler angles (3), velocity (3, ground), position (3), gyro bias (3), flat."""
        return [*self.quaternion, *self.euler, *self.velocity, *self.position, *self.bias]
