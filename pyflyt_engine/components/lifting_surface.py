"""Flapped lifting surface: Khan & Nahon performance profile, flap lag and body loads.

Model (Khan & Nahon, "Real-time modeling of agile fixed-wing UAV aerodynamics",
ICUAS 2015; equations as written out in ``REFERENCE.md``, "Lifting surface")::

    AR    = b / c                                     aspect ratio
    C_La  = C_La,2D AR / (AR + 2 (AR + 4) / (AR + 2))  finite-wing lift slope [1/rad]
    th_f  = arccos(2 c_f/c - 1);  tau_f = 1 - (th_f - sin th_f) / pi    flap effectiveness
    dC_L  = C_La tau_f eta delta;  dC_Lmax = (c_f/c) dC_L
    C_Lmax+- = C_La (a_s+-,base - a_0,base) + dC_Lmax
    a_0   = a_0,base - dC_L / C_La;  a_s+- = a_0 + C_Lmax+- / C_La

    attached (a_s- < a < a_s+):
        C_L = C_La (a - a_0);  a_i = C_L / (pi AR);  a_eff = a - a_0 - a_i
        C_T = C_D0 cos a_eff;  C_N = (C_L + C_T sin a_eff) / cos a_eff
        C_D = C_N sin a_eff + C_T cos a_eff
        C_M = -C_N (0.25 - 0.175 (1 - 2 a_eff / pi))
    stalled (otherwise, |a| <= 90 deg):
        a_i falls linearly from C_La (a_s - a_0) / (pi AR) at a_s to 0 at +-90 deg
        a_eff = a - a_0 - a_i;  C_D,90 = -0.0426 delta^2 + 0.21 delta + 1.98
        C_N = C_D,90 sin a_eff (1 / (0.56 + 0.44 |sin a_eff|) - 0.41 (1 - exp(-17 / AR)))
        C_T = 0.5 C_D0 cos a_eff
        C_L = C_N cos a_eff - C_T sin a_eff;  C_D = C_N sin a_eff + C_T cos a_eff
        C_M = -C_N (0.25 - 0.175 (1 - 2 |a_eff| / pi))

The equations are applied exactly as written, so the profile is **discontinuous at the
two stall angles**: that is the model's abrupt stall (for the fixed-wing main wing C_L
falls from 1.19 to 0.46 at +14 deg).  Everywhere else the curves are continuous.

Reverse flow (|alpha| > 90 deg, air arriving from the trailing edge), which Khan & Nahon
do not cover: the surface is seen as the same plate turned 180 deg about its span axis,
so the profile is evaluated at ``alpha -+ 180 deg`` (lift and drag keep their directions,
see :func:`surface_wrench`), and the pitching moment is moved from that plate's quarter
chord, which lies half a chord behind the real aerodynamic centre, back to the real one:
``C_M = C_N (0.5 - arm)`` instead of ``-C_N arm`` (``arm`` the centre-of-pressure lever
of the formulas above).  C_L, C_D and C_M are then continuous at +-90 deg and at
+-180 deg and bounded everywhere.  Camber and flap act with their forward-flow sign in
the turned view, which is a simplification: reverse flow is brief (tail slides, spins).

Frames and signs: body frame X forward, Y left, Z up.  Each surface has a chord axis
``c`` (trailing edge -> leading edge), a normal axis ``n`` (positive-lift side) and the
span axis ``s = c x n``, so ``(c, n, s)`` is right-handed and a positive rotation about
``s`` turns the leading edge toward ``n``: positive C_M is nose-up.  For a wing with
``c = +X``, ``n = +Z`` the span axis is ``-Y`` (toward the right wing tip).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import NamedTuple

import numpy as np

from pyflyt_engine import exact
from pyflyt_engine.components import AirVelocity, Wrench
from pyflyt_engine.components.kinds import BuildContext, register
from pyflyt_engine.components.lag import lag_coefficient
from pyflyt_engine.components.routing import MixRow, clamp, mix_rows, mixed
from pyflyt_engine.constants import AIR_DENSITY
from pyflyt_engine.spec import SurfaceSpec


# Dimensionless constants of the Khan & Nahon profile (ICUAS 2015; REFERENCE.md).
_CP_BASE = 0.25  # centre-of-pressure lever at the quarter chord, fraction of chord
_CP_SHIFT = 0.175  # centre-of-pressure travel between alpha_eff = 0 and 90 deg, fraction of chord
_CD90_QUAD = -0.0426  # C_D,90 coefficient of delta^2 [1/rad^2]
_CD90_LIN = 0.21  # C_D,90 coefficient of delta [1/rad]
_CD90_ZERO = 1.98  # flat-plate normal-force coefficient at 90 deg, no flap
_CN_BASE = 0.56  # post-stall normal-force shape constant
_CN_SIN = 0.44  # post-stall normal-force shape constant
_CN_AR_GAIN = 0.41  # finite-aspect-ratio reduction of the post-stall normal force
_CN_AR_SCALE = 17.0  # aspect-ratio scale of that reduction
_CT_STALL = 0.5  # post-stall tangential force as a fraction of C_D0

_TWO_PI = 2.0 * math.pi
_HALF_PI = 0.5 * math.pi
_TWO_OVER_PI = 2.0 / math.pi
_AXIS_TOL = 1e-6  # tolerance on axis norms and on chord . normal


class SurfaceConstants(NamedTuple):
    """Plain-float quantities of a :class:`LiftingSurfaceParams` that do not depend on the
    flow, derived once (``params.constants``) for the per-physics-step path.  Every field
    is computed with the same expression, in the same order, as where the equations use
    it, so the fast path is bit-for-bit the model of the module docstring.  The hot
    functions unpack it by position (slices): keep the field order."""

    px: float  #: aerodynamic centre, body frame [m]
    py: float
    pz: float
    cx: float  #: chord axis c
    cy: float
    cz: float
    nx: float  #: normal axis n
    ny: float
    nz: float
    sx: float  #: span axis s = c x n
    sy: float
    sz: float
    area: float  #: S = c b [m^2]
    chord: float  #: c [m]
    aspect_ratio: float  #: AR
    cl_alpha: float  #: C_La [1/rad]
    pi_ar: float  #: pi AR
    delta_cl_per_rad: float  #: C_La tau_f eta: dC_L per radian of flap [1/rad]
    flap_to_chord: float  #: c_f / c
    cl_max_pos_base: float  #: C_La (a_s+,base - a_0,base)
    cl_max_neg_base: float  #: C_La (a_s-,base - a_0,base)
    alpha_0_base: float  #: [rad]
    cd_0: float  #: C_D0
    cn_ar: float  #: 0.41 (1 - exp(-17 / AR)), the post-stall aspect-ratio reduction
    max_deflection: float  #: [rad]


@dataclass(frozen=True, eq=False)
class LiftingSurfaceParams:
    """One flat lifting surface with an optional trailing-edge flap.

    Equality is identity (``eq=False``): fields hold numpy arrays, whose element-wise
    ``==`` has no single truth value.  Arrays are stored read-only as float64.

    Attributes:
        position: aerodynamic centre (quarter chord) in the body frame, shape (3,) [m].
        chord_axis: unit vector in the body frame along the chord, from trailing edge to
            leading edge (forward for a wing), shape (3,).
        normal_axis: unit vector in the body frame perpendicular to ``chord_axis``,
            pointing to the positive-lift side (+Z for a wing, +Y or -Y for a vertical
            tail), shape (3,).
        chord: mean chord c [m], > 0.
        span: span b [m], > 0.
        flap_to_chord: flap chord over surface chord c_f / c, in [0, 1] (0 = no flap,
            1 = all-moving surface).
        alpha_0_base: zero-lift angle of attack with the flap neutral [rad].
        stall_pos_base: positive stall angle with the flap neutral [rad], in
            (alpha_0_base, 90 deg).
        stall_neg_base: negative stall angle with the flap neutral [rad], in
            (-90 deg, alpha_0_base).
        cd_0: zero-lift drag coefficient C_D0, >= 0.
        cl_alpha_2d: section (2-D) lift slope C_La,2D [1/rad], > 0 (thin aerofoil: 2 pi).
        eta: viscosity correction of the flap effectiveness (McCormick 1994, p. 112),
            dimensionless, >= 0.
        max_deflection: flap deflection limit delta_max [rad], >= 0; positive
            deflection is trailing edge toward -normal_axis (more lift).
        tau: flap actuator time constant [s], >= 0 (0 = no lag).
    """

    position: np.ndarray
    chord_axis: np.ndarray
    normal_axis: np.ndarray
    chord: float
    span: float
    flap_to_chord: float
    alpha_0_base: float
    stall_pos_base: float
    stall_neg_base: float
    cd_0: float
    cl_alpha_2d: float
    eta: float
    max_deflection: float
    tau: float

    def __post_init__(self) -> None:
        for name in ("position", "chord_axis", "normal_axis"):
            value = np.array(getattr(self, name), dtype=np.float64)
            if value.shape != (3,) or not np.all(np.isfinite(value)):
                raise ValueError(f"{name} must be 3 finite numbers in the body frame, got {getattr(self, name)!r}")
            value.setflags(write=False)
            object.__setattr__(self, name, value)
        scalars = (
            "chord", "span", "flap_to_chord", "alpha_0_base", "stall_pos_base", "stall_neg_base",
            "cd_0", "cl_alpha_2d", "eta", "max_deflection", "tau",
        )  # fmt: skip
        for name in scalars:
            number = float(getattr(self, name))
            if not math.isfinite(number):
                raise ValueError(f"{name} must be finite, got {number}")
            object.__setattr__(self, name, number)

        for name in ("chord", "span"):
            if getattr(self, name) <= 0.0:
                raise ValueError(
                    f"{name} must be > 0 m (got {getattr(self, name)}): the surface area chord * span "
                    "must be positive; give the real chord and span of the surface"
                )
        for name in ("chord_axis", "normal_axis"):
            norm = exact.norm(getattr(self, name))
            if abs(norm - 1.0) > _AXIS_TOL:
                raise ValueError(
                    f"{name} must be a unit vector (norm 1 +- {_AXIS_TOL}), got norm {norm:.6g}; "
                    f"normalise it, e.g. v / np.linalg.norm(v)"
                )
        dot = exact.dot(self.chord_axis, self.normal_axis)
        if abs(dot) > _AXIS_TOL:
            kind = "parallel" if abs(abs(dot) - 1.0) <= _AXIS_TOL else "not perpendicular"
            raise ValueError(
                f"chord_axis and normal_axis must be perpendicular (|dot| <= {_AXIS_TOL}), got dot = {dot:.6g} "
                f"({kind}); choose normal_axis at right angles to chord_axis"
            )
        if not self.stall_neg_base < self.alpha_0_base < self.stall_pos_base:
            raise ValueError(
                "stall angles must bracket the zero-lift angle, stall_neg_base < alpha_0_base < stall_pos_base, "
                f"got stall_neg_base={self.stall_neg_base}, alpha_0_base={self.alpha_0_base}, "
                f"stall_pos_base={self.stall_pos_base} [rad]; check their signs and order"
            )
        if not 0.0 <= self.flap_to_chord <= 1.0:
            raise ValueError(f"flap_to_chord must be in [0, 1] (flap chord / surface chord), got {self.flap_to_chord}")
        for name in ("tau", "max_deflection", "cd_0", "eta"):
            if getattr(self, name) < 0.0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}; use a non-negative value")
        if self.cl_alpha_2d <= 0.0:
            raise ValueError(
                f"cl_alpha_2d must be > 0 [1/rad], got {self.cl_alpha_2d}; thin-aerofoil theory gives 2 pi"
            )
        for delta in (-self.max_deflection, self.max_deflection):
            _, stall_pos, stall_neg = flap_shifted_angles(self, delta)
            if not -_HALF_PI < stall_neg < stall_pos < _HALF_PI:
                raise ValueError(
                    f"stall angles must stay inside (-90 deg, 90 deg) at every flap deflection; at "
                    f"deflection {delta:.4g} rad they are stall_neg={stall_neg:.4g}, stall_pos={stall_pos:.4g} rad; "
                    "reduce the base stall angles or max_deflection"
                )

    @property
    def area(self) -> float:
        """Planform area S = chord * span [m^2]."""
        return self.chord * self.span

    @property
    def aspect_ratio(self) -> float:
        """Aspect ratio AR = span / chord (rectangular planform)."""
        return self.span / self.chord

    @property
    def cl_alpha(self) -> float:
        """Finite-wing lift slope C_La = C_La,2D AR / (AR + 2 (AR + 4) / (AR + 2)) [1/rad]."""
        ar = self.aspect_ratio
        return self.cl_alpha_2d * ar / (ar + 2.0 * (ar + 4.0) / (ar + 2.0))

    @property
    def flap_effectiveness(self) -> float:
        """tau_f = 1 - (theta_f - sin theta_f) / pi with theta_f = arccos(2 c_f/c - 1)."""
        theta_f = math.acos(2.0 * self.flap_to_chord - 1.0)
        return 1.0 - (theta_f - math.sin(theta_f)) / math.pi

    @property
    def span_axis(self) -> np.ndarray:
        """s = chord_axis x normal_axis, shape (3,): the axis of positive (nose-up) C_M."""
        return np.cross(self.chord_axis, self.normal_axis)

    @cached_property
    def constants(self) -> SurfaceConstants:
        """The flow-independent quantities as plain floats (computed once, then cached)."""
        px, py, pz = self.position.tolist()
        cx, cy, cz = self.chord_axis.tolist()
        nx, ny, nz = self.normal_axis.tolist()
        ar = self.aspect_ratio
        cl_alpha = self.cl_alpha
        return SurfaceConstants(
            px, py, pz, cx, cy, cz, nx, ny, nz,
            cy * nz - cz * ny, cz * nx - cx * nz, cx * ny - cy * nx,
            self.area, self.chord, ar, cl_alpha, math.pi * ar,
            cl_alpha * self.flap_effectiveness * self.eta,
            self.flap_to_chord,
            cl_alpha * (self.stall_pos_base - self.alpha_0_base),
            cl_alpha * (self.stall_neg_base - self.alpha_0_base),
            self.alpha_0_base,
            self.cd_0,
            _CN_AR_GAIN * (1.0 - math.exp(-_CN_AR_SCALE / ar)),
            self.max_deflection,
        )  # fmt: skip


def flap_shifted_angles(params: LiftingSurfaceParams, deflection: float) -> tuple[float, float, float]:
    """Zero-lift and stall angles with the flap at ``deflection`` [rad].

    Returns:
        ``(alpha_0, stall_pos, stall_neg)`` [rad].  Positive deflection lowers all three
        (alpha_0 by tau_f eta delta, the stall angles by (1 - c_f/c) tau_f eta delta).
    """
    return _shifted_angles(params.constants, deflection)


def _shifted_angles(k: SurfaceConstants, deflection: float) -> tuple[float, float, float]:
    cl_alpha, _, delta_cl_per_rad, flap_to_chord, cl_max_pos_base, cl_max_neg_base, alpha_0_base = k[15:22]
    delta_cl = delta_cl_per_rad * deflection
    delta_cl_max = flap_to_chord * delta_cl
    cl_max_pos = cl_max_pos_base + delta_cl_max
    cl_max_neg = cl_max_neg_base + delta_cl_max
    alpha_0 = alpha_0_base - delta_cl / cl_alpha
    return alpha_0, alpha_0 + cl_max_pos / cl_alpha, alpha_0 + cl_max_neg / cl_alpha


def _coefficients(k: SurfaceConstants, alpha: float, deflection: float) -> tuple[float, float, float]:
    cl_alpha, pi_ar, _, _, _, _, _, cd_0, cn_ar = k[15:24]
    alpha_0, stall_pos, stall_neg = _shifted_angles(k, deflection)
    alpha = math.remainder(alpha, _TWO_PI)  # wrap into [-pi, pi]
    reverse = abs(alpha) > _HALF_PI
    if reverse:
        alpha = alpha - math.pi if alpha > 0.0 else alpha + math.pi

    if stall_neg < alpha < stall_pos:
        cl = cl_alpha * (alpha - alpha_0)
        alpha_eff = alpha - alpha_0 - cl / pi_ar
        cos_e, sin_e = math.cos(alpha_eff), math.sin(alpha_eff)
        ct = cd_0 * cos_e
        cn = (cl + ct * sin_e) / cos_e
        lever = _CP_BASE - _CP_SHIFT * (1.0 - _TWO_OVER_PI * alpha_eff)
    else:
        if alpha >= stall_pos:
            alpha_i = cl_alpha * (stall_pos - alpha_0) / pi_ar * (_HALF_PI - alpha) / (_HALF_PI - stall_pos)
        else:
            alpha_i = cl_alpha * (stall_neg - alpha_0) / pi_ar * (_HALF_PI + alpha) / (_HALF_PI + stall_neg)
        alpha_eff = alpha - alpha_0 - alpha_i
        cos_e, sin_e = math.cos(alpha_eff), math.sin(alpha_eff)
        cd_90 = _CD90_QUAD * deflection * deflection + _CD90_LIN * deflection + _CD90_ZERO
        shape = 1.0 / (_CN_BASE + _CN_SIN * abs(sin_e)) - cn_ar
        cn = cd_90 * sin_e * shape
        ct = _CT_STALL * cd_0 * cos_e
        cl = cn * cos_e - ct * sin_e
        lever = _CP_BASE - _CP_SHIFT * (1.0 - _TWO_OVER_PI * abs(alpha_eff))
    cd = cn * sin_e + ct * cos_e
    cm = cn * (0.5 - lever) if reverse else -cn * lever
    return cl, cd, cm


def surface_coefficients(
    params: LiftingSurfaceParams, alpha: float | np.ndarray, deflection: float = 0.0
) -> tuple[float | np.ndarray, float | np.ndarray, float | np.ndarray]:
    """Lift, drag and pitching-moment coefficients of the surface (module docstring).

    Args:
        params: the surface.
        alpha: angle of attack [rad], float or array of any shape; taken modulo 2 pi.
            Beyond +-90 deg the reverse-flow rule of the module docstring applies.
        deflection: actual flap deflection delta [rad] (not clipped here).

    Returns:
        ``(C_L, C_D, C_M)``, floats for a float ``alpha``, else arrays of its shape.
        C_L is positive toward ``normal_axis`` in forward flow; C_M is about the
        aerodynamic centre, positive nose-up (about ``span_axis``).
    """
    k = params.constants
    if np.ndim(alpha) == 0:
        return _coefficients(k, float(alpha), float(deflection))
    alphas = np.asarray(alpha, dtype=np.float64)
    values = [_coefficients(k, a, float(deflection)) for a in alphas.ravel().tolist()]
    cl, cd, cm = (np.array(column, dtype=np.float64).reshape(alphas.shape) for column in zip(*values))
    return cl, cd, cm


def coefficient_curves(
    params: LiftingSurfaceParams, alphas: np.ndarray | None = None, deflection: float = 0.0
) -> dict[str, np.ndarray]:
    """C_L, C_D, C_M over a grid of angles of attack, for plotting or inspection.

    Args:
        params: the surface.
        alphas: angles of attack [rad]; default 1001 points from -pi to pi.
        deflection: flap deflection [rad].

    Returns:
        ``{"alpha": [rad], "cl": ..., "cd": ..., "cm": ...}``, arrays of one shape.
    """
    alpha = np.linspace(-np.pi, np.pi, 1001) if alphas is None else np.asarray(alphas, dtype=np.float64)
    cl, cd, cm = surface_coefficients(params, np.atleast_1d(alpha), deflection)
    shape = np.shape(alpha)
    return {"alpha": alpha, "cl": np.reshape(cl, shape), "cd": np.reshape(cd, shape), "cm": np.reshape(cm, shape)}


def plot_coefficient_curves(
    params: LiftingSurfaceParams,
    path: str | Path,
    deflections: tuple[float, ...] | None = None,
) -> Path:
    """Write a PNG of C_L, C_D and C_M against alpha (-180..180 deg) for some deflections.

    Args:
        params: the surface.
        path: output file (PNG).
        deflections: flap deflections [rad]; default (-max, 0, +max) deflection.

    Returns:
        The path written.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    if deflections is None:
        deflections = tuple(dict.fromkeys((-params.max_deflection, 0.0, params.max_deflection)))
    fig = Figure(figsize=(7.0, 8.0))
    FigureCanvasAgg(fig)
    axes = fig.subplots(3, 1, sharex=True)
    for delta in deflections:
        curves = coefficient_curves(params, deflection=delta)
        alpha_deg = np.degrees(curves["alpha"])
        for ax, key in zip(axes, ("cl", "cd", "cm")):
            ax.plot(alpha_deg, curves[key], label=f"delta = {math.degrees(delta):.1f} deg")
    for ax, label in zip(axes, ("C_L", "C_D", "C_M (nose-up +)")):
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
        ax.axhline(0.0, color="k", linewidth=0.5)
    axes[0].legend(loc="best", fontsize="small")
    axes[-1].set_xlabel("angle of attack alpha [deg]")
    axes[-1].set_xticks(np.arange(-180, 181, 30))
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=100)
    return path


def flap_deflection(deflection: float, command: float, lag: float, max_deflection: float) -> float:
    """The flap one step on, toward ``command * max_deflection`` with a first-order lag.

    Args:
        deflection: current flap deflection delta [rad].
        command: normalised command nu, clipped to [-1, 1].
        lag: ``lag_coefficient(dt, tau)`` for the step length dt and the flap's tau.
        max_deflection: the flap's limit delta_max [rad].

    Returns:
        The new deflection [rad], ``delta + k (clip(nu) delta_max - delta)``.
    """
    clipped = -1.0 if command < -1.0 else 1.0 if command > 1.0 else command  # min(max(nu, -1), 1), NaN kept
    return deflection + lag * (clipped * max_deflection - deflection)


def surface_wrench(
    k: SurfaceConstants,
    deflection: float,
    vx: float,
    vy: float,
    vz: float,
    wx: float,
    wy: float,
    wz: float,
    air_density: float = AIR_DENSITY,
) -> tuple[float, float, float, float, float, float]:
    """Aerodynamic force and torque of one surface on the body, in the body frame.

    The surface moves through the air at ``v = velocity + omega x position`` (body frame,
    ``velocity`` the body's velocity through the air: the wind already subtracted).  The
    model is 2-D: only the part of ``v`` in the chord-normal plane counts (``u = v . c``,
    ``w = v . n``); the spanwise part is ignored for alpha and for the dynamic pressure,
    so pure spanwise flow gives no load.  Then

        alpha = atan2(-w, u),   V^2 = u^2 + w^2,   Q = rho V^2 / 2
        lift  = C_L Q S along s x v_hat (= n at alpha = 0, tilted forward for alpha > 0;
                toward n whenever |alpha| < 90 deg),
        drag  = C_D Q S along -v_hat,
        M     = C_M Q S c about the span axis s (positive nose-up).

    Args:
        k: the surface's :attr:`LiftingSurfaceParams.constants`.
        deflection: actual flap deflection [rad].
        vx, vy, vz: the body's velocity through the air, body frame [m/s].
        wx, wy, wz: its angular velocity through the air, body frame [rad/s].
        air_density: rho [kg/m^3].

    Returns:
        ``(fx, fy, fz, tx, ty, tz)``: force [N] and torque about the body origin [N m]
        (``position x force + M s``), body frame; zeros at zero airspeed.
    """
    px, py, pz, cx, cy, cz, nx, ny, nz, sx, sy, sz, area, chord = k[:14]
    vx += wy * pz - wz * py
    vy += wz * px - wx * pz
    vz += wx * py - wy * px
    u = vx * cx + vy * cy + vz * cz
    w = vx * nx + vy * ny + vz * nz
    speed_sq = u * u + w * w
    if speed_sq == 0.0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0

    cl, cd, cm = _coefficients(k, math.atan2(-w, u), deflection)
    q_area = 0.5 * air_density * speed_sq * area
    # Lift along (-w c + u n) / V, drag along -(u c + w n) / V: components along c and n.
    scale = q_area / math.sqrt(speed_sq)
    f_c = -scale * (cl * w + cd * u)
    f_n = scale * (cl * u - cd * w)
    fx = f_c * cx + f_n * nx
    fy = f_c * cy + f_n * ny
    fz = f_c * cz + f_n * nz
    moment = cm * q_area * chord
    return (
        fx,
        fy,
        fz,
        py * fz - pz * fy + moment * sx,
        pz * fx - px * fz + moment * sy,
        px * fy - py * fx + moment * sz,
    )


class Surfaces:
    """The lifting surfaces of one vehicle as an actuator group: flap deflections, commands, loads.

    Args:
        params: the surfaces, in the centre-of-mass body frame.
        physics_dt: physics step [s].
        mix: per surface, the channels that drive its flap
            (:mod:`~pyflyt_engine.components.routing`; default none).

    Attributes:
        deflection: per surface, the flap deflection [rad] (the state).
        command: per surface, the normalised flap command in [-1, 1] (set at the control rate).
    """

    #: the loads depend on the air-relative velocity
    needs_air = True
    commanded = True

    def __init__(
        self, params: Sequence[LiftingSurfaceParams], physics_dt: float, mix: Sequence[MixRow] | None = None
    ) -> None:
        self.params = tuple(params)
        self._mix = list(mix) if mix is not None else [()] * len(self.params)
        #: per surface, its constants, its flap's lag coefficient for one physics step and its flap limit
        self._surfaces = [
            (surface.constants, float(lag_coefficient(physics_dt, surface.tau)), surface.constants.max_deflection)
            for surface in self.params
        ]
        self._scale = [surface.max_deflection or 1.0 for surface in self.params]
        self.deflection = [0.0] * len(self.params)
        self.command = [0.0] * len(self.params)

    def route(self, channels: Sequence[float], outputs: Sequence[float] | None = None) -> None:
        """Flap commands from the channels (each surface's mix), limited to [-1, 1]; the
        mixer flies no flap (``outputs`` unused)."""
        self.command = [clamp(mixed(channels, row), -1.0, 1.0) for row in self._mix]

    def step(self, air: AirVelocity, thrust_ratio: Sequence[float] | None = None) -> Wrench:
        """One physics step: every flap follows its command (:func:`flap_deflection`), then
        the surfaces' summed wrench (:func:`surface_wrench` per surface) at the body's
        air-relative velocity ``air`` (``thrust_ratio``, the rotors', unused)."""
        (vx, vy, vz), (wx, wy, wz) = air
        deflection = []
        fx = fy = fz = tx = ty = tz = 0.0
        for (k, lag, max_deflection), d, c in zip(self._surfaces, self.deflection, self.command):
            d = flap_deflection(d, c, lag, max_deflection)
            deflection.append(d)
            sfx, sfy, sfz, stx, sty, stz = surface_wrench(k, d, vx, vy, vz, wx, wy, wz)
            fx, fy, fz = fx + sfx, fy + sfy, fz + sfz
            tx, ty, tz = tx + stx, ty + sty, tz + stz
        self.deflection = deflection
        return fx, fy, fz, tx, ty, tz

    def reset(self) -> None:
        """Flaps neutral, commands zero."""
        self.deflection = [0.0] * len(self.params)
        self.command = [0.0] * len(self.params)

    def reseed(self) -> None:
        """No noise: nothing to do."""

    def aux(self) -> list[float]:
        """Flap deflections normalised by their limits, in [-1, 1]."""
        return [d / scale for d, scale in zip(self.deflection, self._scale)]


def build_surfaces(ctx: BuildContext) -> Surfaces | None:
    """The lifting surfaces' group (None without ``surfaces``), each flap driven by its mix."""
    parts = ctx.parts
    return Surfaces(parts.surfaces, ctx.physics_dt, mix_rows(parts.surface_mix)) if parts.surfaces else None


register("surfaces", section="surfaces", spec=SurfaceSpec, build=build_surfaces, order=20, step_order=20)
