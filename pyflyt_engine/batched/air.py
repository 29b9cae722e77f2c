"""The air of the batched backend: the wind field and ground effect as compiled laws.

The PyBullet engine's atmosphere (:mod:`pyflyt_engine.atmosphere`) in the form the
compiled advance loops (:mod:`pyflyt_engine.batched.kernels`) call once per vehicle and
physics step, each law the engine's own expression in the same order of operations
(``tests/batched/test_laws.py`` holds every pair bit for bit):

* the wind at a vehicle (:func:`wind_sample`): the field of
  :class:`~pyflyt_engine.atmosphere.field.WindField` -- the mean wind (uniform, or
  sheared with height by the log or power law, :func:`~pyflyt_engine.atmosphere.field.shear_factor`),
  plus the discrete 1-cosine gust (``gust_profiles``), plus the Dryden turbulence, at the
  env's physics step since its episode began (the engine's field restarts at time 0 on
  every reset and moves on one physics step at a time), at the vehicle's height for a
  sheared wind;
* the Dryden turbulence (:func:`dryden_initial`, :func:`dryden_output`, :func:`dryden_step`):
  the engine's exactly discretised filter (:class:`~pyflyt_engine.atmosphere.dryden.DrydenProcess`,
  its matrices read out of it: :func:`dryden_filter`), stepped once per physics step from
  standard normal draws, its output turned from the turbulence axes to the ground frame.
  The engine draws those normals in blocks of physics steps from its world's wind stream;
  here each env draws them per agent step from its own stream (``BatchedUAVEnv``), so the
  realisations differ while the law is the same -- given the same draws the wind is the
  engine's bit for bit (``tests/batched/test_air.py`` injects the engine's);
* the body's velocity through the air (:func:`air_from_motion`, :func:`air_from_body`):
  :func:`~pyflyt_engine.atmosphere.air.air_velocity` between control ticks (from a read of
  the motion), :func:`~pyflyt_engine.atmosphere.air.air_velocity_from_body` on a tick (from
  the state read, already in the body frame), as the PyBullet engine's world forms it;
  body drag and every lifting surface take it;
* ground effect (:func:`ground_effect_columns`): each rotor's Cheeseman-Bennett ratio at
  its hub height (:meth:`~pyflyt_engine.atmosphere.rotors.RotorInteractions.ground_effect_ratios`)
  applied to the motor wrench columns as ``Motors._scaled_columns`` does (thrust and its
  moment scaled, the reaction torque left alone).

:func:`wind_params` writes a :class:`~pyflyt_engine.atmosphere.config.WindConfig` into the
flat array these laws read (:data:`WIND_FIELDS`), with the constants computed by the same
expressions as the engine's field computes them.
"""

from __future__ import annotations

import inspect
import math
from dataclasses import dataclass

import numpy as np

from pyflyt_engine.batched.compiled import njit
from pyflyt_engine.atmosphere.config import WindConfig
from pyflyt_engine.atmosphere.rotors import RotorInteractions

#: the wind parameter array's layout (:func:`wind_params`)
WIND_FIELDS = (
    "on",
    "mean_x",
    "mean_y",
    "vertical",
    "shear",
    "shear_x",
    "shear_y",
    "roughness_length",
    "reference_height",
    "exponent",
    "gust",
    "gust_x",
    "gust_y",
    "gust_z",
    "gust_length",
    "gust_speed",
    "gust_start",
    "turbulence",
    "turbulence_cos",
    "turbulence_sin",
    "rotary",
)
#: the ground-effect clamp in rotor radii: the PyBullet engine's worlds build their
#: RotorInteractions with its default
GROUND_EFFECT_MIN_HEIGHT = inspect.signature(RotorInteractions).parameters["min_height"].default
#: shear codes: none (a uniform or absent mean wind), the log law, the power law
SHEAR_NONE, SHEAR_LOG, SHEAR_POWER = 0.0, 1.0, 2.0
#: gust codes: none, shape step (holds its peak), shape pulse (back to 0 after 2 lengths)
GUST_NONE, GUST_STEP, GUST_PULSE = 0.0, 1.0, 2.0


def wind_params(config: WindConfig, rotary: bool = False) -> np.ndarray:
    """The flat parameter array (:data:`WIND_FIELDS`) of a wind config's mean wind and gust,
    the mean's components ``speed cos(direction)``, ``speed sin(direction)`` as
    :class:`~pyflyt_engine.atmosphere.field.WindField` computes them.  ``on`` is 0 for a
    calm config (the kernels then leave the air as the body's own velocity); ``rotary``: the
    vehicle takes the turbulence's rotary gusts (:attr:`Dryden.rotary`)."""
    out = np.zeros(len(WIND_FIELDS))
    f = dict.fromkeys(WIND_FIELDS, 0.0)
    mean = config.mean
    if not config.calm:
        f["on"] = 1.0
    if mean is not None:
        heading = math.radians(mean.direction)
        mx, my = mean.speed * math.cos(heading), mean.speed * math.sin(heading)
        f["vertical"] = mean.vertical
        if mean.profile != "uniform" and mean.speed != 0.0:  # the field's "sheared"
            f["shear"] = SHEAR_LOG if mean.profile == "log" else SHEAR_POWER
            f["shear_x"], f["shear_y"] = mx, my
            f["roughness_length"], f["reference_height"], f["exponent"] = (
                mean.roughness_length,
                mean.reference_height,
                mean.exponent,
            )
        else:
            f["mean_x"], f["mean_y"] = mx, my
    gust = config.gust
    if gust is not None:
        f["gust"] = GUST_STEP if gust.shape == "step" else GUST_PULSE
        f["gust_x"], f["gust_y"], f["gust_z"] = (float(v) for v in gust.amplitude)
        f["gust_length"], f["gust_speed"], f["gust_start"] = gust.length, gust.speed, gust.start
    turbulence = config.turbulence
    if turbulence is not None and turbulence.wind_speed_20ft > 0:  # the field's "turbulent"
        direction = turbulence.direction if turbulence.direction is not None else (mean.direction if mean else 0.0)
        heading = math.radians(direction)
        f["turbulence"] = 1.0
        f["turbulence_cos"], f["turbulence_sin"] = math.cos(heading), math.sin(heading)
        f["rotary"] = 1.0 if rotary else 0.0
    for k, name in enumerate(WIND_FIELDS):
        out[k] = f[name]
    return out


@dataclass(frozen=True)
class Dryden:
    """One vehicle's Dryden turbulence filter, read out of the engine's own
    :class:`~pyflyt_engine.atmosphere.dryden.DrydenProcess` (as a
    :class:`~pyflyt_engine.atmosphere.field.WindField` builds it for a world of that one
    vehicle): ``arrays`` is the tuple the compiled laws take, (``Phi``, ``C``, the noise's
    Cholesky factor, the stationary state's factor, per column whether ``C``, the noise
    factor and the state factor have a non-zero entry there (3, n)); ``rotary``: the
    vehicle gets the rotary gusts p, q, r (its span is at least ``rotary_min_span``)."""

    arrays: tuple
    rotary: bool

    @property
    def states(self) -> int:
        return self.arrays[0].shape[0]


def dryden_filter(config: WindConfig, physics_dt: float, span: float, vehicles: int = 1) -> Dryden | None:
    """The turbulence filter of a world of ``vehicles`` vehicles of span ``span`` [m] in
    ``config`` (None: no turbulence), as the engine's field builds it for them: one filter for
    the world, its linear states shared, and with rotary gusts the ``p, q, r`` states and output
    rows of each vehicle in turn (vehicle ``j``'s outputs are rows ``3 + 3 j ... 5 + 3 j`` of
    ``C``, :func:`dryden_rotary`)."""
    turbulence = config.turbulence
    if turbulence is None or turbulence.wind_speed_20ft <= 0:
        return None
    from pyflyt_engine.atmosphere.field import WindField

    field = WindField(config, physics_dt, np.random.default_rng(0), block=1)
    field.add_vehicles([span] * vehicles)
    process = field._process
    assert process is not None
    phi, c = np.ascontiguousarray(process.Phi), np.ascontiguousarray(process.C)
    noise, state = np.ascontiguousarray(process._noise_root), np.ascontiguousarray(process._state_root)
    flags = np.array([m.any(axis=0) for m in (c, noise, state)], dtype=np.float64)
    rotary = bool(turbulence.angular and field._rotary(span))
    return Dryden((phi, c, noise, state, flags), rotary)


def air_rows(
    config: WindConfig, physics_dt: float, span: float, slots: int, filters: int, vehicles: int = 1
) -> tuple[Dryden | None, np.ndarray, tuple, np.ndarray, tuple]:
    """The rows of the air an env's vehicles fly, the config's in every row: the world filter
    (:func:`dryden_filter` for ``vehicles`` vehicles of ``span``; None without turbulence), the
    wind parameters (:func:`wind_params`), the filter's arrays (empty ones without turbulence),
    ``slots`` rows of the parameters and ``filters`` rows of each filter array (writable copies:
    a drawn wind sets an env's or a world's rows per episode)."""
    dryden = dryden_filter(config, physics_dt, span, vehicles)
    params = wind_params(config, rotary=dryden is not None and dryden.rotary)
    arrays = dryden.arrays if dryden is not None else (np.zeros((0, 0)),) * 4 + (np.zeros((3, 0)),)

    def rows(a: np.ndarray, count: int) -> np.ndarray:
        return np.array(np.broadcast_to(a, (count, *np.shape(a))), dtype=np.float64, order="C")

    return dryden, params, arrays, rows(params, slots), tuple(rows(a, filters) for a in arrays)


@njit(cache=True)
def gust_fraction(x: float, length: float, pulse: bool) -> float:
    """The 1-cosine gust fraction at ``x`` [m] past the front, as the engine's field evaluates
    it (``field.gust_profiles``: the rise ``0.5 (1 - cos(pi max(x, 0) / length))``, 0 up to
    the front, then 1 past ``length`` (step) or 0 past ``2 length`` (pulse))."""
    rise = 0.5 * (1.0 - math.cos(math.pi * (x if x > 0.0 else 0.0) / length))
    out = 0.0 if x <= 0.0 else rise
    if not pulse:
        return 1.0 if x > length else out
    return 0.0 if x > 2.0 * length else out


@njit(cache=True)
def shear(params: np.ndarray, height: float) -> float:
    """The mean wind's height factor (``field.shear_factor``) of a sheared wind at ``height`` [m]."""
    if params[4] == SHEAR_LOG:
        z0 = params[7]
        return math.log(height / z0) / math.log(params[8] / z0) if height > z0 else 0.0
    return (height / params[8]) ** params[9] if height > 0.0 else 0.0


@njit(cache=True)
def wind_sample(params: np.ndarray, step: int, height: float, physics_dt: float, turbulence):
    """The wind (x, y, z [m/s], p, q, r [rad/s]), ground frame, at physics step ``step`` of
    the episode and at ``height`` [m] (``WindField.at``): the mean (0 where sheared), plus
    the gust ``amplitude * fraction``, plus the ``turbulence`` (:func:`dryden_output`, in the
    ground frame; added where ``params`` has turbulence), then the sheared mean ``factor *
    mean``; the rotary gusts are the turbulence's (0 without)."""
    wx, wy, wz = params[1], params[2], params[3]
    if params[10] != GUST_NONE:
        t = float(step) * physics_dt
        f = gust_fraction(params[15] * (t - params[16]), params[14], params[10] == GUST_PULSE)
        wx = wx + params[11] * f
        wy = wy + params[12] * f
        wz = wz + params[13] * f
    p = q = r = 0.0
    if params[17] != 0.0:
        wx = wx + turbulence[0]
        wy = wy + turbulence[1]
        wz = wz + turbulence[2]
        if params[20] != 0.0:
            p, q, r = turbulence[3], turbulence[4], turbulence[5]
    if params[4] != SHEAR_NONE:
        f = shear(params, height)
        wx = wx + f * params[5]
        wy = wy + f * params[6]
    return wx, wy, wz, p, q, r


@njit(cache=True)
def _matvec_row(a: np.ndarray, used: np.ndarray, i: int, x: np.ndarray) -> float:
    """Row ``i`` of ``a @ x`` as ``exact.array_matmul`` sums it: over the columns in order,
    skipping a column that is zero in every row (``used`` 0 there), from 0.0."""
    acc = 0.0
    for k in range(a.shape[1]):
        if used[k] != 0.0:
            acc += a[i, k] * x[k]
    return acc


@njit(cache=True)
def dryden_output(dryden, x: np.ndarray, c: float, s: float):
    """The turbulence of state ``x`` in the ground frame, (u, v, w [m/s], p, q, r [rad/s]):
    ``C x`` (``DrydenProcess.generate``'s output, by ``exact.array_matmul``), each triple
    turned from the turbulence axes by the heading's cosine ``c`` and sine ``s`` as
    ``field._turned`` turns it (``c x - s y``, ``s x + c y``); the rotary triple 0 without
    rotary rows."""
    cm, flags = dryden[1], dryden[4]
    u, v, w = _matvec_row(cm, flags[0], 0, x), _matvec_row(cm, flags[0], 1, x), _matvec_row(cm, flags[0], 2, x)
    p, q, r = dryden_rotary(dryden, x, c, s, 0)
    return c * u - s * v, s * u + c * v, w, p, q, r


@njit(cache=True)
def dryden_rotary(dryden, x: np.ndarray, c: float, s: float, j: int):
    """Vehicle ``j``'s rotary gusts (p, q, r) [rad/s] in the ground frame from state ``x``: rows
    ``3 + 3 j`` to ``5 + 3 j`` of ``C x`` turned as :func:`dryden_output` turns them; 0 where the
    filter has no rotary rows (turned as they are: the zeros keep their signs' arithmetic)."""
    cm, flags = dryden[1], dryden[4]
    row = 3 + 3 * j
    p = q = r = 0.0
    if cm.shape[0] >= row + 3:
        p, q, r = (
            _matvec_row(cm, flags[0], row, x),
            _matvec_row(cm, flags[0], row + 1, x),
            _matvec_row(cm, flags[0], row + 2, x),
        )
    return c * p - s * q, s * p + c * q, r


@njit(cache=True)
def dryden_step(dryden, x: np.ndarray, z: np.ndarray, scratch: np.ndarray) -> None:
    """One step of the exactly discretised filter, ``x`` updated in place from the standard
    normal draws ``z`` (one per state): the noise ``w = L z`` (``exact.array_matmul``), then
    row by row ``x'_i = (w_i + sum_{j<i} Phi_ij x_j) + Phi_ii x_i`` with the old state, the
    sum over the non-zero ``Phi_ij`` in order -- ``DrydenProcess.generate``'s recursion, whose
    ``lfilter`` adds ``Phi_ii x_i`` last.  ``scratch`` (n,)."""
    phi, noise, flags = dryden[0], dryden[2], dryden[4]
    n = x.shape[0]
    for i in range(n):
        f = _matvec_row(noise, flags[1], i, z)
        for j in range(i):
            if phi[i, j] != 0.0:
                f += phi[i, j] * x[j]
        scratch[i] = f + phi[i, i] * x[i]
    for i in range(n):
        x[i] = scratch[i]


@njit(cache=True)
def dryden_initial(dryden, z: np.ndarray, x: np.ndarray) -> None:
    """A state drawn from the stationary distribution, ``x = L_P z`` (``DrydenProcess.reset``)."""
    root, flags = dryden[3], dryden[4]
    for i in range(x.shape[0]):
        x[i] = _matvec_row(root, flags[2], i, z)


@njit(cache=True)
def air_from_motion(r, v0: float, v1: float, v2: float, w0: float, w1: float, w2: float, wind):
    """``R^T (v - v_wind)``, ``R^T (omega - omega_gust)`` (``air.air_velocity``): the body's
    velocity through the air from ground-frame velocities; ``r`` row-major body to ground."""
    r0, r1, r2, r3, r4, r5, r6, r7, r8 = r
    wx, wy, wz, gp, gq, gr = wind
    lx, ly, lz, ax, ay, az = v0 - wx, v1 - wy, v2 - wz, w0 - gp, w1 - gq, w2 - gr
    return (
        r0 * lx + r3 * ly + r6 * lz,
        r1 * lx + r4 * ly + r7 * lz,
        r2 * lx + r5 * ly + r8 * lz,
        r0 * ax + r3 * ay + r6 * az,
        r1 * ax + r4 * ay + r7 * az,
        r2 * ax + r5 * ay + r8 * az,
    )


@njit(cache=True)
def air_from_body(r, b0: float, b1: float, b2: float, c0: float, c1: float, c2: float, wind):
    """``v_body - R^T v_wind``, ``omega_body - R^T omega_gust`` (``air.air_velocity_from_body``):
    the velocity through the air from body-frame velocities (a control tick's state read)."""
    r0, r1, r2, r3, r4, r5, r6, r7, r8 = r
    wx, wy, wz, gp, gq, gr = wind
    return (
        b0 - (r0 * wx + r3 * wy + r6 * wz),
        b1 - (r1 * wx + r4 * wy + r7 * wz),
        b2 - (r2 * wx + r5 * wy + r8 * wz),
        c0 - (r0 * gp + r3 * gq + r6 * gr),
        c1 - (r1 * gp + r4 * gq + r7 * gr),
        c2 - (r2 * gp + r5 * gq + r8 * gr),
    )


@njit(cache=True)
def ground_effect_ratio(height: float, radius: float, min_height: float) -> float:
    """``1 / (1 - (R / 4z)^2)`` with ``z`` clamped to at least ``min_height R``
    (``rotors.ground_effect_ratio``)."""
    z = min_height * radius if min_height * radius > height else height  # Python's max(height, ...)
    x = radius / (4.0 * z)
    return 1.0 / (1.0 - x * x)


@njit(cache=True)
def ground_effect_ratios(
    z: float, r6: float, r7: float, r8: float, rotors: np.ndarray, min_height: float, out: np.ndarray
) -> None:
    """Per motor the ground-effect ratio at its hub height ``z + r6 px + r7 py + r8 pz`` into
    ``out`` (n,) (1 without a radius; ``RotorInteractions.ground_effect_ratios``): the
    ``thrust_ratio`` the modelled motors take (``ModelledMotors.step``), where the static
    motors take :func:`ground_effect_columns`."""
    for m in range(rotors.shape[0]):
        px, py, pz, radius = rotors[m, 0], rotors[m, 1], rotors[m, 2], rotors[m, 3]
        out[m] = ground_effect_ratio(z + r6 * px + r7 * py + r8 * pz, radius, min_height) if radius != 0.0 else 1.0


@njit(cache=True)
def ground_effect_columns(
    z: float,
    r6: float,
    r7: float,
    r8: float,
    rotors: np.ndarray,
    columns: np.ndarray,
    min_height: float,
    out: np.ndarray,
) -> None:
    """The motor wrench columns in ground effect into ``out`` (n, 6): per motor the ratio
    ``k`` at its hub height ``z + r6 px + r7 py + r8 pz`` (1 without a radius;
    ``RotorInteractions.ground_effect_ratios``), then ``Motors._scaled_columns``: the force
    and its moment times ``k``, the reaction torque ``rho F`` (``rho`` the reaction per
    newton) left alone.  ``rotors`` (n, 5): hub position, prop radius (0: none), ``rho``."""
    for m in range(columns.shape[0]):
        px, py, pz, radius, rho = rotors[m, 0], rotors[m, 1], rotors[m, 2], rotors[m, 3], rotors[m, 4]
        k = ground_effect_ratio(z + r6 * px + r7 * py + r8 * pz, radius, min_height) if radius != 0.0 else 1.0
        fx, fy, fz = columns[m, 0], columns[m, 1], columns[m, 2]
        rx, ry, rz = rho * fx, rho * fy, rho * fz
        out[m, 0], out[m, 1], out[m, 2] = k * fx, k * fy, k * fz
        out[m, 3] = k * (columns[m, 3] - rx) + rx
        out[m, 4] = k * (columns[m, 4] - ry) + ry
        out[m, 5] = k * (columns[m, 5] - rz) + rz
