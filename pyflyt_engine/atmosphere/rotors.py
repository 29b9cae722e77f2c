"""Rotor aerodynamic interactions: ground effect and downwash between vehicles.

**Ground effect** (Cheeseman & Bennett, "The effect of the ground on a helicopter rotor
in forward flight", ARC R&M 3021, 1955; the hover form from the method of images)::

    T_IGE / T_OGE = 1 / (1 - (R / (4 z))^2)

for a rotor of radius ``R`` whose hub is ``z`` above the ground.  The ratio diverges at
``z = R / 4`` while measured ratios stay finite close to the ground (e.g.
Sanchez-Cuevas et al., "Characterization of the aerodynamic ground effect and its influence
in multirotor control", Int. J. Aerospace Eng. 2017), so the height is clamped to
``z >= min_height * R`` (default 0.5: at most 4/3).  Each motor's thrust is scaled by
the ratio at its own hub height: :meth:`RotorInteractions.ground_effect_ratios` gives
them, and the motor group takes them as an input of its step
(:meth:`pyflyt_engine.components.motor.Motors.step`); the reaction torque is left alone.

**Downwash** (momentum theory plus a round turbulent jet; our model): a rotorcraft of
total thrust ``T`` over total disc area ``A`` induces ``v_h = sqrt(T / (2 rho A))`` at its
discs (Rankine-Froude momentum theory, Leishman, "Principles of Helicopter Aerodynamics",
2nd ed., 2006, chapter 2); its fully developed wake moves down at ``U_J = 2 v_h`` through
half the disc area, a jet of diameter ``d = sqrt(2 A / pi)``.  Below, it spreads as a
self-similar round jet (Pope, "Turbulent Flows", 2000, section 5.1: centreline velocity
``B U_J d / (x - x0)`` with ``B = 5.8``, half-width ``S (x - x0)`` with ``S = 0.094``)::

    U_c(dz) = U_J B d / (dz + B d)                 (x0 = -B d: U_c = U_J at the rotor)
    r_half(dz) = S (dz + B d)                      (~ d / 2 at the rotor)
    w(dz, r) = -U_c exp(-ln 2 (r / r_half)^2)      (ground frame, downward)

at ``dz`` below the rotorcraft and ``r`` off its axis.  The downwash is a wind: it enters
the vehicle below through its air-relative velocity (body drag, lifting surfaces) like any
other wind.  Limits: the jet is vertical whatever the upper vehicle's attitude; the change
of a rotor's thrust in the descending air of the wake (inflow) is not modelled; positions
of the other vehicles are their latest reads (at most one physics step old), and their
thrust is that of their current throttles.

**Which pairs are evaluated.** The wake is Gaussian across, so every rotorcraft above
reaches every vehicle below in principle; but beyond ``r = WAKE_REACH * r_half`` (about
33 half-widths) the factor ``exp(-ln 2 (r / r_half)^2)`` is below ``exp(-760)``, which
IEEE double arithmetic rounds to exactly 0.0 (the least subnormal number is about
``exp(-744.4)``), so the term it would add is exactly 0.0 and leaving it out changes no
bit of the sum.  A :class:`~pyflyt_engine.spatial.PlanarGrid` bins the rotorcraft by
horizontal position in square cells; a vehicle's downwash (:meth:`RotorInteractions.downwash_near`) visits only the
cells within the reach of the highest rotorcraft, and of those only the vehicles above it
whose own reach covers it, in index order -- the same terms, summed in the same order,
as the all-pairs definition :meth:`RotorInteractions.downwash_at`.  In a swarm flying at
one height the reach is 1.1 to 3 m for Crazyflie-class vehicles, so the work per vehicle
is bounded by the neighbours within it, not by the size of the swarm.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from pyflyt_engine.constants import AIR_DENSITY
from pyflyt_engine.spatial import PlanarGrid

JET_DECAY = 5.8  # B, round jet centreline decay constant (Pope 2000, table 5.1, Hussein et al. 1994)
JET_SPREAD = 0.094  # S, round jet spreading rate (Pope 2000, table 5.1, Hussein et al. 1994)
_LN2 = math.log(2.0)
#: exp(-x) is exactly 0.0 in double precision for x > 745.14 (IEEE 754: the least subnormal,
#: 2^-1074, is exp(-744.44), and smaller results round to 0); 760 leaves a margin far above
#: any rounding of the reach test
_UNDERFLOW = 760.0
#: in half-widths: a wake's Gaussian factor is exactly 0.0 beyond this distance off its axis
WAKE_REACH = math.sqrt(_UNDERFLOW / _LN2)


def ground_effect_ratio(height: float, radius: float, min_height: float = 0.5) -> float:
    """T_IGE / T_OGE = 1 / (1 - (R / 4z)^2) at hub height ``height`` [m] for radius ``radius`` [m],
    with the height clamped to at least ``min_height * radius``."""
    z = max(height, min_height * radius)
    x = radius / (4.0 * z)
    return 1.0 / (1.0 - x * x)


def downwash_velocity(dz: float, r: float, thrust: float, disc_area: float, air_density: float = AIR_DENSITY) -> float:
    """Downward wake speed [m/s] at ``dz`` [m] below and ``r`` [m] off the axis of a rotorcraft
    of total thrust ``thrust`` [N] and disc area ``disc_area`` [m^2] (0 above it or without thrust)."""
    if dz <= 0.0 or thrust <= 0.0 or disc_area <= 0.0:
        return 0.0
    jet = 2.0 * math.sqrt(thrust / (2.0 * air_density * disc_area))
    d = math.sqrt(2.0 * disc_area / math.pi)
    x = dz + JET_DECAY * d
    half = JET_SPREAD * x
    return jet * JET_DECAY * d / x * math.exp(-_LN2 * (r / half) ** 2)


@dataclass
class _Rotorcraft:
    """The rotors of one vehicle: hub positions (centre-of-mass frame), radii, full thrusts."""

    positions: list[tuple[float, float, float]]
    radii: list[float | None]
    max_thrust: list[float]
    disc_area: float

    @property
    def jet_diameter(self) -> float:
        """``d = sqrt(2 A / pi)``, the diameter of the fully developed wake [m]."""
        return math.sqrt(2.0 * self.disc_area / math.pi)


class RotorInteractions:
    """Ground effect and downwash for the vehicles of one world (see the module docstring).

    Holds each vehicle's rotor geometry only; where the vehicles are and how hard their
    rotors push are given to every call.

    Args:
        ground_effect: scale each motor's thrust by its ground-effect ratio (needs a ground).
        downwash: add the wakes of the rotorcraft above to each vehicle's wind.
        min_height: the ground-effect clamp, in rotor radii.
    """

    def __init__(self, ground_effect: bool, downwash: bool, min_height: float = 0.5) -> None:
        self.ground_effect = ground_effect
        self.downwash = downwash
        self.min_height = min_height
        self.vehicles: list[_Rotorcraft | None] = []
        #: the rotorcraft with a disc area binned by position (:meth:`downwash_near`)
        self.wakes = PlanarGrid(1.0)
        self._jet_diameters: list[float] = []
        self._widest = 0.0

    def add_vehicle(
        self, positions: Sequence[Sequence[float]], radii: Sequence[float | None], max_thrust: Sequence[float]
    ) -> None:
        """Register the next vehicle: its motors' hub positions (centre-of-mass frame), prop
        radii (None: not a rotor) and full thrusts [N]; no motors: empty sequences."""
        if not len(positions):
            self.vehicles.append(None)
            self._jet_diameters.append(0.0)
            return
        radii = list(radii)
        area = sum(math.pi * r * r for r in radii if r)
        hubs = [tuple(float(v) for v in p) for p in positions]
        craft = _Rotorcraft(hubs, radii, [float(t) for t in max_thrust], area)  # type: ignore[arg-type]
        self.vehicles.append(craft)
        d = craft.jet_diameter if area > 0.0 else 0.0
        self._jet_diameters.append(d)
        if d > self._widest:
            self._widest = d
            # a cell as wide as the reach of the widest wake at its own height: a swarm at one
            # height then looks at the 3 x 3 cells about each vehicle
            self.wakes = PlanarGrid(max(WAKE_REACH * JET_SPREAD * JET_DECAY * d, 0.05))

    def set_max_thrust(self, index: int, max_thrust: Sequence[float]) -> None:
        """Vehicle ``index``'s motors' full thrusts [N] from now on (its motors took new constants:
        a drawn ``randomize.motor_kf``); its wake's strength follows them."""
        craft = self.vehicles[index]
        if craft is None:
            return
        if len(max_thrust) != len(craft.max_thrust):
            raise ValueError(f"vehicle {index} has {len(craft.max_thrust)} motors, got {len(max_thrust)} thrusts")
        craft.max_thrust = [float(t) for t in max_thrust]

    def ground_effect_ratios(self, index: int, position: Sequence[float], r: Sequence[float]) -> list[float] | None:
        """Per motor of vehicle ``index``, at ``position`` with body-to-ground matrix ``r``
        (row-major), the ground-effect thrust ratio at its hub height (1 for a motor without
        a radius); None when ground effect is off or the vehicle has no motors."""
        craft = self.vehicles[index]
        if craft is None or not self.ground_effect:
            return None
        _, _, _, _, _, _, r6, r7, r8 = r
        z = position[2]
        ratios = []
        for (px, py, pz), radius in zip(craft.positions, craft.radii):
            if radius:
                ratios.append(ground_effect_ratio(z + r6 * px + r7 * py + r8 * pz, radius, self.min_height))
            else:
                ratios.append(1.0)
        return ratios

    def thrust(self, index: int, throttle: Sequence[float]) -> float:
        """Total static thrust [N] of vehicle ``index``'s rotors at ``throttle`` (its motors' throttles)."""
        craft = self.vehicles[index]
        if craft is None:
            return 0.0
        return sum(t * x * abs(x) for t, x, radius in zip(craft.max_thrust, throttle, craft.radii) if radius)

    def downwash_at(
        self,
        index: int,
        position: Sequence[float],
        positions: Sequence[Sequence[float]],
        throttles: Sequence[Sequence[float] | None],
    ) -> float:
        """Vertical wind [m/s] (negative: down) at ``position`` of vehicle ``index`` from the
        others' wakes, the vehicles being at ``positions`` with motor ``throttles`` (one
        entry per vehicle, None without motors)."""
        x, y, z = position[0], position[1], position[2]
        w = 0.0
        for j, craft in enumerate(self.vehicles):
            if j == index or craft is None or craft.disc_area <= 0.0:
                continue
            cx, cy, cz = positions[j]
            if cz <= z:
                continue
            thrust = self.thrust(j, throttles[j])  # type: ignore[arg-type]
            w -= downwash_velocity(cz - z, math.hypot(x - cx, y - cy), thrust, craft.disc_area)
        return w

    def place(self, index: int, position: Sequence[float]) -> None:
        """Bin vehicle ``index`` at its latest read ``position`` in :attr:`wakes` (rotorcraft only)."""
        craft = self.vehicles[index]
        if craft is not None and craft.disc_area > 0.0:
            self.wakes.place(index, position)

    def sources(self, index: int, position: Sequence[float]) -> list[int]:
        """The vehicles whose wake can add a non-zero term at ``position`` of vehicle ``index``:
        binned in :attr:`wakes` within the reach of the highest one, above it, and within
        their own reach (``WAKE_REACH`` half-widths at that depth), in index order."""
        wakes = self.wakes
        x, y, z = position[0], position[1], position[2]
        if wakes.top <= z:
            return []
        reach = WAKE_REACH * JET_SPREAD
        found = wakes.near(x, y, reach * (wakes.top - z + JET_DECAY * self._widest))
        out = []
        placed, diameters = wakes.placed, self._jet_diameters
        for j in found:
            if j == index:
                continue
            cx, cy, cz = placed[j]
            if cz <= z:
                continue
            r = reach * (cz - z + JET_DECAY * diameters[j])
            dx, dy = x - cx, y - cy
            if dx * dx + dy * dy <= r * r:
                out.append(j)
        return out

    def downwash_near(
        self,
        index: int,
        position: Sequence[float],
        sources: Sequence[int],
        positions: Sequence[Sequence[float]],
        throttles: Sequence[Sequence[float]],
    ) -> float:
        """:meth:`downwash_at` over the vehicles ``sources`` only (from :meth:`sources`; their
        ``positions`` and ``throttles`` in the same order): the same number, bit for bit,
        when every other vehicle's term is exactly zero (see the module docstring)."""
        x, y, z = position[0], position[1], position[2]
        w = 0.0
        vehicles = self.vehicles
        for j, (cx, cy, cz), throttle in zip(sources, positions, throttles):
            craft = vehicles[j]
            thrust = self.thrust(j, throttle)
            w -= downwash_velocity(cz - z, math.hypot(x - cx, y - cy), thrust, craft.disc_area)  # type: ignore[union-attr]
        return w
