"""Electric two-axis gimbal: lagged servo angles and the rotation they produce.

Model (paper, "Electric Gimbals"), vectorised over ``n`` gimbals.  Gimbal ``i`` has two
servo axes ``c_a`` and ``c_b`` (unit vectors in the body frame, X forward, Y left, Z up;
not necessarily orthogonal), maximum angles ``k_a``, ``k_b`` and a time constant ``tau``.

* Angles ``eps = [eps_a, eps_b]`` (rad) follow a first-order lag toward
  ``clip(command, -1, 1) * max_angle`` with coefficient
  :func:`pyflyt_engine.components.lag.lag_coefficient` (exact zero-order hold instead of
  the paper's Euler ``1 / (tau r_p)``).
* Each axis gives a Rodrigues rotation in the numerically stable form of the paper::

      R_j = I + sin(eps_j) W_j + 2 sin^2(eps_j / 2) W_j^2,   j in {a, b}

  with ``W_j`` the skew (cross-product) matrix of ``c_j``, so ``W_j v = c_j x v``;
  ``W_j`` and ``W_j^2`` depend only on the axes and are precomputed.
* The gimbal rotation is ``R = R_a @ R_b`` (paper): a vector is first rotated about
  ``c_b``, then about ``c_a``, both axes fixed in the body frame.

Typical use is thrust vectoring: :func:`rotate_vector_scalar` turns a booster's or a
motor's nominal thrust axis into the vectored one its group then pushes along.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple, Protocol, cast

import numpy as np

from pyflyt_engine import exact
from pyflyt_engine.components import AirVelocity
from pyflyt_engine.components.kinds import BuildContext, register
from pyflyt_engine.components.lag import lag_coefficient
from pyflyt_engine.components.routing import clamp
from pyflyt_engine.spec import GimbalSpec

_UNIT_TOL = 1e-6
#: a target group's ``turn(index, thrust_axis)``: point its actuator ``index`` along the axis
Turn = Callable[[int, Sequence[float]], None]


def skew(u: np.ndarray) -> np.ndarray:
    """(..., 3) vectors -> (..., 3, 3) skew matrices W with ``W @ v == u x v`` (paper's W)."""
    u = np.asarray(u, dtype=np.float64)
    ux, uy, uz = u[..., 0], u[..., 1], u[..., 2]
    zero = np.zeros_like(ux)
    return np.stack(
        [
            np.stack([zero, -uz, uy], axis=-1),
            np.stack([uz, zero, -ux], axis=-1),
            np.stack([-uy, ux, zero], axis=-1),
        ],
        axis=-2,
    )


def _squares(W: np.ndarray) -> np.ndarray:
    """(n, 3, 3) ``W_i @ W_i`` with :func:`math.fsum` sums (:mod:`pyflyt_engine.exact`; not BLAS)."""
    return np.array([exact.matmul(w, w) for w in W], dtype=np.float64).reshape(W.shape)


def _readonly(arr: np.ndarray) -> np.ndarray:
    arr = np.array(arr, dtype=np.float64)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class GimbalParams:
    """Parameters of ``n`` two-axis gimbals (one entry/row per gimbal).

    Scalars are broadcast to ``n`` (taken from ``axis_a``); a single 3-vector is
    broadcast to ``(n, 3)``.  Arrays are stored read-only.  Equality is identity
    (``eq=False``): arrays have no truth value.
    """

    axis_a: np.ndarray
    """(n, 3) unit vectors, body frame: first servo axis c_a (applied last, R = R_a R_b)."""
    axis_b: np.ndarray
    """(n, 3) unit vectors, body frame: second servo axis c_b."""
    max_angle_a: np.ndarray
    """(n,) rad, angle about c_a at command +1 (paper k_g-a); >= 0."""
    max_angle_b: np.ndarray
    """(n,) rad, angle about c_b at command +1 (paper k_g-b); >= 0."""
    tau: np.ndarray
    """(n,) s, servo time constant (paper tau_g); >= 0 (0 = no lag)."""

    W_a: np.ndarray = field(init=False, repr=False)
    """(n, 3, 3) derived: skew matrix of axis_a (paper W_a)."""
    W_a2: np.ndarray = field(init=False, repr=False)
    """(n, 3, 3) derived: W_a @ W_a."""
    W_b: np.ndarray = field(init=False, repr=False)
    """(n, 3, 3) derived: skew matrix of axis_b (paper W_b)."""
    W_b2: np.ndarray = field(init=False, repr=False)
    """(n, 3, 3) derived: W_b @ W_b."""

    def __post_init__(self) -> None:
        axis_a = np.asarray(self.axis_a, dtype=np.float64)
        if axis_a.ndim == 1:
            axis_a = axis_a[None, :]
        if axis_a.ndim != 2 or axis_a.shape[1] != 3:
            raise ValueError(f"axis_a has shape {axis_a.shape}, expected (n, 3); give one unit vector per gimbal.")
        n = axis_a.shape[0]
        axes = {"axis_a": axis_a, "axis_b": np.asarray(self.axis_b, dtype=np.float64)}
        if axes["axis_b"].shape == (3,):
            axes["axis_b"] = np.broadcast_to(axes["axis_b"], (n, 3))
        for name, arr in axes.items():
            if arr.shape != (n, 3):
                raise ValueError(
                    f"{name} has shape {arr.shape}, expected ({n}, 3) to match axis_a; give one unit vector per gimbal."
                )
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{name} contains non-finite values; give finite unit vectors.")
            norms = np.sqrt(np.sum(arr * arr, axis=1))
            if np.any(np.abs(norms - 1.0) > _UNIT_TOL):
                raise ValueError(
                    f"{name} must be unit vectors (norms {norms.tolist()}); normalise each axis to length 1."
                )
            object.__setattr__(self, name, _readonly(arr))

        for name in ("max_angle_a", "max_angle_b", "tau"):
            arr = np.asarray(getattr(self, name), dtype=np.float64)
            if arr.ndim == 0:
                arr = np.full(n, arr)
            if arr.shape != (n,):
                raise ValueError(
                    f"{name} has shape {arr.shape}, expected ({n},) or a scalar; give one value per gimbal."
                )
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{name} contains non-finite values; give finite numbers.")
            if np.any(arr < 0.0):
                unit = "s" if name == "tau" else "rad"
                raise ValueError(f"{name} must be >= 0 {unit}; give a non-negative value.")
            object.__setattr__(self, name, _readonly(arr))

        W_a = skew(self.axis_a)
        W_b = skew(self.axis_b)
        object.__setattr__(self, "W_a", _readonly(W_a))
        object.__setattr__(self, "W_a2", _readonly(_squares(W_a)))
        object.__setattr__(self, "W_b", _readonly(W_b))
        object.__setattr__(self, "W_b2", _readonly(_squares(W_b)))

    @property
    def n(self) -> int:
        """Number of gimbals."""
        return int(self.axis_a.shape[0])

    @property
    def max_angles(self) -> np.ndarray:
        """(n, 2) rad, ``[max_angle_a, max_angle_b]`` per gimbal."""
        return np.stack([self.max_angle_a, self.max_angle_b], axis=1)


class GimbalConstants(NamedTuple):
    """One gimbal's parameters for a fixed physics step, as plain floats (see
    :func:`gimbal_constants`): what :func:`gimbal_step_scalar` and
    :func:`rotate_vector_scalar` need."""

    lag: float  #: lag_coefficient(dt, tau)
    max_angle_a: float  #: [rad]
    max_angle_b: float  #: [rad]
    W_a: tuple[float, ...]  #: skew matrix of c_a, row-major (9)
    W_a2: tuple[float, ...]  #: W_a @ W_a, row-major
    W_b: tuple[float, ...]
    W_b2: tuple[float, ...]


def gimbal_constants(params: GimbalParams, dt: float) -> list[GimbalConstants]:
    """One :class:`GimbalConstants` per gimbal, for steps of length ``dt`` [s] (> 0)."""
    if dt <= 0.0:
        raise ValueError(f"dt must be > 0 s, got {dt}.")
    return [
        GimbalConstants(
            float(lag_coefficient(dt, float(params.tau[i]))),
            float(params.max_angle_a[i]),
            float(params.max_angle_b[i]),
            *(tuple(getattr(params, name)[i].ravel().tolist()) for name in ("W_a", "W_a2", "W_b", "W_b2")),
        )
        for i in range(params.n)
    ]


def gimbal_step_scalar(k: GimbalConstants, eps_a: float, eps_b: float, xi_a: float, xi_b: float) -> tuple[float, float]:
    """One gimbal's servo angles [rad] after one physics step toward ``clip(xi, -1, 1) * max_angle``
    (the first-order lag of the module docstring, coefficient ``k.lag``)."""
    target_a = min(max(xi_a, -1.0), 1.0) * k.max_angle_a
    target_b = min(max(xi_b, -1.0), 1.0) * k.max_angle_b
    return eps_a + k.lag * (target_a - eps_a), eps_b + k.lag * (target_b - eps_b)


def _rodrigues(
    W: tuple[float, ...], W2: tuple[float, ...], eps: float, x: float, y: float, z: float
) -> tuple[float, float, float]:
    """(I + sin(eps) W + 2 sin^2(eps / 2) W^2) v."""
    sin = math.sin(eps)
    vers = 2.0 * math.sin(0.5 * eps) ** 2
    return (
        x + sin * (W[0] * x + W[1] * y + W[2] * z) + vers * (W2[0] * x + W2[1] * y + W2[2] * z),
        y + sin * (W[3] * x + W[4] * y + W[5] * z) + vers * (W2[3] * x + W2[4] * y + W2[5] * z),
        z + sin * (W[6] * x + W[7] * y + W[8] * z) + vers * (W2[6] * x + W2[7] * y + W2[8] * z),
    )


def rotate_vector_scalar(
    k: GimbalConstants, eps_a: float, eps_b: float, v: tuple[float, float, float]
) -> tuple[float, float, float]:
    """``R_a R_b v`` for one gimbal at angles (eps_a, eps_b) [rad]: the Rodrigues rotation of
    the module docstring about ``c_b``, then about ``c_a``, applied to the vector."""
    return _rodrigues(k.W_a, k.W_a2, eps_a, *_rodrigues(k.W_b, k.W_b2, eps_b, *v))


class Gimbals:
    """The gimbals of one vehicle as an actuator group: servo angles and commands.

    A gimbal applies no load of its own: each physics step it moves its servos and points
    its target motor or booster along the thrust axis the new angles give (the target's
    ``turn``, handed to it at build); it steps before every group that loads the body.

    Args:
        params: the gimbals.
        physics_dt: physics step [s].
        nominal_axes: per gimbal, the axis it turns (its target's nominal thrust axis,
            body frame).
        channels: per gimbal, the indices of its (a, b) command channels, or (-1, -1) for
            a gimbal the mixer flies (default: (-1, -1) for every gimbal).
        mixer_outputs: gimbal index -> the mixer output that commands its axis a (axis b
            centred), for the gimbals the mixer flies.
        targets: per gimbal, (its target group's ``turn``, the target's index) (default:
            none; :meth:`servo_step` alone then moves the servos).

    Attributes:
        angles: per gimbal, (eps_a, eps_b) [rad] (the state).
        command: per gimbal, normalised (xi_a, xi_b) in [-1, 1] (set at the control rate).
    """

    needs_air = False
    commanded = True

    def __init__(
        self,
        params: GimbalParams,
        physics_dt: float,
        nominal_axes: Sequence[tuple[float, float, float]],
        channels: Sequence[tuple[int, int]] | None = None,
        mixer_outputs: dict[int, int] | None = None,
        targets: Sequence[tuple[Turn, int]] = (),
    ) -> None:
        self.params = params
        self._targets = list(targets)
        self._constants = gimbal_constants(params, physics_dt)
        self._nominal = [(float(x), float(y), float(z)) for x, y, z in nominal_axes]
        self._channels = [tuple(c) for c in channels] if channels is not None else [(-1, -1)] * params.n
        self._mixer_outputs = dict(mixer_outputs or {})
        self._scale = [(max(a, 1e-12), max(b, 1e-12)) for a, b in params.max_angles.tolist()]
        self.reset()

    def route(self, channels: Sequence[float], outputs: Sequence[float] | None) -> None:
        """Commands from the channels (each axis its channel, limited to [-1, 1]; (0, 0) for
        a gimbal without channels) and, for a gimbal the mixer flies, the mixer's output
        on axis a (0, centred, when there is none this tick)."""
        self.command = [
            (clamp(channels[i], -1.0, 1.0), clamp(channels[j], -1.0, 1.0)) if i >= 0 else (0.0, 0.0)
            for i, j in self._channels
        ]
        for g, k in self._mixer_outputs.items():
            self.command[g] = (clamp(outputs[k], -1.0, 1.0) if outputs is not None else 0.0, 0.0)

    def step(self, air: AirVelocity | None = None, thrust_ratio: Sequence[float] | None = None) -> None:
        """One physics step (:meth:`servo_step`), each target pointed along its turned axis;
        no load of its own."""
        for (turn, index), axis in zip(self._targets, self.servo_step()):
            turn(index, axis)

    def servo_step(self) -> list[tuple[float, float, float]]:
        """Servos one physics step toward their commands; returns, per gimbal, its target's
        thrust axis turned by the new angles (:func:`rotate_vector_scalar`)."""
        angles, command = self.angles, self.command
        axes = []
        for g, (k, nominal) in enumerate(zip(self._constants, self._nominal)):
            eps_a, eps_b = angles[g] = gimbal_step_scalar(k, *angles[g], *command[g])
            axes.append(rotate_vector_scalar(k, eps_a, eps_b, nominal))
        return axes

    def reset(self) -> None:
        """Servos centred, commands zero."""
        self.angles = [(0.0, 0.0)] * self.params.n
        self.command = [(0.0, 0.0)] * self.params.n

    def reseed(self) -> None:
        """No noise: nothing to do."""

    def aux(self) -> list[float]:
        """Servo angles normalised by their limits, in [-1, 1]."""
        values: list[float] = []
        for (eps_a, eps_b), (max_a, max_b) in zip(self.angles, self._scale):
            values += (eps_a / max_a, eps_b / max_b)
        return values


class _Turnable(Protocol):  # what a gimbal's target group offers (Motors, Boosters)
    turn: Turn


def build_gimbals(ctx: BuildContext) -> Gimbals | None:
    """The gimbals' group (None without ``gimbals``), each handed its target motor's or
    booster's ``turn`` (those groups are built before it: lower order)."""
    parts = ctx.parts
    if parts.gimbals is None:
        return None
    targets, nominal = [], []
    for kind, index in parts.gimbal_targets:
        # the spec validator checks every gimbal's target exists
        group = cast(_Turnable, ctx.groups["motors" if kind == "motor" else "boosters"])
        targets.append((group.turn, index))
        axes = (parts.motors if kind == "motor" else parts.boosters).thrust_axes  # type: ignore[union-attr]
        nominal.append(tuple(axes[index].tolist()))
    # a gimbal the mixer flies: its command is the mixer output after the motors' throttles
    n_mixer = len(parts.mixer_motors)
    flown = {g: n_mixer + k for k, (g, _) in enumerate(parts.mixer_tilts)}
    channels = [tuple(row) for row in parts.gimbal_channels.tolist()]
    return Gimbals(parts.gimbals, ctx.physics_dt, nominal, channels, flown, targets)


# built after the motors and boosters it turns; stepped first, before any load
register("gimbals", section="gimbals", spec=GimbalSpec, build=build_gimbals, order=40, step_order=0)
