"""Ray-cast range sensors (LiDARs, depth cameras) on the batched backend: the PyBullet
engine's :class:`~pyflyt_engine.components.range_sensor.RangeSensor` on arrays, one row per
env, in one compiled call.

A single-agent batched env holds nothing a ray can hit but the ground plane ``z = 0``
(obstacles and payloads are refused), so where the engine asks ``pybullet.rayTestBatch``
this computes the hit in closed form.  The rays are the engine's: each sensor's body-frame
starts ``offset + min_range d`` and ends ``offset + max_range d`` (``d`` the beam or pixel
direction turned by the mount, ``offset`` the mount point from the centre of mass) come from
a :class:`RangeSensor` built from the same spec, so the beam layout is written once.  For
env ``i`` at position ``p`` and body-to-ground rotation ``R`` (its state quaternion) a ray's
ground-frame heights are ``s_z = (R start)_z + p_z`` and ``e_z = (R end)_z + p_z``; it hits
the plane where the two have opposite signs (Bullet's triangle ray test:
``dist_a * dist_b < 0``, a ray from below hits too), at the fraction
``f = s_z / (s_z - e_z)`` of the way (a hit needs ``f < 1``, the engine's test), and then
reads, as the engine reads a fraction, ``f * (max_range - min_range) + min_range``; a miss
reads ``1 * (max_range - min_range) + min_range`` (a LiDAR) or ``max_range`` (a depth
camera), as the engine's fraction 1 gives.  Noise: when ``noise_std > 0`` every scan draws
one standard normal per ray, in ray order, from the sensor's own stream (numpy's ziggurat,
:func:`pyflyt_engine.batched.normals.standard_normal`, the draws of
``Generator.standard_normal(n)``), and a hit reads ``clip(r + noise_std eta, min_range,
max_range)``; a depth camera then reads a hit times the pixel's cosine to the optical axis.
The readings are rounded to float32, as the engine's are.

Refresh: a scan is cast when the observation is built and ``1 / rate_hz - 1e-9`` s of
simulated time (``physics_steps * physics_dt``) have passed since the last cast, else the
last readings are shown again; a reset forgets the last scan (the engine's ``scan(time)``
and ``reset``).  So the state per env is each sensor's last cast time (NaN: none since the
reset) and the readings it holds, which a checkpoint carries with the sensors' streams.

Streams: env ``i``'s sensor ``k`` draws from the child of env ``i``'s seed sequence with
spawn key ``(3, 0, k)``, the key under which the PyBullet world seeds sensor ``k`` of its
vehicle 0 (``World._sensor_rngs``), apart from every other draw of the env.

Against PyBullet (``tests/batched/test_range_sensors.py``): PyBullet intersects the ray
with the two triangles it makes of the plane over the ray's bounding box, in double
precision, and the fraction it reports differs from the closed form by rounding of the
order of ``1e-15``; the rotation it places the rays with differs from the state's in the
last bits.  The reading is then rounded to float32, so the two readings agree to within one
float32 spacing at the reading (``2**-23 max_range`` at most, relative ``1.2e-7`` of the
max range) plus that rounding: the test holds them to ``2**-22 max_range``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pyflyt_engine.batched.compiled import njit
from pyflyt_engine.batched.kernels import rotation_rows as _rotation_rows
from pyflyt_engine.batched.normals import standard_normal
from pyflyt_engine.batched.sensors import stream_interface

#: a sensor's parameters: min_range, max_range, span, noise_std, refresh period, depth flag,
#: its first ray and its ray count (in the stacked rays)
R_MIN, R_MAX, R_SPAN, R_NOISE, R_PERIOD, R_DEPTH, R_FIRST, R_COUNT = range(8)
PARAMETER_SIZE = 8


@njit(cache=True)
def scan_row(params, starts, ends, axial, rotation, pos, time, last, held, states, next_uint64, next_double):
    """One env's scans at simulated ``time``: every sensor (a row of ``params``) whose last cast
    (``last[k]``, NaN: none) is at least its period old casts its rays (rows ``first ...`` of
    the body-frame ``starts``, ``ends``; ``axial`` a depth pixel's cosine) from the body at
    ``pos`` with body-to-ground ``rotation`` (9, row-major) into ``held`` and draws its noise
    from the stream at ``states[k]`` (module docstring)."""
    r6, r7, r8 = rotation[6], rotation[7], rotation[8]
    pz = pos[2]
    for k in range(params.shape[0]):
        p = params[k]
        if not np.isnan(last[k]) and time - last[k] < p[R_PERIOD]:
            continue
        last[k] = time
        low, high, span, std = p[R_MIN], p[R_MAX], p[R_SPAN], p[R_NOISE]
        depth = p[R_DEPTH] != 0.0
        first, count = int(p[R_FIRST]), int(p[R_COUNT])
        for j in range(first, first + count):
            # btTransform * v: the basis's row dotted with v, then the origin
            sz = r6 * starts[j, 0] + r7 * starts[j, 1] + r8 * starts[j, 2] + pz
            ez = r6 * ends[j, 0] + r7 * ends[j, 1] + r8 * ends[j, 2] + pz
            fraction = 1.0
            if sz * ez < 0.0:
                f = sz / (sz - ez)
                if f < 1.0:
                    fraction = f
            hit = fraction < 1.0
            reading = fraction * span + low
            if std > 0.0:
                eta = standard_normal(states[k], next_uint64, next_double)
                if hit:
                    reading = min(max(reading + std * eta, low), high)
            if depth:
                reading = reading * axial[j] if hit else high
            held[j] = np.float64(np.float32(reading))


@njit(cache=True)
def scan_rows(index, params, starts, ends, axial, pos, quat, times, last, held, states, next_uint64, next_double):
    """:func:`scan_row` of every env in ``index`` (env ``i`` at time ``times[i]``, its
    rotation from its state quaternion)."""
    rotation = np.empty(9)
    for m in range(index.shape[0]):
        i = index[m]
        _rotation_rows(quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3], rotation)
        scan_row(
            params,
            starts,
            ends,
            axial,
            rotation,
            pos[i],
            times[i],
            last[i],
            held[i],
            states[i],
            next_uint64,
            next_double,
        )


class BatchedRangeSensors:
    """The range sensors of ``n`` envs of one airframe (module docstring).

    Args:
        specs: the airframe's range sensors, the env config's appended (the order the
            PyBullet vehicle holds them in).
        com: the airframe's centre of mass in its spec's coordinates.
        n: envs.
        physics_dt: the physics step [s].
    """

    def __init__(self, specs: list[Any], com: Any, n: int, physics_dt: float) -> None:
        from pyflyt_engine.components.range_sensor import RangeSensor

        self.physics_dt = float(physics_dt)
        #: the engine's sensors built from the same specs (their rays, shapes and names)
        self.engine = [
            RangeSensor(s, tuple(float(a) - float(c) for a, c in zip(s.position, com)), np.random.default_rng(0))
            for s in specs
        ]
        starts, ends, axial, params = [], [], [], []
        first = 0
        for sensor in self.engine:
            start, end = sensor._local
            starts.append(start)
            ends.append(end)
            axial.append(sensor._axial if sensor._axial is not None else np.ones(sensor.count))
            params.append(
                (
                    sensor.min_range,
                    sensor.max_range,
                    sensor._span,
                    float(sensor.spec.noise_std),
                    sensor._period,
                    float(sensor._axial is not None),
                    first,
                    sensor.count,
                )
            )
            first += sensor.count
        self.starts = np.ascontiguousarray(np.concatenate(starts), dtype=np.float64)
        self.ends = np.ascontiguousarray(np.concatenate(ends), dtype=np.float64)
        self.axial = np.ascontiguousarray(np.concatenate(axial), dtype=np.float64)
        self.params = np.array(params, dtype=np.float64)
        #: each sensor's columns of the held readings, by name
        self.columns = {
            s.name: slice(int(p[R_FIRST]), int(p[R_FIRST] + p[R_COUNT])) for s, p in zip(self.engine, self.params)
        }
        #: per env, each ray's held reading (float32 values) and each sensor's last cast time
        self.held = np.zeros((n, first))
        self.last = np.full((n, len(self.engine)), np.nan)
        #: per env, one stream per sensor
        self.rngs: list[list[np.random.Generator]] = []
        self._interface: tuple[np.ndarray, Any, Any] | None = None
        self._interface_of: list | None = None

    @property
    def names(self) -> list[str]:
        return [s.name for s in self.engine]

    def seed(self, children: list[np.random.SeedSequence]) -> None:
        """Env ``i``'s sensor ``k`` stream: the child of ``children[i]`` with spawn key ``(3, 0, k)``."""
        self.rngs = [
            [
                np.random.default_rng(np.random.SeedSequence(c.entropy, spawn_key=(*c.spawn_key, 3, 0, k)))
                for k in range(len(self.engine))
            ]
            for c in children
        ]

    def interface(self) -> tuple[np.ndarray, Any, Any]:
        if self._interface_of is not self.rngs or self._interface is None:
            flat = [rng for row in self.rngs for rng in row]
            states, next_uint64, next_double = stream_interface(flat)
            self._interface = (states.reshape(len(self.rngs), len(self.engine)), next_uint64, next_double)
            self._interface_of = self.rngs
        return self._interface

    def forget(self, index: np.ndarray) -> None:
        """A reset of the envs ``index``: no scan since (the next observation casts one)."""
        self.last[index] = np.nan

    def scan(self, index: np.ndarray, pos: np.ndarray, quat: np.ndarray, physics_steps: np.ndarray) -> None:
        """The envs ``index`` cast what is due at their time ``physics_steps * physics_dt``."""
        states, next_uint64, next_double = self.interface()
        times = physics_steps * self.physics_dt
        scan_rows(
            np.asarray(index, dtype=np.int64),
            self.params,
            self.starts,
            self.ends,
            self.axial,
            pos,
            quat,
            times,
            self.last,
            self.held,
            states,
            next_uint64,
            next_double,
        )

    def readings(self, i: int) -> dict[str, np.ndarray]:
        """Env ``i``'s held readings by name, float32 in each sensor's shape (``world.scan``'s)."""
        return {s.name: self.held[i, self.columns[s.name]].astype(np.float32).reshape(s.shape) for s in self.engine}


__all__ = ["BatchedRangeSensors", "scan_row", "scan_rows"]
