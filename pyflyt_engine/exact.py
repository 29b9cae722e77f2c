"""Arithmetic whose results do not depend on the CPU: the engine's linear algebra.

Same seed and same config give bit-identical trajectories on any x86-64 CPU with AVX2
(``docs/reproducibility.md``).  Two libraries under NumPy would break that, because they
choose their code by CPU at run time:

* **OpenBLAS** (``@``, ``np.dot``, ``np.linalg``, ``scipy.linalg``; also
  ``np.linalg.norm`` of a vector) has kernels per CPU family, which sum in other orders
  and fuse multiply-adds differently: the last bits of a product change;
* **NumPy's own SIMD loops** for ``np.sin``, ``np.exp``, ``np.arccos``, ``np.tanh``,
  ``np.power`` ... (SVML on AVX-512 machines, other vector code on AVX2 ones) round
  differently from each other and from the C library.

A flight is chaotic: a last-bit difference becomes another trajectory within seconds.
So everything that decides a simulated number -- at set-up (airframe to parameters,
mixer, turbulence filters, spawn and task geometry) and at every step (loads, control,
wind, observations, rewards) -- is computed from Python floats, Python's :mod:`math`
(glibc's libm, which gives the same results on every AVX2 x86-64 CPU), and NumPy's
element-wise ``+ - * /``, ``sqrt``, ``abs``, ``minimum``/``maximum`` and sums, which
are IEEE-exact wherever they run.  This module holds what that needs beyond them:

* per step: 3-vectors and 3 x 3 rotations written out, in a fixed order
  (:func:`rotate`, :func:`rotate_t`, :func:`rows_rotate_t`, :func:`norm`, :func:`cross`);
* at set-up: small dense algebra with dot products summed by :func:`math.fsum`:
  :func:`dot`, :func:`matmul`, :func:`inverse` (Gauss-Jordan), :func:`pinv`, :func:`rank`,
  :func:`eigvalsh3`; and on NumPy arrays with element-wise operations only:
  :func:`array_matmul`, :func:`expm`, :func:`covariance_root`;
* :func:`apply`: a :mod:`math` function over an array.

Results equal NumPy's and LAPACK's up to rounding, not bit for bit.
``tests/engine/test_numeric_kernels.py`` checks that nothing on the simulated path calls
the CPU-dependent functions, and that trajectories stay bit-identical under other
CPUs' kernels.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

Vec3 = tuple[float, float, float]
Matrix = list[list[float]]
# what the functions below take: Python sequences or NumPy arrays (read element by element)
VectorLike = Sequence[float] | np.ndarray
MatrixLike = Sequence[Sequence[float]] | np.ndarray

# --------------------------------------------------------------------- per step


def rotate(m: MatrixLike, v: VectorLike) -> Vec3:
    """``m v`` for a 3 x 3 matrix ``m`` (rows) and a 3-vector ``v``."""
    (a, b, c), (d, e, f), (g, h, i) = m
    x, y, z = v
    return (a * x + b * y + c * z, d * x + e * y + f * z, g * x + h * y + i * z)


def rotate_t(m: MatrixLike, v: VectorLike) -> Vec3:
    """``m^T v``: with ``m`` a body-to-ground rotation, ``v`` turned into the body frame."""
    (a, b, c), (d, e, f), (g, h, i) = m
    x, y, z = v
    return (a * x + d * y + g * z, b * x + e * y + h * z, c * x + f * y + i * z)


def rows_rotate_t(
    vectors: MatrixLike,
    m: MatrixLike,
    origin: VectorLike = (0.0, 0.0, 0.0),
) -> np.ndarray:
    """``(vectors - origin) @ m`` for ``n`` row 3-vectors: each row ``v`` becomes
    ``m^T (v - origin)`` (with ``m`` a body-to-ground rotation and ``origin`` the body's
    position, ground-frame points in the body frame); an ``(n, 3)`` array."""
    rows = vectors.tolist() if isinstance(vectors, np.ndarray) else vectors
    (a, b, c), (d, e, f), (g, h, i) = m
    px, py, pz = origin
    out = []
    for x, y, z in rows:
        x, y, z = x - px, y - py, z - pz
        out.append((a * x + d * y + g * z, b * x + e * y + h * z, c * x + f * y + i * z))
    return np.array(out, dtype=np.float64).reshape(-1, 3)


def cross(u: VectorLike, v: VectorLike) -> Vec3:
    """``u x v`` of two 3-vectors."""
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


def norm(v: VectorLike) -> float:
    """Euclidean length of a vector: :func:`math.hypot` (CPython's own accurate algorithm on
    plain doubles, the same on every CPU)."""
    return math.hypot(*(float(x) for x in v))


def apply(function: Callable[[float], float], values: VectorLike | float) -> np.ndarray:
    """``function`` (e.g. :func:`math.cos`) on every element: float64 array of the shape of ``values``."""
    arr = np.asarray(values, dtype=np.float64)
    return np.array([function(x) for x in arr.ravel().tolist()], dtype=np.float64).reshape(arr.shape)


# ---------------------------------------------------------------------- set-up


def dot(u: VectorLike, v: VectorLike) -> float:
    """Dot product: :func:`math.fsum` of the rounded products (their sum correctly rounded,
    whatever the order)."""
    return math.fsum(float(a) * float(b) for a, b in zip(u, v, strict=True))


def _rows(m: MatrixLike) -> Matrix:
    if isinstance(m, np.ndarray):
        return np.asarray(m, dtype=np.float64).tolist()
    return [[float(x) for x in row] for row in m]


def transpose(m: MatrixLike) -> Matrix:
    """The transpose, as lists."""
    return [list(col) for col in zip(*_rows(m))]


def matmul(a: MatrixLike, b: MatrixLike) -> Matrix:
    """``a b`` for small matrices, every entry a :func:`dot`; lists of rows."""
    cols = transpose(b)
    return [[dot(row, col) for col in cols] for row in _rows(a)]


def inverse(m: MatrixLike) -> Matrix:
    """Inverse of a small square matrix: Gauss-Jordan elimination with partial pivoting.

    Raises:
        ValueError: the matrix is singular (a zero pivot).
    """
    rows = _rows(m)
    n = len(rows)
    aug = [row + [1.0 if i == j else 0.0 for j in range(n)] for i, row in enumerate(rows)]
    for col in range(n):
        pivot = max(range(col, n), key=lambda r: abs(aug[r][col]))
        if aug[pivot][col] == 0.0:
            raise ValueError("singular matrix")
        aug[col], aug[pivot] = aug[pivot], aug[col]
        p = aug[col][col]
        aug[col] = [x / p for x in aug[col]]
        for r in range(n):
            factor = aug[r][col]
            if r != col and factor != 0.0:
                aug[r] = [x - factor * y for x, y in zip(aug[r], aug[col])]
    return [row[n:] for row in aug]


def pinv(m: MatrixLike) -> Matrix:
    """Moore-Penrose pseudo-inverse of a matrix of full row rank: ``A^T (A A^T)^-1``.

    The rows are first scaled by powers of two to about unit length (exact), which keeps
    ``A A^T`` well conditioned when the rows have very different scales (thrust per newton
    against yaw torque per newton); ``pinv(D A) D = pinv(A)`` for a diagonal ``D``.
    """
    rows = _rows(m)
    scales = [2.0 ** -math.frexp(math.sqrt(math.fsum(x * x for x in row)) or 1.0)[1] for row in rows]
    scaled = [[s * x for x in row] for s, row in zip(scales, rows)]
    gram_inverse = inverse([[dot(r, q) for q in scaled] for r in scaled])
    out = matmul(transpose(scaled), gram_inverse)
    return [[x * s for x, s in zip(row, scales)] for row in out]


def rank(m: MatrixLike, tol: float) -> int:
    """Numerical rank: pivots above ``tol`` in Gaussian elimination with complete pivoting."""
    a = _rows(m)
    if not a or not a[0]:
        return 0
    n_rows, n_cols = len(a), len(a[0])
    r = 0
    for _ in range(min(n_rows, n_cols)):
        best, pi, pj = 0.0, -1, -1
        for i in range(r, n_rows):
            for j in range(r, n_cols):
                if abs(a[i][j]) > best:
                    best, pi, pj = abs(a[i][j]), i, j
        if best <= tol:
            break
        a[r], a[pi] = a[pi], a[r]
        for row in a:
            row[r], row[pj] = row[pj], row[r]
        p = a[r][r]
        for i in range(r + 1, n_rows):
            factor = a[i][r] / p
            if factor != 0.0:
                a[i] = [x - factor * y for x, y in zip(a[i], a[r])]
        r += 1
    return r


def eigvalsh3(m: MatrixLike) -> list[float]:
    """Eigenvalues of a symmetric 3 x 3 matrix, ascending (the trigonometric closed form,
    O. K. Smith, "Eigenvalues of a symmetric 3 x 3 matrix", Comm. ACM 4(4), 1961)."""
    (a, b, c), (_, d, e), (_, _, f) = _rows(m)
    off = b * b + c * c + e * e
    if off == 0.0:
        return sorted((a, d, f))
    q = (a + d + f) / 3.0
    p2 = (a - q) ** 2 + (d - q) ** 2 + (f - q) ** 2 + 2.0 * off
    p = math.sqrt(p2 / 6.0)
    ba, bd, bf, bb, bc, be = (a - q) / p, (d - q) / p, (f - q) / p, b / p, c / p, e / p
    half_det = 0.5 * (ba * (bd * bf - be * be) - bb * (bb * bf - be * bc) + bc * (bb * be - bd * bc))
    phi = math.acos(min(1.0, max(-1.0, half_det))) / 3.0
    largest = q + 2.0 * p * math.cos(phi)
    smallest = q + 2.0 * p * math.cos(phi + 2.0 * math.pi / 3.0)
    return sorted((smallest, 3.0 * q - largest - smallest, largest))


def array_matmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` by element-wise operations only: entry (i, j) is the sum over k, in order,
    of the rounded products ``a[i, k] b[k, j]`` -- the same bits on every CPU.  For the
    turbulence filters (tens of states; blocks of thousands of steps)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    out = np.zeros((a.shape[0], b.shape[1]))
    for k in range(a.shape[1]):
        column = a[:, k : k + 1]
        if column.any():
            out += column * b[k : k + 1, :]
    return out


#: Taylor terms of :func:`expm` after scaling the norm below 1/2: the remainder,
#: below 0.5^19 / 19!, is far under one rounding
_EXPM_TERMS = 18


def expm(a: np.ndarray) -> np.ndarray:
    """Matrix exponential: scaling by a power of two to an infinity norm <= 1/2, the Taylor
    series (Horner form, :data:`_EXPM_TERMS` terms), then squaring back; every product by
    :func:`array_matmul`."""
    a = np.asarray(a, dtype=np.float64)
    n = a.shape[0]
    size = max((math.fsum(abs(x) for x in row) for row in a.tolist()), default=0.0)
    squarings = max(0, math.frexp(size)[1] + 1) if size > 0.0 else 0  # size / 2^s <= 1/2
    x = a * 2.0**-squarings
    identity = np.eye(n)
    out = identity.copy()
    for k in range(_EXPM_TERMS, 0, -1):
        out = identity + array_matmul(x, out) / k
    for _ in range(squarings):
        out = array_matmul(out, out)
    return out


def covariance_root(covariance: np.ndarray, rel_tol: float = 1e-12) -> np.ndarray:
    """A lower-triangular ``L`` with ``L L^T = covariance`` for a symmetric positive
    semi-definite matrix: Cholesky's algorithm, a column left zero where the remaining
    pivot is below ``rel_tol`` times its diagonal entry (a direction without variance, e.g.
    two identical filters driven by the same noise) or negative from rounding."""
    a = np.array(covariance, dtype=np.float64)
    n = a.shape[0]
    diagonal = np.diag(a).copy()
    root = np.zeros((n, n))
    for j in range(n):
        pivot = float(a[j, j])
        if not pivot > rel_tol * float(diagonal[j]):
            continue
        column = a[j:, j] / math.sqrt(pivot)
        root[j:, j] = column
        rest = column[1:]
        a[j + 1 :, j + 1 :] -= rest[:, None] * rest[None, :]
    return root
