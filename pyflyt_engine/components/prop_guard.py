"""Propeller guards: the drag of a ring around a rotor, opposing the air across its disc.

A guard is a ring (a duct's band) of radius ``R`` and height ``H`` around motor ``i``'s
rotor, centred on its hub ``p_i`` with its axis along the motor's thrust axis ``a_i``
(both body frame, from the centre of mass).  The air crossing the ring edge-on meets its
projected area ``2 R H``; the air along the axis meets only the band's thin edge, which is
left out.  With the hub's velocity through the air ``h = v + omega x p_i`` (body frame) and
its part across the disc ``h_perp = h - (h . a_i) a_i``::

    F_i = -1/2 rho C_d (2 R H) |h_perp| h_perp,      T_i = p_i x F_i

summed over the guards (a quadratic drag law on a bluff body's projected area, as the body
drag of :mod:`pyflyt_engine.components.drag`).  The default ``C_d = 1.2`` is that of a flat
plate normal to the flow at aspect ratios of a few to ten (Hoerner, *Fluid-Dynamic Drag*,
1965, ch. 3, flat plates): a first estimate for the ring's front and back arcs together, the
back one partly in the front one's wake; a measured value replaces it.

The guards follow their motors' nominal thrust axes (a gimbal turning a motor does not
turn its guard).  They draw no noise, take no command and add nothing to the auxiliary
state; the vehicle's drag switch (``World.add_vehicle(drag=False)``) leaves them out with
the body drag.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from pyflyt_engine.components import AirVelocity, Wrench
from pyflyt_engine.components.kinds import BuildContext, register
from pyflyt_engine.constants import AIR_DENSITY
from pyflyt_engine.spec import PropGuardSpec

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class PropGuardParams:
    """Attributes:
    positions: per guard, its centre (the hub of its motor), body frame, from the centre of mass [m].
    axes: per guard, its axis (its motor's nominal thrust axis), a unit vector in the body frame.
    factor: 1/2 rho C_d (2 R H), the same for every guard [kg/m].
    """

    positions: tuple[Vec3, ...]
    axes: tuple[Vec3, ...]
    factor: float


def guard_factor(radius: float, height: float, drag_coefficient: float) -> float:
    """``1/2 rho C_d (2 R H)`` [kg/m]: the drag per squared speed across one guard's disc."""
    return 0.5 * AIR_DENSITY * drag_coefficient * 2.0 * radius * height


def guard_wrench(factor: float, position: Vec3, axis: Vec3, air: AirVelocity) -> Wrench:
    """One guard's wrench about the centre of mass, body frame [N, N m], at the body's
    velocity through the air ``air`` (the module docstring's law)."""
    (u, v, w), (p, q, r) = air
    px, py, pz = position
    ax, ay, az = axis
    hx, hy, hz = u + q * pz - r * py, v + r * px - p * pz, w + p * py - q * px  # v + omega x p
    along = hx * ax + hy * ay + hz * az
    cx, cy, cz = hx - along * ax, hy - along * ay, hz - along * az  # across the disc
    k = -factor * (cx * cx + cy * cy + cz * cz) ** 0.5
    fx, fy, fz = k * cx, k * cy, k * cz
    return fx, fy, fz, py * fz - pz * fy, pz * fx - px * fz, px * fy - py * fx


class PropGuards:
    """The propeller guards of one vehicle as a group: no state, a wrench from the air."""

    needs_air = True
    commanded = False

    def __init__(self, params: PropGuardParams) -> None:
        self.params = params
        self._guards = tuple(zip(params.positions, params.axes))

    def route(self, channels: Sequence[float], outputs: Sequence[float] | None = None) -> None:
        """Nothing commands a guard."""

    def step(self, air: AirVelocity, thrust_ratio: Sequence[float] | None = None) -> Wrench:
        """The guards' summed wrench (:func:`guard_wrench` per guard, in motor order)."""
        k = self.params.factor
        fx = fy = fz = tx = ty = tz = 0.0
        for position, axis in self._guards:
            gx, gy, gz, hx, hy, hz = guard_wrench(k, position, axis, air)
            fx, fy, fz, tx, ty, tz = fx + gx, fy + gy, fz + gz, tx + hx, ty + hy, tz + hz
        return fx, fy, fz, tx, ty, tz

    def reset(self) -> None:
        """No state: nothing to reset."""

    def reseed(self) -> None:
        """No noise: nothing to do."""

    def aux(self) -> list[float]:
        """No read-outs."""
        return []


def build_prop_guards(ctx: BuildContext) -> PropGuards | None:
    """The guards of an airframe's ``prop_guards`` (None without, or with the drag switched
    off), on its motors' hubs and nominal thrust axes."""
    spec: PropGuardSpec | None = ctx.spec.prop_guards
    motors = ctx.parts.motors
    if spec is None or motors is None or not ctx.drag:
        return None
    guarded = spec.motors if spec.motors is not None else range(motors.count)
    positions = motors.positions.tolist()  # already from the centre of mass
    axes = motors.thrust_axes.tolist()
    return PropGuards(
        PropGuardParams(
            positions=tuple(tuple(positions[i]) for i in guarded),
            axes=tuple(tuple(axes[i]) for i in guarded),
            factor=guard_factor(spec.radius, spec.height, spec.drag_coefficient),
        )
    )


# summed last, after the body drag
register("prop_guards", section="prop_guards", spec=PropGuardSpec, build=build_prop_guards, order=55, step_order=55)
