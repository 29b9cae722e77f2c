"""Dryden continuous turbulence, low-altitude form (MIL-F-8785C, section 3.7, "Atmospheric disturbances"; MIL-HDBK-1797).

Scales and intensities at height ``h`` (in feet, 10 ft <= h <= 1000 ft) from the wind
speed ``W20`` measured 20 ft above the ground (MIL-F-8785C, low-altitude turbulence)::

    L_w = h                 L_u = L_v = h / (0.177 + 0.000823 h)^1.2
    sigma_w = 0.1 W20       sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h)^0.4

Below 10 ft the 10 ft values are used (the model's lower bound, as in MIL-HDBK-1797's
low-altitude model).  Shaping filters (MIL-F-8785C, Dryden forms) driven by
white noise, for the turbulence carried past at speed ``V`` (Taylor's frozen field)::

    H_u(s) = sigma_u sqrt(2 L_u / (pi V))                    / (1 + (L_u/V) s)
    H_v(s) = sigma_v sqrt(L_v / (pi V))   (1 + sqrt(3) (L_v/V) s) / (1 + (L_v/V) s)^2
    H_w(s) = sigma_w sqrt(L_w / (pi V))   (1 + sqrt(3) (L_w/V) s) / (1 + (L_w/V) s)^2
    H_p(s) = sigma_w sqrt(0.8 / V) (pi / (4 b))^(1/6) / (L_w^(1/3) (1 + (4 b / (pi V)) s))
    H_q(s) =  (s / V) / (1 + (4 b / (pi V)) s) H_w(s)
    H_r(s) = -(s / V) / (1 + (3 b / (pi V)) s) H_v(s)

``b`` is the span of the vehicle feeling the rotary gusts.  With these gains the one-
sided spectra ``Phi(omega) = |H(j omega)|^2`` [(m/s)^2 / (rad/s)] integrate to the
variances (``int_0^inf Phi_u d omega = sigma_u^2``) when the white noise has the
two-sided intensity ``pi``: ``E[n(t) n(t')] = pi delta(t - t')``.

Discretisation is exact: the filters are one linear system ``x' = A x + B n``; over a
step ``dt`` the state moves as ``x[k+1] = Phi x[k] + w[k]`` with ``Phi = exp(A dt)``
and ``w[k] ~ N(0, Q_d)``, ``Q_d = int_0^dt exp(A t) B pi B^T exp(A^T t) dt`` (Van Loan,
"Computing integrals involving the matrix exponential", IEEE TAC 23(3), 1978), so the
samples have exactly the covariance of the continuous process at the sample instants,
whatever ``dt``.  The initial state is drawn from the stationary distribution (the
solution ``P`` of ``A P + P A^T + B pi B^T = 0``): no start-up transient.

Because ``A`` is lower triangular in the state order used here, the recursion is solved
a row at a time for a whole block of steps with :func:`scipy.signal.lfilter` (C loops):
a physics step then costs a list lookup.

No step goes through BLAS or LAPACK, whose last bits depend on the CPU
(:mod:`pyflyt_engine.exact`): the exponential is :func:`~pyflyt_engine.exact.expm`, the
stationary covariance solves the Lyapunov equation by substitution (``A`` is
triangular), the noise is shaped by a Cholesky factor
(:func:`~pyflyt_engine.exact.covariance_root`) and the matrix products of a block are
sums of element-wise products (:func:`~pyflyt_engine.exact.array_matmul`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pyflyt_engine import exact

FOOT = 0.3048  # [m], exact (international foot)
#: lower bound of the low-altitude model [ft] (MIL-HDBK-1797, low-altitude turbulence)
MIN_HEIGHT_FT = 10.0
#: upper bound of the low-altitude model [ft] (MIL-F-8785C: the low-altitude model applies below 1000 ft)
MAX_HEIGHT_FT = 1000.0
SQRT3 = math.sqrt(3.0)
NOISE_INTENSITY = math.pi  # two-sided white-noise intensity matching the one-sided spectra


@dataclass(frozen=True)
class DrydenScales:
    """Length scales [m] and intensities [m/s] at one height (MIL-F-8785C low altitude)."""

    L_u: float
    L_v: float
    L_w: float
    sigma_u: float
    sigma_v: float
    sigma_w: float


def low_altitude_scales(height: float, wind_speed_20ft: float) -> DrydenScales:
    """Scales and intensities at ``height`` [m] for the wind speed at 20 ft ``W20`` [m/s].

    ``height`` is clamped to the model's range [10 ft, 1000 ft] (3.05 m to 304.8 m).
    """
    h = min(max(float(height) / FOOT, MIN_HEIGHT_FT), MAX_HEIGHT_FT)  # [ft]; a Python float: ** is libm's pow
    base = 0.177 + 0.000823 * h
    L_uv = h / base**1.2 * FOOT
    sigma_w = 0.1 * wind_speed_20ft
    sigma_uv = sigma_w / base**0.4
    return DrydenScales(L_uv, L_uv, h * FOOT, sigma_uv, sigma_uv, sigma_w)


def spectrum(component: str, omega: np.ndarray, scales: DrydenScales, airspeed: float, span: float = 1.0) -> np.ndarray:
    """The specified one-sided PSD ``Phi(omega)`` [(m/s)^2/(rad/s) or (rad/s)^2/(rad/s)] of a
    component ``u, v, w, p, q, r`` at angular frequencies ``omega`` [rad/s] (the oracle of the tests
    and the plots; MIL-F-8785C with ``Omega = omega / V``)."""
    V = airspeed
    s = scales
    w = np.asarray(omega, dtype=float)

    def lateral(sigma: float, L: float) -> np.ndarray:
        x = (L * w / V) ** 2
        return sigma**2 * L / (math.pi * V) * (1 + 3 * x) / (1 + x) ** 2

    if component == "u":
        return s.sigma_u**2 * 2 * s.L_u / (math.pi * V) / (1 + (s.L_u * w / V) ** 2)
    if component == "v":
        return lateral(s.sigma_v, s.L_v)
    if component == "w":
        return lateral(s.sigma_w, s.L_w)
    if component == "p":
        return (
            s.sigma_w**2
            / (s.L_w * V)
            * 0.8
            * (math.pi * s.L_w / (4 * span)) ** (1 / 3)
            / (1 + (4 * span * w / (math.pi * V)) ** 2)
        )
    if component == "q":
        return (w / V) ** 2 / (1 + (4 * span * w / (math.pi * V)) ** 2) * lateral(s.sigma_w, s.L_w)
    if component == "r":
        return (w / V) ** 2 / (1 + (3 * span * w / (math.pi * V)) ** 2) * lateral(s.sigma_v, s.L_v)
    raise ValueError(f"unknown Dryden component {component!r}: use u, v, w, p, q or r")


class DrydenProcess:
    """Linear and rotary Dryden gusts for any number of spans, exactly discretised.

    State order (lower-triangular ``A``): ``u``; ``v2, v1``; ``w2, w1``; then per span
    ``p, q, r`` filter states.  Outputs per step: ``(u, v, w)`` [m/s] in the turbulence
    axes (x along the mean wind, y to its left, z up) and per span ``(p, q, r)`` [rad/s].

    Args:
        scales: :func:`low_altitude_scales`.
        airspeed: speed ``V`` [m/s] at which the frozen field passes (> 0).
        spans: span ``b`` [m] per vehicle (> 0); empty: linear gusts only.
        dt: sample interval [s].
        rng: the generator of the white noise and of the stationary initial state.
        block: steps generated per call of the vectorised recursion.
    """

    def __init__(
        self,
        scales: DrydenScales,
        airspeed: float,
        spans: Sequence[float],
        dt: float,
        rng: np.random.Generator,
        block: int = 240,
    ) -> None:
        # imported here, not with the module: scipy.signal takes ~2 s to import, and only an
        # atmosphere with turbulence needs it
        from scipy.signal import lfilter

        self._lfilter = lfilter
        self.scales, self.airspeed, self.spans, self.dt, self.block = scales, airspeed, tuple(spans), dt, block
        self.rng = rng
        A, B, C = self._system()
        n = A.shape[0]
        G = exact.array_matmul(B, B.T) * NOISE_INTENSITY
        # Van Loan: expm([[-A, G], [0, A^T]] dt) = [[., Phi^-1 Q_d], [0, Phi^T]]
        E = exact.expm(np.block([[-A, G], [np.zeros((n, n)), A.T]]) * dt)
        self.Phi = E[n:, n:].T.copy()
        Qd = exact.array_matmul(self.Phi, E[:n, n:])
        self.Qd = 0.5 * (Qd + Qd.T)
        self.P = _stationary_covariance(A, G)
        self.C = C
        self._noise_root = exact.covariance_root(self.Qd)
        self._state_root = exact.covariance_root(self.P)
        self._diag = np.diag(self.Phi).copy()
        self._lower = [np.flatnonzero(self.Phi[i, :i]).tolist() for i in range(n)]  # dependencies of each row
        self.state = np.zeros(n)
        self.reset()

    def _system(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        s, V = self.scales, self.airspeed
        m = len(self.spans)
        n = 5 + 3 * m
        A = np.zeros((n, n))
        B = np.zeros((n, 3 + m))
        C = np.zeros((3 + 3 * m, n))
        Tu, Tv, Tw = s.L_u / V, s.L_v / V, s.L_w / V
        A[0, 0], B[0, 0] = -1 / Tu, 1 / Tu
        C[0, 0] = s.sigma_u * math.sqrt(2 * s.L_u / (math.pi * V))
        for row, T, sigma, L, col in ((1, Tv, s.sigma_v, s.L_v, 1), (3, Tw, s.sigma_w, s.L_w, 2)):
            # x2 = n / (1 + T s); x1 = x2 / (1 + T s); y = K ((1 - sqrt3) x1 + sqrt3 x2)
            A[row, row], B[row, col] = -1 / T, 1 / T
            A[row + 1, row + 1], A[row + 1, row] = -1 / T, 1 / T
            K = sigma * math.sqrt(L / (math.pi * V))
            C[col, row + 1], C[col, row] = K * (1 - SQRT3), K * SQRT3
        for j, b in enumerate(self.spans):
            ip, iq, ir = 5 + 3 * j, 6 + 3 * j, 7 + 3 * j
            Tp, Tq, Tr = 4 * b / (math.pi * V), 4 * b / (math.pi * V), 3 * b / (math.pi * V)
            A[ip, ip], B[ip, 3 + j] = -1 / Tp, 1 / Tp
            C[3 + 3 * j, ip] = s.sigma_w * math.sqrt(0.8 / V) * (math.pi / (4 * b)) ** (1 / 6) / s.L_w ** (1 / 3)
            # z = y / (1 + T s);  (s / V) z = (y - z) / (V T)
            A[iq, iq] = -1 / Tq
            A[iq, :5] += C[2, :5] / Tq
            C[4 + 3 * j, :5] = C[2, :5] / (V * Tq)
            C[4 + 3 * j, iq] = -1 / (V * Tq)
            A[ir, ir] = -1 / Tr
            A[ir, :5] += C[1, :5] / Tr
            C[5 + 3 * j, :5] = -C[1, :5] / (V * Tr)
            C[5 + 3 * j, ir] = 1 / (V * Tr)
        return A, B, C

    def reset(self) -> None:
        """A fresh realisation: the state drawn from the stationary distribution."""
        self.state = exact.array_matmul(self._state_root, self.rng.standard_normal((self.state.size, 1)))[:, 0]

    def generate(self, steps: int | None = None) -> np.ndarray:
        """(outputs, steps) samples: the current state's output first; the state moves on ``steps``."""
        N = self.block if steps is None else steps
        W = exact.array_matmul(self._noise_root, self.rng.standard_normal((self.state.size, N)))
        X = np.empty((self.state.size, N + 1))
        X[:, 0] = self.state
        for i in range(self.state.size):
            f = W[i].copy()
            for j in self._lower[i]:
                f += self.Phi[i, j] * X[j, :N]
            a = self._diag[i]
            X[i, 1:] = self._lfilter([1.0], [1.0, -a], f, zi=[a * X[i, 0]])[0]
        self.state = X[:, N].copy()
        return exact.array_matmul(self.C, X[:, :N])


def _stationary_covariance(A: np.ndarray, G: np.ndarray) -> np.ndarray:
    """The solution ``P`` of ``A P + P A^T + G = 0`` for a lower-triangular stable ``A``.

    Entry (i, j) of the equation is ``(a_ii + a_jj) p_ij + sum_{k<i} a_ik p_kj +
    sum_{k<j} a_jk p_ik + g_ij = 0``, so the entries follow one another row by row
    (forward substitution; the Bartels-Stewart method with ``A`` already triangular),
    each sum by :func:`math.fsum`.
    """
    n = A.shape[0]
    a = A.tolist()
    g = G.tolist()
    lower = [[(k, a[i][k]) for k in range(i) if a[i][k] != 0.0] for i in range(n)]
    p = [[0.0] * n for _ in range(n)]
    for i in range(n):
        for j in range(i + 1):
            terms = [g[i][j]]
            terms += [a_ik * p[k][j] for k, a_ik in lower[i]]
            terms += [a_jk * p[i][k] for k, a_jk in lower[j]]
            p[i][j] = p[j][i] = -math.fsum(terms) / (a[i][i] + a[j][j])
    return np.array(p)
