"""The wind field of a World: one coherent field, sampled at each vehicle's position.

The field is the sum of the parts of a :class:`~pyflyt_engine.atmosphere.config.WindConfig`:

* **mean** wind, ground frame: ``speed`` toward ``direction`` times a height factor —
  1 (``uniform``), ``ln(z / z0) / ln(h_ref / z0)`` for ``z > z0`` and 0 below (``log``,
  the neutral surface-layer law, e.g. Stull, "An Introduction to Boundary Layer
  Meteorology", 1988, eq. 9.7.5c), or ``(z / h_ref)^alpha`` for ``z > 0`` (``power``,
  Hellmann's law) — plus a uniform ``vertical`` component;
* a discrete **gust** (MIL-F-8785C 3.7.3, "1-cosine"), the same everywhere at a time;
* **turbulence** (Dryden, :mod:`pyflyt_engine.atmosphere.dryden`): the linear gusts
  ``(u, v, w)`` are one realisation for the whole world (a frozen field advected past
  every vehicle at the same instant, evaluated at the config's reference height), and the
  rotary gusts ``(p, q, r)`` are per vehicle, shaped by its span and derived from the same
  ``w`` and ``v`` gusts (``p`` from its own noise).  Nearby vehicles therefore feel the
  same linear turbulence; spatial decorrelation between vehicles is not modelled.

A vehicle flies through the air, so the loads see ``v_air = v_body - R^T v_wind`` and
``omega_air = omega_body - R^T omega_gust`` (``R`` body to ground): that subtraction is
done once, by the vehicle (:meth:`pyflyt_engine.vehicle.Vehicle.read_velocity`).

The world advances the field one physics step at a time (:meth:`WindField.advance`) and
reseeds it with everything else; all randomness comes from the field's own generator.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from pyflyt_engine.atmosphere.config import WindConfig
from pyflyt_engine.atmosphere.dryden import DrydenProcess, low_altitude_scales

#: (wind x, y, z [m/s], rotary gust p, q, r [rad/s]), ground frame
WindSample = tuple[float, float, float, float, float, float]
_ZERO3 = (0.0, 0.0, 0.0)


def gust_profile(x: float, length: float, shape: str) -> float:
    """The 1-cosine gust fraction (0..1) at distance ``x`` [m] past the gust front (MIL-F-8785C 3.7.3)."""
    if x <= 0.0:
        return 0.0
    if x <= length:
        return 0.5 * (1.0 - math.cos(math.pi * x / length))
    if shape == "step":
        return 1.0
    if x <= 2.0 * length:
        return 0.5 * (1.0 - math.cos(math.pi * x / length))
    return 0.0


def shear_factor(config: WindConfig, height: float) -> float:
    """The mean wind's height factor at ``height`` [m] (1 for a uniform wind)."""
    mean = config.mean
    if mean is None or mean.profile == "uniform":
        return 1.0
    if mean.profile == "log":
        z0 = mean.roughness_length
        return math.log(height / z0) / math.log(mean.reference_height / z0) if height > z0 else 0.0
    return (height / mean.reference_height) ** mean.exponent if height > 0.0 else 0.0


class WindField:
    """The wind of one world (see the module docstring).

    Args:
        config: the wind config (not calm: a calm world has no field).
        physics_dt: the physics step [s].
        rng: the generator of the turbulence (the world's wind stream).
    """

    def __init__(self, config: WindConfig, physics_dt: float, rng: np.random.Generator) -> None:
        self.config = config
        self.physics_dt = physics_dt
        self.rng = rng
        mean = config.mean
        if mean is not None:
            heading = math.radians(mean.direction)
            self._mean = (mean.speed * math.cos(heading), mean.speed * math.sin(heading))
            self._vertical = mean.vertical
            self._sheared = mean.profile != "uniform" and mean.speed != 0.0
        else:
            self._mean, self._vertical, self._sheared = (0.0, 0.0), 0.0, False
        turbulence = config.turbulence
        self._turbulent = turbulence is not None and turbulence.wind_speed_20ft > 0
        self._angular = self._turbulent and turbulence.angular  # type: ignore[union-attr]
        if self._turbulent:
            assert turbulence is not None
            direction = turbulence.direction if turbulence.direction is not None else (mean.direction if mean else 0.0)
            self._turbulence_heading = math.radians(direction)
            self.scales = low_altitude_scales(turbulence.height, turbulence.wind_speed_20ft)
        self.spans: list[float] = []
        self._process: DrydenProcess | None = None
        self._rows: list[list[float]] = []
        self.step_index = 0
        self._now: tuple[float, ...] = ()
        self._build()

    # ------------------------------------------------------------ building

    def add_vehicle(self, span: float) -> Callable[[Sequence[float]], WindSample]:
        """Register a vehicle of span ``span`` [m]; returns its probe ``position -> WindSample``.

        With rotary turbulence the process is rebuilt (a new realisation): add vehicles
        before flying.
        """
        index = len(self.spans)
        self.spans.append(float(span))
        if self._angular:
            self._build()

        def probe(position: Sequence[float]) -> WindSample:
            return self.at(index, position)

        return probe

    def _build(self) -> None:
        if self._turbulent:
            turbulence = self.config.turbulence
            assert turbulence is not None
            self._process = DrydenProcess(
                self.scales,
                turbulence.advection_speed,
                self.spans if self._angular else (),
                self.physics_dt,
                self.rng,
            )
            c, s = math.cos(self._turbulence_heading), math.sin(self._turbulence_heading)
            blocks = 1 + (len(self.spans) if self._angular else 0)
            rotation = np.zeros((3 * blocks, 3 * blocks))
            for b in range(blocks):  # turbulence axes -> ground frame, per (u, v, w) and (p, q, r) triple
                rotation[3 * b : 3 * b + 3, 3 * b : 3 * b + 3] = ((c, -s, 0.0), (s, c, 0.0), (0.0, 0.0, 1.0))
            self._to_ground = rotation
        self._restart()

    def _restart(self) -> None:
        self.step_index = 0
        self._k = 0
        self._rows = self._generate() if self._process is not None else []
        self._update()

    def _generate(self) -> list[list[float]]:
        assert self._process is not None
        return (self._to_ground @ self._process.generate()).T.tolist()

    # ------------------------------------------------------------ stepping

    def reset(self, rng: np.random.Generator | None = None) -> None:
        """Back to time 0 with a new turbulence realisation (from ``rng`` when given)."""
        if rng is not None:
            self.rng = rng
            if self._process is not None:
                self._process.rng = rng
        if self._process is not None:
            self._process.reset()
        self._restart()

    def reseed(self, rng: np.random.Generator) -> None:
        """Draw the turbulence from ``rng`` from now on (a restored stream)."""
        self.rng = rng
        if self._process is not None:
            self._process.rng = rng

    def advance(self) -> None:
        """Move on one physics step."""
        self.step_index += 1
        if self._process is not None:
            self._k += 1
            if self._k == len(self._rows):
                self._rows = self._generate()
                self._k = 0
        self._update()

    def _update(self) -> None:
        """The parts that are the same everywhere at this step: (x, y, z) wind and the turbulence row."""
        wx, wy = self._mean
        wz = self._vertical
        if self._sheared:
            wx = wy = 0.0  # the sheared mean wind is added per position
        gust = self.config.gust
        if gust is not None:
            f = gust_profile(gust.speed * (self.step_index * self.physics_dt - gust.start), gust.length, gust.shape)
            ax, ay, az = gust.amplitude
            wx, wy, wz = wx + f * ax, wy + f * ay, wz + f * az
        if self._process is not None:
            row = self._rows[self._k]
            wx, wy, wz = wx + row[0], wy + row[1], wz + row[2]
            self._now = (wx, wy, wz, row)
        else:
            self._now = (wx, wy, wz, None)

    @property
    def time(self) -> float:
        """Time since the last reset [s]."""
        return self.step_index * self.physics_dt

    def at(self, index: int, position: Sequence[float]) -> WindSample:
        """Wind velocity (x, y, z) [m/s] and rotary gust (p, q, r) [rad/s], ground frame, at
        ``position`` [m] for vehicle ``index`` at the current step."""
        wx, wy, wz, row = self._now
        if self._sheared:
            f = shear_factor(self.config, position[2])
            wx += f * self._mean[0]
            wy += f * self._mean[1]
        if row is not None and self._angular:
            k = 3 + 3 * index
            return (wx, wy, wz, row[k], row[k + 1], row[k + 2])
        return (wx, wy, wz, 0.0, 0.0, 0.0)


def vehicle_span(motor_positions: np.ndarray | None, surfaces: Sequence) -> float:
    """A vehicle's span ``b`` [m] for the rotary gusts: twice its largest lateral reach
    (motor hubs; surface centres plus half their span along y), at least 0.05 m."""
    reach = 0.0
    if motor_positions is not None and len(motor_positions):
        reach = float(np.max(np.abs(np.asarray(motor_positions)[:, 1])))
    for s in surfaces:
        c, n = s.chord_axis, s.normal_axis
        span_y = float(c[2] * n[0] - c[0] * n[2])  # y of the span axis c x n
        reach = max(reach, abs(float(s.position[1])) + 0.5 * float(s.span) * abs(span_y))
    return max(2.0 * reach, 0.05)
