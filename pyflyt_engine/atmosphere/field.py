"""The wind field of a World: one coherent field, sampled at each vehicle's position.

The field is the sum of the parts of a :class:`~pyflyt_engine.atmosphere.config.WindConfig`:

* **mean** wind, ground frame: ``speed`` toward ``direction`` times a height factor —
  1 (``uniform``), ``ln(z / z0) / ln(h_ref / z0)`` for ``z > z0`` and 0 below (``log``,
  the neutral surface-layer law, e.g. Stull, "An Introduction to Boundary Layer
  Meteorology", 1988, section 9.7), or ``(z / h_ref)^alpha`` for ``z > 0`` (``power``,
  Hellmann's law) — plus a uniform ``vertical`` component;
* a discrete **gust** (MIL-F-8785C, discrete gusts, "1-cosine"), the same everywhere at a time;
* **turbulence** (Dryden, :mod:`pyflyt_engine.atmosphere.dryden`): the linear gusts
  ``(u, v, w)`` are one realisation for the whole world (a frozen field advected past
  every vehicle at the same instant, evaluated at the config's reference height), and the
  rotary gusts ``(p, q, r)`` are per vehicle, shaped by its span and derived from the same
  ``w`` and ``v`` gusts (``p`` from its own noise).  Nearby vehicles therefore feel the
  same linear turbulence; spatial decorrelation between vehicles is not modelled.

A vehicle flies through the air, so the loads see ``v_air = v_body - R^T v_wind`` and
``omega_air = omega_body - R^T omega_gust`` (``R`` body to ground): that subtraction is
done once, for every vehicle, by :mod:`pyflyt_engine.atmosphere.air`.

The world advances the field one physics step at a time (:meth:`WindField.advance`) and
reseeds it with everything else; all randomness comes from the field's own generator.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from pyflyt_engine import exact
from pyflyt_engine.atmosphere.config import WindConfig
from pyflyt_engine.atmosphere.dryden import DrydenProcess, low_altitude_scales

#: (wind x, y, z [m/s], rotary gust p, q, r [rad/s]), ground frame
WindSample = tuple[float, float, float, float, float, float]
_ZERO3 = (0.0, 0.0, 0.0)


def gust_profile(x: float, length: float, shape: str) -> float:
    """The 1-cosine gust fraction (0..1) at distance ``x`` [m] past the gust front (MIL-F-8785C, discrete gusts)."""
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

    Samples are generated ahead in blocks of ``block`` physics steps, vectorised (mean
    wind, gust and turbulence together, one row per vehicle and step), so advancing a
    step is an index increment and sampling at a vehicle a list lookup (plus the shear
    factor of its height, for a sheared mean wind).

    Args:
        config: the wind config (not calm: a calm world has no field).
        physics_dt: the physics step [s].
        rng: the generator of the turbulence (the world's wind stream).
        block: physics steps generated at a time.
    """

    def __init__(self, config: WindConfig, physics_dt: float, rng: np.random.Generator, block: int = 2048) -> None:
        self.config = config
        self.physics_dt = physics_dt
        self.rng = rng
        self.block = block
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
        #: the field does not change with time (no gust, no turbulence): the world need not advance it
        self.static = config.gust is None and not self._turbulent
        if self.static:
            self.block = 1
        self.spans: list[float] = []
        self._process: DrydenProcess | None = None
        self._rows: list[list[list[float]]] = []  # per vehicle, per step of the block: the 6 values
        self._start = 0  # physics step of the block's first row
        self._k = 0  # row of the current step in the block
        self._n = 0  # rows in the block
        self._build()

    # ------------------------------------------------------------ building

    def add_vehicle(self, span: float) -> Callable[[Sequence[float]], WindSample]:
        """Register a vehicle of span ``span`` [m]; returns its probe ``position -> WindSample``.

        The samples from the current step on are generated again (with rotary turbulence,
        from a new realisation: add vehicles before flying); the time goes on.
        """
        return self.add_vehicles([span])[0]

    def add_vehicles(self, spans: Sequence[float]) -> list[Callable[[Sequence[float]], WindSample]]:
        """Register vehicles of spans ``spans`` [m] at once; returns their probes, in order.

        As many :meth:`add_vehicle` calls would, but the turbulence filter is built once, for
        all of them (the same filter the last of those calls builds; it draws one stationary
        state, where each call draws its own)."""
        first = len(self.spans)
        self.spans.extend(float(b) for b in spans)
        if self._angular and any(self._rotary(b) for b in self.spans[first:]):
            self._build()
        else:
            self._start = self.step_index
            self._fill()
        return [self._probe(index) for index in range(first, len(self.spans))]

    def _probe(self, index: int) -> Callable[[Sequence[float]], WindSample]:
        if self._sheared:
            mx, my = self._mean
            config = self.config

            def sheared(position: Sequence[float]) -> WindSample:
                row = self._rows[index][self._k]
                f = shear_factor(config, position[2])
                return (row[0] + f * mx, row[1] + f * my, row[2], row[3], row[4], row[5])

            return sheared

        def probe(position: Sequence[float]) -> WindSample:
            return self._rows[index][self._k]  # type: ignore[return-value]

        return probe

    def _rotary(self, span: float) -> bool:
        """Whether a vehicle of ``span`` [m] gets rotary gusts (``rotary_min_span``)."""
        turbulence = self.config.turbulence
        return turbulence is not None and span >= turbulence.rotary_min_span

    def _build(self) -> None:
        if self._turbulent:
            turbulence = self.config.turbulence
            assert turbulence is not None
            #: per vehicle: its row in the process's rotary outputs, or None (no rotary gusts)
            self._rotary_rows: list[int | None] = []
            spans: list[float] = []
            for b in self.spans if self._angular else ():
                self._rotary_rows.append(len(spans) if self._rotary(b) else None)
                if self._rotary(b):
                    spans.append(b)
            self._process = DrydenProcess(
                self.scales,
                turbulence.advection_speed,
                spans,
                self.physics_dt,
                self.rng,
                block=self.block,
            )
            #: cosine and sine of the turbulence x axis's heading (turbulence axes -> ground frame)
            self._to_ground = (math.cos(self._turbulence_heading), math.sin(self._turbulence_heading))
        self._start = self.step_index
        self._fill()

    def _restart(self) -> None:
        self._start = 0
        self._fill()

    def _fill(self) -> None:
        """Generate the block of samples that starts at physics step :attr:`_start`."""
        n = self.block
        linear = np.empty((3, n))
        linear[0] = 0.0 if self._sheared else self._mean[0]
        linear[1] = 0.0 if self._sheared else self._mean[1]
        linear[2] = self._vertical
        gust = self.config.gust
        if gust is not None:
            t = (self._start + np.arange(n)) * self.physics_dt
            f = gust_profiles(gust.speed * (t - gust.start), gust.length, gust.shape)
            linear += np.outer(gust.amplitude, f)
        rotary = None
        if self._process is not None:
            turbulence = _turned(self._process.generate(n), *self._to_ground)
            linear += turbulence[:3]
            if self._angular:
                rotary = turbulence[3:]
        zeros = np.zeros((3, n))
        rows = getattr(self, "_rotary_rows", [])
        self._rows = []
        for i in range(len(self.spans)):
            j = rows[i] if rotary is not None and i < len(rows) else None
            spin = rotary[3 * j : 3 * j + 3] if rotary is not None and j is not None else zeros
            self._rows.append(np.vstack((linear, spin)).T.tolist())
        self._k = 0
        self._n = n

    # ------------------------------------------------------------ stepping

    def reset(self, rng: np.random.Generator | None = None) -> None:
        """Back to time 0 with a new turbulence realisation (from ``rng`` when given)."""
        if rng is not None:
            self.reseed(rng)
        if self._process is not None:
            self._process.reset()
        self._restart()

    def reseed(self, rng: np.random.Generator) -> None:
        """Draw the turbulence from ``rng`` from now on (a restored stream)."""
        self.rng = rng
        if self._process is not None:
            self._process.rng = rng

    def advance(self) -> None:
        """Move on one physics step (a static field stays as it is: its one row)."""
        if self.static:
            return
        k = self._k + 1
        if k == self._n:
            self._start += self._n
            self._fill()
        else:
            self._k = k

    @property
    def step_index(self) -> int:
        """Physics steps since the last reset."""
        return self._start + self._k

    @property
    def time(self) -> float:
        """Time since the last reset [s]."""
        return self.step_index * self.physics_dt

    def at(self, index: int, position: Sequence[float]) -> WindSample:
        """Wind velocity (x, y, z) [m/s] and rotary gust (p, q, r) [rad/s], ground frame, at
        ``position`` [m] for vehicle ``index`` at the current step."""
        wx, wy, wz, p, q, r = self._rows[index][self._k]
        if self._sheared:
            f = shear_factor(self.config, position[2])
            wx += f * self._mean[0]
            wy += f * self._mean[1]
        return (wx, wy, wz, p, q, r)


def _turned(samples: np.ndarray, c: float, s: float) -> np.ndarray:
    """Each (x, y, z) triple of rows of ``samples`` turned about z from the turbulence axes
    to the ground frame: ``(c x - s y, s x + c y, z)``."""
    out = np.empty_like(samples)
    for b in range(0, samples.shape[0], 3):
        x, y = samples[b], samples[b + 1]
        out[b] = c * x - s * y
        out[b + 1] = s * x + c * y
        out[b + 2] = samples[b + 2]
    return out


def gust_profiles(x: np.ndarray, length: float, shape: str) -> np.ndarray:
    """:func:`gust_profile` over an array of distances ``x`` [m]."""
    x = np.asarray(x, dtype=float)
    # math.cos per element, not np.cos (CPU-dependent on AVX-512 machines: pyflyt_engine.exact)
    rise = 0.5 * (1.0 - exact.apply(math.cos, np.pi * np.clip(x, 0.0, None) / length))
    out = np.where(x <= 0.0, 0.0, rise)
    if shape == "step":
        return np.where(x > length, 1.0, out)
    return np.where(x > 2.0 * length, 0.0, out)


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
