"""Body drag: quadratic per body axis plus linear rotational damping.

    F_i = -1/2 rho C_d,i A_i v_i |v_i|     (i = body x, y, z; v in the body frame)
    T_i = -c omega_i |omega_i|              (omega the body angular velocity)

The rotational term is quadratic like the translational one, as in the reference model
files that give c (which apply it as -c omega^2 with the sign lost; ours opposes the
rotation in both directions).

PyBullet's own velocity damping is switched off for vehicles (see
:mod:`pyflyt_engine.vehicle`), so this is the only drag they feel.  Unlike the reference
package, the damping applies whether or not the vehicle touches anything.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from pyflyt_engine.components import AirVelocity, Wrench
from pyflyt_engine.components.kinds import BuildContext, register
from pyflyt_engine.constants import AIR_DENSITY
from pyflyt_engine.spec import DragSpec


@dataclass(frozen=True)
class DragParams:
    """Attributes:
    coefficients: drag coefficient per body axis (x, y, z).
    areas: reference area per body axis [m^2].
    angular_damping: rotational drag coefficient c [N m s^2].
    """

    coefficients: tuple[float, float, float] = (0.0, 0.0, 0.0)
    areas: tuple[float, float, float] = (0.0, 0.0, 0.0)
    angular_damping: float = 0.0

    @property
    def factors(self) -> tuple[float, float, float]:
        """1/2 rho C_d A per axis [kg/m]."""
        return tuple(0.5 * AIR_DENSITY * c * a for c, a in zip(self.coefficients, self.areas))  # type: ignore[return-value]

    @property
    def active(self) -> bool:
        """Whether any drag term is non-zero."""
        return any(self.factors) or self.angular_damping > 0


class BodyDrag:
    """A vehicle's body drag as a load group: no state, a wrench from the air-relative velocity."""

    needs_air = True
    commanded = False

    def __init__(self, params: DragParams) -> None:
        self.set_params(params)

    def set_params(self, params: DragParams) -> None:
        """Use new coefficients (e.g. sampled by domain randomisation)."""
        self.params = params
        self._factors = params.factors
        self._damping = params.angular_damping

    def route(self, channels: Sequence[float], outputs: Sequence[float] | None = None) -> None:
        """Nothing commands drag."""

    def step(self, air: AirVelocity, thrust_ratio: Sequence[float] | None = None) -> Wrench:
        """The drag force [N] and damping torque [N m], body frame, at the body's velocity
        through the air ``air`` (body frame, [m/s] and [rad/s]): the module docstring's law."""
        (vx, vy, vz), (wx, wy, wz) = air
        kx, ky, kz = self._factors  # 1/2 rho C_d A per axis
        c = self._damping
        return (-kx * vx * abs(vx), -ky * vy * abs(vy), -kz * vz * abs(vz),
                -c * wx * abs(wx), -c * wy * abs(wy), -c * wz * abs(wz))  # fmt: skip

    def reset(self) -> None:
        """Nothing to reset: drag has no state."""

    def reseed(self) -> None:
        """No noise: nothing to do."""

    def aux(self) -> list[float]:
        """No read-outs."""
        return []


def drag_params(spec: DragSpec) -> DragParams:
    """The :class:`DragParams` of an airframe's ``drag`` section."""
    return DragParams(spec.coefficients, spec.areas, spec.angular_damping)


def build_drag(ctx: BuildContext) -> BodyDrag | None:
    """The body drag's group: None when every term is zero, or with the vehicle's drag switched off."""
    params = drag_params(ctx.spec.drag)
    return BodyDrag(params) if ctx.drag and params.active else None


# summed after the motors, surfaces and boosters
register("drag", section="drag", spec=DragSpec, build=build_drag, order=50, step_order=50)
