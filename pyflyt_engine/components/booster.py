"""Fueled booster: ignition latch, throttle-limited duty cycle, fuel burn, tank mass.

Model (paper, "Fueled Boosters"), for each of a vehicle's ``n`` boosters
(:func:`booster_step_scalar`, stepped by the group :class:`Boosters`, which also sums
their loads).  Per physics step of length ``dt``, for booster ``i``:

1. Ignition latch.  A booster that is not reignitable cannot be put out::

       I[t+1] = (not reignitable and I[t]) or ignition[t]

2. Duty cycle ``lambda`` in [0, 1].  While the booster is lit and has fuel it follows a
   first-order lag toward its target (coefficient from
   :func:`pyflyt_engine.components.lag.lag_coefficient`), times zero-mean multiplicative
   noise ``(1 + noise_ratio * eta)`` with ``eta ~ N(0, 1)`` drawn independently per
   booster by the caller; it is clipped to [0, 1] and is exactly 0 when unlit or when
   the tank is empty::

       lambda[t+1] = I[t+1] * 1{fuel[t] > 0}
                     * clip((lambda[t] + k * (target - lambda[t])) * (1 + noise_ratio * eta), 0, 1)
       k = lag_coefficient(dt, tau)

3. Thrust along the booster's thrust axis ``T = lambda[t+1] * max_thrust`` (N), so an
   empty or unlit booster gives no thrust.  Boosters produce no reaction torque about
   their own axis: the load on the body is the force ``T a`` at the booster's position
   ``p``, i.e. that force and the torque ``p x (T a)`` about the centre of mass.

4. Fuel burn ``fuel[t+1] = max(fuel[t] - lambda[t+1] * max_fuel_rate * dt, 0)`` (kg).

5. Tank mass properties: mass = remaining fuel; diagonal inertia about the tank's own
   centre scales linearly, ``J = fuel / total_fuel * J_full``.

Deviations from the paper's equation, on purpose:

* **Throttle mapping.**  The paper writes the duty target as ``beta * (1 - lambda_min)``
  with ``lambda_min = min_thrust / max_thrust``.  Taken literally that target never
  exceeds ``1 - lambda_min``, so ``max_thrust`` is unreachable, and a lit booster at
  ``beta = 0`` gives zero thrust, so ``min_thrust`` has no effect.  We use the affine map
  ``target = lambda_min + beta * (1 - lambda_min)`` with ``beta = clip(throttle, 0, 1)``,
  so a lit booster's steady thrust spans exactly ``[min_thrust, max_thrust]``: the
  throttleability range the parameters describe (e.g. Falcon 9 Merlin: 39-100 %).
* **Noise.**  The paper's factor is ``(1 + sigma * lambda[t] * eta)``; we use
  ``(1 + noise_ratio * eta)``, a relative fluctuation of the duty cycle that is
  zero-mean and independent per booster (the reference package instead drew one
  shared, biased N(4, 1) scalar).  Noise samples are passed in, never drawn here.
* **Lag.**  The exact zero-order-hold coefficient replaces the Euler ``1 / (tau r_p)``;
  see :mod:`pyflyt_engine.components.lag`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from pyflyt_engine.components import AirVelocity, Wrench
from pyflyt_engine.components.kinds import BuildContext, register
from pyflyt_engine.components.lag import lag_coefficient
from pyflyt_engine.components.noise import NoiseBlocks, NoiseSource
from pyflyt_engine.components.routing import clamp
from pyflyt_engine.spec import BoostersSpec

_UNIT_TOL = 1e-6


def _as_vector(name: str, value, n: int, dtype=np.float64) -> np.ndarray:
    """Return ``value`` as a read-only (n,) array, broadcasting a scalar."""
    arr = np.asarray(value, dtype=dtype)
    if arr.ndim == 0:
        arr = np.full(n, arr, dtype=dtype)
    if arr.shape != (n,):
        raise ValueError(
            f"{name} has shape {arr.shape}, expected ({n},) to match positions "
            f"(one value per booster) or a scalar; give one value per booster."
        )
    arr = arr.copy()
    arr.setflags(write=False)
    return arr


def _as_vec3(name: str, value, n: int) -> np.ndarray:
    """Return ``value`` as a read-only (n, 3) float array, broadcasting a single (3,)."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape == (3,):
        arr = np.broadcast_to(arr, (n, 3))
    if arr.shape != (n, 3):
        raise ValueError(
            f"{name} has shape {arr.shape}, expected ({n}, 3) to match positions "
            f"(one 3-vector per booster); give one row per booster."
        )
    arr = np.array(arr, dtype=np.float64)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class BoosterParams:
    """Parameters of ``n`` fueled boosters (all arrays, one entry/row per booster).

    Scalars are broadcast to ``n`` (taken from ``positions``); a single 3-vector is
    broadcast to ``(n, 3)``.  Arrays are stored as read-only float64 (bool for
    ``reignitable``).  Equality is identity (``eq=False``): arrays have no truth value.
    """

    positions: np.ndarray
    """(n, 3) m, body frame (X forward, Y left, Z up): point where thrust is applied."""
    thrust_axes: np.ndarray
    """(n, 3) unit vectors, body frame: direction of the thrust force on the vehicle."""
    fuel_tank_positions: np.ndarray
    """(n, 3) m, body frame: centre of each fuel tank (may differ from the booster)."""
    total_fuel: np.ndarray
    """(n,) kg, fuel mass of a full tank (paper m_b,max); > 0."""
    max_fuel_rate: np.ndarray
    """(n,) kg/s, fuel mass flow at duty 1 (paper k_fr); > 0."""
    inertia_full: np.ndarray
    """(n, 3) kg m^2, diagonal (Jxx, Jyy, Jzz) of the full tank about its own centre; >= 0."""
    min_thrust: np.ndarray
    """(n,) N, steady thrust of a lit booster at throttle 0; 0 <= min_thrust <= max_thrust."""
    max_thrust: np.ndarray
    """(n,) N, steady thrust at throttle 1 (duty 1); > 0."""
    reignitable: np.ndarray
    """(n,) bool: True if the booster can be put out and relit (paper I_b)."""
    tau: np.ndarray
    """(n,) s, time constant of the duty-cycle lag (paper tau_b); >= 0 (0 = no lag)."""
    noise_ratio: np.ndarray
    """(n,) dimensionless, std of the multiplicative duty noise (paper sigma_b); >= 0."""

    def __post_init__(self) -> None:
        positions = np.asarray(self.positions, dtype=np.float64)
        if positions.ndim != 2 or positions.shape[1] != 3 or positions.shape[0] < 1:
            raise ValueError(
                f"positions has shape {positions.shape}, expected (n, 3) with n >= 1; "
                f"give one body-frame point (m) per booster."
            )
        n = positions.shape[0]
        object.__setattr__(self, "positions", _as_vec3("positions", positions, n))
        for name in ("thrust_axes", "fuel_tank_positions", "inertia_full"):
            object.__setattr__(self, name, _as_vec3(name, getattr(self, name), n))
        for name in ("total_fuel", "max_fuel_rate", "min_thrust", "max_thrust", "tau", "noise_ratio"):
            object.__setattr__(self, name, _as_vector(name, getattr(self, name), n))
        object.__setattr__(self, "reignitable", _as_vector("reignitable", self.reignitable, n, dtype=bool))

        for name in (
            "positions",
            "thrust_axes",
            "fuel_tank_positions",
            "inertia_full",
            "total_fuel",
            "max_fuel_rate",
            "min_thrust",
            "max_thrust",
            "tau",
            "noise_ratio",
        ):
            if not np.all(np.isfinite(getattr(self, name))):
                raise ValueError(f"{name} contains non-finite values; give finite numbers.")

        norms = np.sqrt(np.sum(self.thrust_axes * self.thrust_axes, axis=1))
        if np.any(np.abs(norms - 1.0) > _UNIT_TOL):
            raise ValueError(
                f"thrust_axes must be unit vectors (norms {norms.tolist()}); normalise each thrust axis to length 1."
            )
        if np.any(self.total_fuel <= 0.0):
            raise ValueError("total_fuel must be > 0 kg for every booster; give the full-tank fuel mass.")
        if np.any(self.max_fuel_rate <= 0.0):
            raise ValueError("max_fuel_rate must be > 0 kg/s for every booster; give the fuel flow at full duty.")
        if np.any(self.max_thrust <= 0.0):
            raise ValueError("max_thrust must be > 0 N for every booster; give the thrust at full throttle.")
        if np.any(self.min_thrust < 0.0):
            raise ValueError("min_thrust must be >= 0 N; use 0 for a booster that throttles to zero.")
        if np.any(self.min_thrust > self.max_thrust):
            raise ValueError("min_thrust must be <= max_thrust; lower min_thrust or raise max_thrust.")
        if np.any(self.inertia_full < 0.0):
            raise ValueError("inertia_full must be >= 0 kg m^2; give the diagonal of the full-tank inertia.")
        if np.any(self.tau < 0.0):
            raise ValueError("tau must be >= 0 s; use 0 for no lag.")
        if np.any(self.noise_ratio < 0.0):
            raise ValueError("noise_ratio must be >= 0 (a standard deviation); use 0 for no noise.")

    @property
    def n(self) -> int:
        """Number of boosters."""
        return int(self.positions.shape[0])

    @property
    def min_duty(self) -> np.ndarray:
        """(n,) dimensionless, paper's lambda_min = min_thrust / max_thrust."""
        return self.min_thrust / self.max_thrust


@dataclass(frozen=True, eq=False)
class BoosterState:
    """State of ``n`` boosters at one physics step."""

    ignited: np.ndarray
    """(n,) bool, lit indicator I_lambda (latched for non-reignitable boosters)."""
    duty: np.ndarray
    """(n,) dimensionless in [0, 1], duty cycle lambda; thrust = duty * max_thrust."""
    fuel: np.ndarray
    """(n,) kg, fuel remaining in each tank, in [0, total_fuel]."""

    def __post_init__(self) -> None:
        ignited = np.array(self.ignited, dtype=bool, ndmin=1)
        duty = np.array(self.duty, dtype=np.float64, ndmin=1)
        fuel = np.array(self.fuel, dtype=np.float64, ndmin=1)
        if not (ignited.shape == duty.shape == fuel.shape and ignited.ndim == 1):
            raise ValueError(
                f"ignited, duty and fuel must all have shape (n,), got "
                f"{ignited.shape}, {duty.shape}, {fuel.shape}; give one value per booster."
            )
        for name, arr in (("ignited", ignited), ("duty", duty), ("fuel", fuel)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)


def initial_booster_state(
    params: BoosterParams, fuel_fraction: float | np.ndarray = 1.0, ignited: bool | np.ndarray = False
) -> BoosterState:
    """State with duty 0 and ``fuel_fraction`` (scalar or (n,), in [0, 1]) of a full tank."""
    fraction = np.broadcast_to(np.asarray(fuel_fraction, dtype=np.float64), (params.n,))
    if np.any(fraction < 0.0) or np.any(fraction > 1.0):
        raise ValueError("fuel_fraction must be in [0, 1]; it is the fraction of total_fuel in the tank.")
    return BoosterState(
        ignited=np.broadcast_to(np.asarray(ignited, dtype=bool), (params.n,)),
        duty=np.zeros(params.n),
        fuel=fraction * params.total_fuel,
    )


class BoosterConstants(NamedTuple):
    """One booster's parameters for a fixed physics step, as plain floats (see
    :func:`booster_constants`): what :func:`booster_step_scalar` needs."""

    reignitable: bool
    min_duty: float  #: lambda_min = min_thrust / max_thrust
    lag: float  #: lag_coefficient(dt, tau)
    noise_ratio: float
    max_fuel_rate: float  #: [kg/s]
    max_thrust: float  #: [N]
    dt: float  #: physics step [s]


def booster_constants(params: BoosterParams, dt: float) -> list[BoosterConstants]:
    """One :class:`BoosterConstants` per booster, for steps of length ``dt`` [s] (> 0)."""
    if dt <= 0.0:
        raise ValueError(f"dt must be > 0 s, got {dt}.")
    min_duty = params.min_duty.tolist()
    return [
        BoosterConstants(
            bool(params.reignitable[i]),
            min_duty[i],
            float(lag_coefficient(dt, float(params.tau[i]))),
            float(params.noise_ratio[i]),
            float(params.max_fuel_rate[i]),
            float(params.max_thrust[i]),
            float(dt),
        )
        for i in range(params.n)
    ]


def booster_step_scalar(
    k: BoosterConstants, ignited: bool, duty: float, fuel: float, ignition: bool, throttle: float, eta: float
) -> tuple[bool, float, float, float]:
    """One booster, one physics step: the model of the module docstring on plain floats.

    Args:
        k: the booster's constants.
        ignited, duty, fuel: its state at step t (lit, duty cycle, fuel [kg]).
        ignition: ignition command; throttle: normalised throttle (clipped to [0, 1]).
        eta: a standard-normal sample for the duty noise.

    Returns:
        ``(ignited, duty, fuel, thrust)`` at t+1, thrust in N along the thrust axis.
    """
    beta = min(max(throttle, 0.0), 1.0)
    ignited = (not k.reignitable and ignited) or ignition
    min_duty = k.min_duty
    target = min_duty + beta * (1.0 - min_duty)
    lagged = duty + k.lag * (target - duty)
    noisy = lagged * (1.0 + k.noise_ratio * eta)
    duty = min(max(noisy, 0.0), 1.0) if ignited and fuel > 0.0 else 0.0
    fuel = max(fuel - duty * k.max_fuel_rate * k.dt, 0.0)
    return ignited, duty, fuel, duty * k.max_thrust


def tank_inertia(fuel: float, total_fuel: float, inertia_full: Sequence[float]) -> tuple[float, float, float]:
    """One tank's diagonal inertia about its own centre [kg m^2] with ``fuel`` kg left:
    ``fuel / total_fuel * inertia_full`` (item 5 of the module docstring)."""
    ratio = fuel / total_fuel
    jx, jy, jz = inertia_full
    return ratio * jx, ratio * jy, ratio * jz


def tank_mass_properties(params: BoosterParams, fuel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mass and diagonal inertia of each fuel tank for the remaining fuel.

    Args:
        params: booster parameters.
        fuel: (n,) kg remaining (e.g. ``state.fuel``).

    Returns:
        ``(mass, inertia)``: (n,) kg equal to ``fuel``, and (n, 3) kg m^2 diagonal
        inertia about each tank's own centre (at ``params.fuel_tank_positions``),
        ``fuel / total_fuel * inertia_full`` (paper: linear in remaining fuel).
    """
    fuel = np.asarray(fuel, dtype=np.float64)
    if fuel.shape != (params.n,):
        raise ValueError(f"fuel has shape {fuel.shape}, expected ({params.n},).")
    rows = zip(fuel.tolist(), params.total_fuel.tolist(), params.inertia_full.tolist())
    inertia = np.array([tank_inertia(f, total, full) for f, total, full in rows], dtype=np.float64).reshape(-1, 3)
    return fuel.copy(), inertia


class Boosters:
    """The boosters of one vehicle as an actuator group: lit, duty and fuel state, commands, thrust.

    Args:
        params: the boosters, in the centre-of-mass body frame.
        physics_dt: physics step [s].
        noise: the vehicle's noise generator (duty noise is drawn from it in blocks).
        fuel_fraction: fuel at spawn, as a fraction of a full tank.
        ignition_channels, throttle_channels: per booster, the index of its ignition and
            of its throttle channel, for :meth:`route` (a group driven by setting
            ``ignition`` and ``throttle`` directly needs neither).

    Attributes:
        ignition, throttle: per booster, the commands (set at the control rate).
        axes: per booster, the thrust axis in the body frame (a gimbal turns it).
    """

    #: the thrust does not depend on the air
    needs_air = False
    commanded = True
    # the state as arrays, built when first read after a step (None: not built yet)
    _state: BoosterState | None

    def __init__(
        self,
        params: BoosterParams,
        physics_dt: float,
        noise: NoiseSource,
        fuel_fraction: float,
        ignition_channels: Sequence[int] = (),
        throttle_channels: Sequence[int] = (),
    ) -> None:
        self.params = params
        self._ignition_channels = list(ignition_channels)
        self._throttle_channels = list(throttle_channels)
        self.fuel_fraction = fuel_fraction
        self._constants = booster_constants(params, physics_dt)
        self._positions = [tuple(p) for p in params.positions.tolist()]
        self._nominal_axes = [tuple(a) for a in params.thrust_axes.tolist()]
        self._total_fuel = params.total_fuel.tolist()
        self._inertia_full = [tuple(j) for j in params.inertia_full.tolist()]
        # per tank, the parallel-axis factors |r|^2 - r_i^2 of its offset r from the centre of mass
        r = params.fuel_tank_positions
        self._tank_offsets = [tuple(o) for o in (np.sum(r * r, axis=1)[:, None] - r * r).tolist()]
        self._noisy = bool(np.any(params.noise_ratio > 0))
        self._zeros = [0.0] * params.n
        self._noise = NoiseBlocks(noise, params.n)
        self.reset()

    @property
    def state(self) -> BoosterState:
        """The boosters' :class:`BoosterState` (read-only arrays; assign one to set it)."""
        if self._state is None:
            self._state = BoosterState(ignited=self.ignited, duty=self.duty, fuel=self.fuel)
        return self._state

    @state.setter
    def state(self, state: BoosterState) -> None:
        self.ignited, self.duty, self.fuel = state.ignited.tolist(), state.duty.tolist(), state.fuel.tolist()
        self._state = state

    def route(self, channels: Sequence[float], outputs: Sequence[float] | None = None) -> None:
        """Commands from the channels: a booster is lit while its ignition channel is above
        0.5; its throttle is its throttle channel limited to [0, 1] (the mixer flies no
        booster: ``outputs`` unused)."""
        self.ignition = [channels[j] > 0.5 for j in self._ignition_channels]
        self.throttle = [clamp(channels[j], 0.0, 1.0) for j in self._throttle_channels]

    def step(self, air: AirVelocity | None = None, thrust_ratio: Sequence[float] | None = None) -> Wrench:
        """One physics step of every booster (:func:`booster_step_scalar`); returns their summed
        thrust wrench (the module docstring, item 3).  The air does not enter this model."""
        noise = self._noise.next() if self._noisy else self._zeros
        ignited, duty, fuel = self.ignited, self.duty, self.fuel
        fx = fy = fz = tx = ty = tz = 0.0
        for i, k in enumerate(self._constants):
            ignited[i], duty[i], fuel[i], thrust = booster_step_scalar(
                k, ignited[i], duty[i], fuel[i], self.ignition[i], self.throttle[i], noise[i]
            )
            ax, ay, az = self.axes[i]
            px, py, pz = self._positions[i]
            ffx, ffy, ffz = thrust * ax, thrust * ay, thrust * az
            if i == 0:
                fx, fy, fz = ffx, ffy, ffz
                tx, ty, tz = py * ffz - pz * ffy, pz * ffx - px * ffz, px * ffy - py * ffx
            else:
                fx, fy, fz = fx + ffx, fy + ffy, fz + ffz
                tx, ty, tz = tx + (py * ffz - pz * ffy), ty + (pz * ffx - px * ffz), tz + (px * ffy - py * ffx)
        self._state = None
        return fx, fy, fz, tx, ty, tz

    def fuel_mass_properties(self) -> tuple[float, tuple[float, float, float]]:
        """The remaining fuel's mass [kg] and inertia diagonal [kg m^2] about the body origin
        (the centre of mass): per tank :func:`tank_inertia` plus the parallel-axis term of
        its offset ``r``, ``fuel * (|r|^2 - r_i^2)`` on axis i.  Summed over the tanks in
        their order, first tank first: NumPy's order for the sums over fewer than 8 tanks,
        with which the recorded trajectories were made."""
        mass = inertia = None
        for f, total, full, (ox, oy, oz) in zip(self.fuel, self._total_fuel, self._inertia_full, self._tank_offsets):
            jx, jy, jz = tank_inertia(f, total, full)
            jx, jy, jz = jx + f * ox, jy + f * oy, jz + f * oz
            if inertia is None:
                mass, inertia = f, (jx, jy, jz)
            else:
                mass, inertia = mass + f, (inertia[0] + jx, inertia[1] + jy, inertia[2] + jz)
        assert mass is not None and inertia is not None  # BoosterParams has n >= 1
        return mass, inertia

    def turn(self, index: int, thrust_axis: Sequence[float]) -> None:
        """Point booster ``index``'s thrust along ``thrust_axis`` (a gimbal moved it)."""
        self.axes[index] = tuple(thrust_axis)

    def reset(self) -> None:
        """Unlit, duty 0, ``fuel_fraction`` of each tank; idle commands; buffered noise discarded."""
        self.state = initial_booster_state(self.params, fuel_fraction=self.fuel_fraction)
        self.ignition = [False] * self.params.n
        self.throttle = [0.0] * self.params.n
        self.axes = list(self._nominal_axes)
        self._noise.discard()

    def reseed(self) -> None:
        """The noise generator was replaced: draw from the new one."""
        self._noise.discard()

    def aux(self) -> list[float]:
        """Per booster: fuel fraction, duty and ignition (0/1)."""
        values: list[float] = []
        for fuel, total, duty, ignited in zip(self.fuel, self._total_fuel, self.duty, self.ignited):
            values += (fuel / total, duty, 1.0 if ignited else 0.0)
        return values


def build_boosters(ctx: BuildContext) -> Boosters | None:
    """The boosters' group (None without ``boosters``), lit and throttled by their channels."""
    parts, spec = ctx.parts, ctx.spec.boosters
    if parts.boosters is None or spec is None:
        return None
    return Boosters(
        parts.boosters,
        ctx.physics_dt,
        ctx.noise,
        spec.initial_fuel,
        parts.ignition_index.tolist(),
        parts.throttle_index.tolist(),
    )


register("boosters", section="boosters", spec=BoostersSpec, build=build_boosters, order=30, step_order=30)
