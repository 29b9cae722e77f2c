"""Rotor aerodynamic interactions: ground effect and downwash between vehicles.

**Ground effect** (Cheeseman & Bennett, "The effect of the ground on a helicopter rotor
in forward flight", ARC R&M 3021, 1955; the hover form from the method of images)::

    T_IGE / T_OGE = 1 / (1 - (R / (4 z))^2)

for a rotor of radius ``R`` whose hub is ``z`` above the ground.  The ratio diverges at
``z = R / 4`` while measured ratios stay finite close to the ground (e.g.
Sanchez-Cuevas et al., "Characterization of the aerodynamic ground effect and its influence
in multirotor control", Int. J. Aerospace Eng. 2017), so the height is clamped to
``z >= min_height * R`` (default 0.5: at most 4/3).  Each motor's thrust is scaled by
the ratio at its own hub height (:attr:`pyflyt_engine.components.motor.Motors.thrust_scale`);
the reaction torque is left alone.

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
of the other vehicles are their latest reads (at most one physics step old).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from pyflyt_engine.constants import AIR_DENSITY

JET_DECAY = 5.8  # B, round jet centreline decay constant (Pope 2000, table 5.1, Hussein et al. 1994)
JET_SPREAD = 0.094  # S, round jet spreading rate (Pope 2000, table 5.1, Hussein et al. 1994)
_LN2 = math.log(2.0)


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
    motors: object  # pyflyt_engine.components.motor.Motors
    positions: list[tuple[float, float, float]]
    radii: list[float | None]
    max_thrust: list[float]
    disc_area: float
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    heights: list[float] = field(default_factory=list)


class RotorInteractions:
    """Ground effect and downwash for the vehicles of one world (see the module docstring).

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

    def add_vehicle(
        self, motors: object | None, positions: Sequence[Sequence[float]], radii: Sequence[float | None]
    ) -> Callable:
        """Register a vehicle (its motor group, hub positions in the CoM frame and radii);
        returns its hook ``(position, rotation) -> None`` for :attr:`Vehicle.rotor_effects`."""
        index = len(self.vehicles)
        if motors is None:
            self.vehicles.append(None)
        else:
            radii = list(radii)
            area = sum(math.pi * r * r for r in radii if r)
            self.vehicles.append(
                _Rotorcraft(
                    motors,
                    [tuple(float(v) for v in p) for p in positions],  # type: ignore[misc]
                    radii,
                    motors.params.max_thrust.tolist(),  # type: ignore[attr-defined]
                    area,
                )
            )

        def hook(position: Sequence[float], r: Sequence[float]) -> None:
            self.update(index, position, r)

        return hook

    def update(self, index: int, position: Sequence[float], r: Sequence[float]) -> None:
        """Vehicle ``index`` is at ``position`` with body-to-ground matrix ``r`` (row-major)."""
        craft = self.vehicles[index]
        if craft is None:
            return
        craft.position = (position[0], position[1], position[2])
        if not self.ground_effect:
            return
        _, _, _, _, _, _, r6, r7, r8 = r
        z = position[2]
        scale = []
        for (px, py, pz), radius in zip(craft.positions, craft.radii):
            if radius:
                scale.append(ground_effect_ratio(z + r6 * px + r7 * py + r8 * pz, radius, self.min_height))
            else:
                scale.append(1.0)
        craft.motors.thrust_scale = scale  # type: ignore[attr-defined]

    def thrust(self, index: int) -> float:
        """Total static thrust [N] of vehicle ``index``'s rotors at their current throttles."""
        craft = self.vehicles[index]
        if craft is None:
            return 0.0
        throttle = craft.motors.throttle  # type: ignore[attr-defined]
        return sum(t * x * abs(x) for t, x, radius in zip(craft.max_thrust, throttle, craft.radii) if radius)

    def downwash_at(self, index: int, position: Sequence[float]) -> float:
        """Vertical wind [m/s] (negative: down) at ``position`` of vehicle ``index`` from the others' wakes."""
        x, y, z = position[0], position[1], position[2]
        w = 0.0
        for j, craft in enumerate(self.vehicles):
            if j == index or craft is None or craft.disc_area <= 0.0:
                continue
            cx, cy, cz = craft.position
            if cz <= z:
                continue
            w -= downwash_velocity(cz - z, math.hypot(x - cx, y - cy), self.thrust(j), craft.disc_area)
        return w

    def wind_probe(self, index: int, probe: Callable | None) -> Callable:
        """``probe`` (the wind field's, or None) plus the downwash at vehicle ``index``."""

        def with_downwash(position: Sequence[float]) -> tuple[float, ...]:
            w = self.downwash_at(index, position)
            if probe is None:
                return (0.0, 0.0, w, 0.0, 0.0, 0.0)
            wx, wy, wz, p, q, r = probe(position)
            return (wx, wy, wz + w, p, q, r)

        return with_downwash
