"""Range sensors by ray casting: a scanning LiDAR and a low-resolution depth camera.

Both cast one ray per beam or pixel with ``pybullet.rayTestBatch`` against the collision
shapes of the world (the ground, obstacles, payloads, other vehicles); nothing is
rendered.  A ray starts ``min_range`` from the sensor's origin (so the airframe carrying
it is never seen: choose ``min_range`` beyond its collision shape) and ends at
``max_range``.  The rays of a vehicle's sensors skip every body in collision filter group
:data:`RAY_SKIP_GROUP` -- the vehicles carrying range sensors, which the vehicle puts in
that group (their collision mask stays "everything", so they collide as before) -- so a
sensor never sees its own airframe, nor another sensor-carrying vehicle.

Frames: the sensor's frame follows the body convention (x forward, y left, z up) and is
mounted on the body at ``position`` (relative to the body origin, the centre of mass) and
``orientation`` (roll, pitch, yaw, the camera's convention: positive pitch looks down).
The beam directions, and so the rays' starts and ends, are fixed in the body frame when the
vehicle is built.  A vehicle's sensor (built with its ``body``) hands PyBullet these
body-frame rays with the body as their parent (``rayTestBatch``'s ``parentObjectUniqueId``,
base link): PyBullet places them at the body's pose (its centre-of-mass frame, the pose the
vehicle's state reads) in C++, so a scan does no per-ray arithmetic in Python.  A sensor
without a body turns them into the ground frame for the pose it is given by elementwise
NumPy products and sums (exact, no BLAS; :meth:`RangeSensor.rays`, which the recorder's
point clouds also use).  Both hand PyBullet float64 arrays (read in one block; lists of
lists are read ray by ray).  The two placements differ by rounding only: hit fractions
differ by ~1e-15 and the float32 readings were the same bit for bit in every comparison
of ``experiments/speed_range_sensors.py`` (docs/obstacles_and_sensors.md).

Readings (float32, ``max_range`` where nothing is hit):

===========  =======================  ================================================
sensor       shape                    value
===========  =======================  ================================================
``lidar``    (vertical, horizontal)   distance along the beam [m]; row 0 the lowest
             or (horizontal,) for     elevation, column 0 the most clockwise azimuth
             one scan line
``depth``    (height, width)          distance along the optical axis (+x) [m]; row 0
                                      the top of the image, column 0 its left
===========  =======================  ================================================

Noise: each reading of a hit gets ``noise_std * eta``, ``eta ~ N(0, 1)`` from the
sensor's own seeded stream (apart from the physics' streams), clipped to
``[min_range, max_range]``; readings of rays that hit nothing stay ``max_range``.
A scan is refreshed at most once per ``1 / rate_hz`` of simulated time.
"""

from __future__ import annotations

import gc
import math
from collections.abc import Sequence
from operator import itemgetter
from typing import TYPE_CHECKING, Any

import numpy as np

from pyflyt_engine import exact
from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.frames import euler_to_quaternion, quaternion_to_rows

if TYPE_CHECKING:
    from pyflyt_engine.spec import DepthSensorSpec, LidarSpec

#: most rays cast in one ``rayTestBatch`` call.  PyBullet streams a batch only while it
#: holds fewer than MAX_RAY_INTERSECTION_BATCH_SIZE_STREAMING rays (16 * 1024 on Linux and
#: Windows, 4 * 1024 on macOS; bullet3 examples/SharedMemory/SharedMemoryPublic.h and
#: PhysicsDirect::uploadRaysToSharedMemory) and silently drops the rest; every ray is cast on
#: its own, so the split does not change a reading
MAX_BATCH = 4 * 1024 - 1
#: collision filter group of a vehicle carrying range sensors (its collision mask stays
#: "everything", so it collides as any body); its sensors' rays skip this group: every ray
#: starts inside the vehicle's bounding box, and testing each against its shape would cost
#: ~4 us a ray (docs/obstacles_and_sensors.md)
RAY_SKIP_GROUP = 1 << 20
#: the rays' collision mask: every group but :data:`RAY_SKIP_GROUP`
RAY_MASK = -1 ^ RAY_SKIP_GROUP
#: the hit fraction of one of ``rayTestBatch``'s result tuples
_FRACTION = itemgetter(2)


def lidar_directions(spec: LidarSpec) -> tuple[list[tuple[float, float, float]], tuple[int, int]]:
    """Unit beam directions in the sensor frame, row-major over (vertical, horizontal)."""
    h, v = math.radians(spec.horizontal_fov_deg), math.radians(spec.vertical_fov_deg)
    n, m = spec.horizontal_beams, spec.vertical_beams
    out = []
    for j in range(m):
        elevation = -0.5 * v + (j + 0.5) * v / m
        ce, se = math.cos(elevation), math.sin(elevation)
        for k in range(n):
            azimuth = -0.5 * h + (k + 0.5) * h / n
            out.append((ce * math.cos(azimuth), ce * math.sin(azimuth), se))
    return out, (m, n)


def depth_directions(spec: DepthSensorSpec) -> tuple[list[tuple[float, float, float]], tuple[int, int], list[float]]:
    """Unit pixel-centre directions in the sensor frame (row-major, row 0 the top), the
    shape, and per pixel the cosine to the optical axis (range -> depth)."""
    w, hgt = spec.width, spec.height
    tv = math.tan(math.radians(spec.fov) / 2.0)
    th = tv * w / hgt  # the horizontal half-angle's tangent follows from the aspect ratio
    out, cosines = [], []
    for r in range(hgt):
        z = tv * (1.0 - 2.0 * (r + 0.5) / hgt)
        for c in range(w):
            y = th * (1.0 - 2.0 * (c + 0.5) / w)  # column 0 is the left: +y
            norm = math.sqrt(1.0 + y * y + z * z)
            out.append((1.0 / norm, y / norm, z / norm))
            cosines.append(1.0 / norm)
    return out, (hgt, w), cosines


class RangeSensor:
    """One ray-cast sensor on a vehicle.

    Args:
        spec: the sensor's :class:`~pyflyt_engine.spec.LidarSpec` or
            :class:`~pyflyt_engine.spec.DepthSensorSpec`.
        offset: mount point relative to the body origin (centre of mass), body frame [m].
        rng: the sensor's noise stream.
        body: the PyBullet body carrying the sensor: its rays are then cast from its frame
            (module docstring) and :meth:`scan` reads the pose from PyBullet, not its arguments.
    """

    def __init__(self, spec: Any, offset: Sequence[float], rng: np.random.Generator, body: int | None = None) -> None:
        self.spec = spec
        self.name: str = spec.name
        self.kind: str = spec.type
        self.offset = tuple(float(v) for v in offset)
        self.min_range, self.max_range = float(spec.min_range), float(spec.max_range)
        self.shape: tuple[int, ...]
        if self.kind == "lidar":
            directions, self.shape = lidar_directions(spec)
            if self.shape[0] == 1:  # one scan line: a vector of the horizontal beams
                self.shape = (self.shape[1],)
            self._axial = None
        else:
            directions, self.shape, cosines = depth_directions(spec)
            self._axial = np.array(cosines)
        mount = quaternion_to_rows(euler_to_quaternion(*(math.radians(a) for a in spec.orientation_deg)))
        in_body = [exact.rotate(mount, d) for d in directions]  # beam directions in the body frame
        #: (n, 3): the body-frame beam directions, one row per beam, and its columns (n, 1)
        self._directions = np.array(in_body)
        self._columns = [self._directions[:, i : i + 1].copy() for i in range(3)]
        self._count = len(in_body)
        #: (2, 1, 1): the distances of a ray's start and end from the sensor
        self._reach = np.array([self.min_range, self.max_range]).reshape(2, 1, 1)
        self._span = self.max_range - self.min_range
        self._period = 1.0 / spec.rate_hz - 1e-9  # a scan younger than this is returned again
        #: the carrying body, or None (the rays are then placed by :meth:`rays`)
        self.body = body
        # the body-frame rays: starts offset + min_range d, ends offset + max_range d, (n, 3) each
        local = self._reach * self._directions
        local += np.array(self.offset)
        self._local = (np.ascontiguousarray(local[0]), np.ascontiguousarray(local[1]))
        self.rng = rng
        self._last: tuple[float, np.ndarray] | None = None

    @property
    def count(self) -> int:
        """Rays per scan."""
        return self._count

    def rays(self, position: Sequence[float], quaternion: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
        """Ground-frame ray starts and ends, ``(n, 3)`` each, for a body at ``position``, ``quaternion``
        (C-contiguous float64 views of one ``(2, n, 3)`` array)."""
        (a, b, c), (d, e, f), (g, h, i) = quaternion_to_rows(quaternion)
        x, y, z = self.offset
        px, py, pz = (float(v) for v in position)
        # the mount point in the ground frame: R offset + position
        origin = np.array((a * x + b * y + c * z + px, d * x + e * y + f * z + py, g * x + h * y + i * z + pz))
        rt = np.array(((a, d, g), (b, e, h), (c, f, i)))  # rt[j] = column j of R
        dx, dy, dz = self._columns
        # R d for every beam as elementwise products and sums in a fixed order: exact, no BLAS
        ground = dx * rt[0]
        ground += dy * rt[1]
        ground += dz * rt[2]
        ends = self._reach * ground  # (2, n, 3): min_range R d, max_range R d
        ends += origin
        return ends[0], ends[1]

    def scan(
        self, client: int, position: Sequence[float], quaternion: Sequence[float], time: float | None = None
    ) -> np.ndarray:
        """The readings (module docstring), cast again when ``1 / rate_hz`` has passed since the last."""
        cached = self._last
        if time is not None and cached is not None and time - cached[0] < self._period:
            return cached[1].copy()
        body = self.body
        if body is None:
            starts, ends = self.rays(position, quaternion)
            parent = {}
        else:  # PyBullet places the body-frame rays at the body's pose
            starts, ends = self._local
            parent = {"parentObjectUniqueId": body, "parentLinkIndex": -1}
        n = self._count
        # PyBullet's result tuples are thousands of small containers for a large sensor: with
        # the cyclic garbage collector on, their allocation sets off collections that walk
        # every live object of the process (for a 64 x 48 image: ~11 ms a scan instead of
        # ~4); none of them can form a cycle, so collection waits until they are freed
        collecting = gc.isenabled()
        gc.disable()
        try:
            # PyBullet reports fraction 1 for a ray that hits nothing: its reading is max_range
            if n <= MAX_BATCH:
                results = p.rayTestBatch(starts, ends, collisionFilterMask=RAY_MASK, physicsClientId=client, **parent)
                fractions = np.fromiter(map(_FRACTION, results), np.float64, n)
            else:
                fractions = np.empty(n)
                for a in range(0, n, MAX_BATCH):
                    b = min(a + MAX_BATCH, n)
                    results = p.rayTestBatch(
                        starts[a:b], ends[a:b], collisionFilterMask=RAY_MASK, physicsClientId=client, **parent
                    )
                    fractions[a:b] = np.fromiter(map(_FRACTION, results), np.float64, b - a)
            del results
        finally:
            if collecting:
                gc.enable()
        noisy, axial = self.spec.noise_std > 0, self._axial
        hit = fractions < 1.0 if noisy or axial is not None else None
        ranges = fractions * self._span
        ranges += self.min_range
        if noisy and hit is not None:  # (hit is computed whenever noisy)
            eta = self.rng.standard_normal(n)
            ranges = np.where(hit, np.clip(ranges + self.spec.noise_std * eta, self.min_range, self.max_range), ranges)
        if axial is not None and hit is not None:  # depth camera: along the optical axis
            ranges = np.where(hit, ranges * axial, self.max_range)
        readings = ranges.reshape(self.shape).astype(np.float32)
        self._last = (time if time is not None else float("nan"), readings)
        return readings.copy()

    def reset(self) -> None:
        """Forget the last scan."""
        self._last = None


def points(
    sensor: RangeSensor, readings: np.ndarray, position: Sequence[float], quaternion: Sequence[float]
) -> np.ndarray:
    """The hit points of a scan in the ground frame, ``(k, 3)`` (rays that hit nothing left out)."""
    starts, ends = sensor.rays(position, quaternion)
    values = np.asarray(readings, dtype=np.float64).reshape(-1)
    if sensor._axial is not None:
        values = values / sensor._axial
    unit = (ends - starts) / (sensor.max_range - sensor.min_range)
    origin = starts - sensor.min_range * unit
    keep = values < sensor.max_range - 1e-6
    return origin[keep] + values[keep, None] * unit[keep]
