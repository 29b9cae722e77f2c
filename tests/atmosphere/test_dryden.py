"""Dryden turbulence against its specification: scales, variances, spectra, exact sampling."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy import signal

from pyflyt_engine.atmosphere.dryden import FOOT, DrydenProcess, low_altitude_scales, spectrum

W20 = 15 * 0.514444  # light turbulence, 15 kt (MIL-F-8785C low-altitude "light")


def test_low_altitude_scales_match_the_formulas_evaluated_by_hand():
    # h = 100 ft: 0.177 + 0.0823 = 0.2593; L_u = 100 / 0.2593^1.2; sigma_u = sigma_w / 0.2593^0.4
    s = low_altitude_scales(100 * FOOT, 10.0)
    assert s.L_w == pytest.approx(100 * FOOT)
    assert s.L_u == pytest.approx(100 / 0.2593**1.2 * FOOT) and s.L_v == s.L_u
    assert s.L_u / FOOT == pytest.approx(505.4, rel=1e-3)  # 100 / 0.19786
    assert s.sigma_w == pytest.approx(1.0)
    assert s.sigma_u == pytest.approx(1 / 0.2593**0.4) and s.sigma_v == s.sigma_u
    # below the model's 10 ft floor the 10 ft values hold; above 1000 ft, the 1000 ft ones
    assert low_altitude_scales(0.5, 10.0) == low_altitude_scales(10 * FOOT, 10.0)
    assert low_altitude_scales(1000.0, 10.0) == low_altitude_scales(1000 * FOOT, 10.0)


@pytest.fixture(scope="module")
def realisation():
    scales = low_altitude_scales(10.0, W20)
    dt = 1 / 240
    process = DrydenProcess(scales, W20, [0.12], dt, np.random.default_rng(7), block=8192)
    samples = np.hstack([process.generate() for _ in range(100)])  # 819 200 steps = 57 min
    return scales, dt, process, samples


def test_stationary_variance_is_the_specified_intensity(realisation):
    scales, _, process, _ = realisation
    C, P = process.C, process.P
    # exact: the state covariance of the continuous filters gives sigma^2 on the linear gusts
    assert C[0] @ P @ C[0] == pytest.approx(scales.sigma_u**2, rel=1e-9)
    assert C[1] @ P @ C[1] == pytest.approx(scales.sigma_v**2, rel=1e-9)
    assert C[2] @ P @ C[2] == pytest.approx(scales.sigma_w**2, rel=1e-9)
    # and each output's variance is the integral of its specified spectrum
    omega = np.concatenate([np.linspace(0, 50, 200_001), np.geomspace(50.0001, 1e7, 200_001)])
    for row, name in enumerate("uvwpqr"):
        integral = np.trapezoid(spectrum(name, omega, scales, W20, 0.12), omega)
        assert C[row] @ P @ C[row] == pytest.approx(integral, rel=2e-3), name


def test_sample_variance_matches_the_intensity_within_sampling_error():
    """Exact sampling keeps the variance at any step, so a 1 s step gives a long record cheaply."""
    scales = low_altitude_scales(10.0, W20)
    dt, steps = 1.0, 200_000
    process = DrydenProcess(scales, W20, [], dt, np.random.default_rng(11), block=steps)
    y = process.generate()
    for row, sigma, L in (
        (0, scales.sigma_u, scales.L_u),
        (1, scales.sigma_v, scales.L_v),
        (2, scales.sigma_w, scales.L_w),
    ):
        # about T / (2 L / V) independent samples in a record of length T (at least one per
        # step): the standard error of a variance estimate is sigma^2 sqrt(2 / n)
        n_independent = min(steps, steps * dt / (2 * L / W20))
        assert np.var(y[row]) == pytest.approx(sigma**2, rel=4 * math.sqrt(2 / n_independent)), "uvw"[row]


def _aliased(name: str, f: np.ndarray, fs: float, scales, span: float) -> np.ndarray:
    """The one-sided PSD per hertz of the exactly sampled process: the specified spectrum
    folded about the sampling rate: the two-sided density pi Phi(2 pi |f|) summed over the
    aliases f + k fs, doubled, S(f) = 2 pi sum_k Phi(2 pi |f + k fs|))."""
    total = np.zeros_like(f)
    for k in range(-200, 201):
        total += 2 * np.pi * spectrum(name, 2 * np.pi * np.abs(f + k * fs), scales, W20, span)
    return total


@pytest.mark.parametrize("row,name", [(0, "u"), (1, "v"), (2, "w"), (3, "p"), (4, "q"), (5, "r")])
def test_welch_psd_matches_the_specified_spectrum(realisation, row, name):
    scales, dt, _, y = realisation
    nperseg = 8192
    f, psd = signal.welch(y[row], fs=1 / dt, nperseg=nperseg)
    expected = _aliased(name, f, 1 / dt, scales, 0.12)
    segments = 2 * y.shape[1] // nperseg - 1  # Hann window, 50 % overlap
    # octave-wide groups of bins from 0.2 Hz (below, too few bins) to 51.2 Hz: each
    # group's mean ratio is 1 within 4 standard errors (about segments * bins / 2
    # independent chi-square(2) values: overlap and the window correlate neighbours)
    edges = 0.2 * 2.0 ** np.arange(0, 9)
    for lo, hi in itertools.pairwise(edges):
        pick = (f >= lo) & (f < hi)
        stderr = 1 / math.sqrt(segments * pick.sum() / 2)
        assert (psd[pick] / expected[pick]).mean() == pytest.approx(1.0, abs=max(4 * stderr, 0.02)), (name, lo, hi)


def test_sampling_is_exact_lag_one_correlation_of_u(realisation):
    """u is a first-order process: corr(u[k], u[k+1]) = exp(-V dt / L_u), whatever dt."""
    scales, dt, process, _ = realisation
    assert process.Phi[0, 0] == pytest.approx(math.exp(-W20 * dt / scales.L_u), rel=1e-12)
    coarse = DrydenProcess(scales, W20, [], 0.5, np.random.default_rng(1), block=4096)
    u = np.hstack([coarse.generate() for _ in range(20)])[0]
    rho = np.corrcoef(u[:-1], u[1:])[0, 1]
    assert rho == pytest.approx(math.exp(-W20 * 0.5 / scales.L_u), abs=0.02)
    assert np.var(u) == pytest.approx(scales.sigma_u**2, rel=0.1)  # no variance lost to a coarse step


def test_same_generator_same_realisation_and_blocks_do_not_matter():
    scales = low_altitude_scales(10.0, W20)
    a = DrydenProcess(scales, W20, [0.1], 1 / 240, np.random.default_rng(3), block=100)
    b = DrydenProcess(scales, W20, [0.1], 1 / 240, np.random.default_rng(3), block=100)
    c = DrydenProcess(scales, W20, [0.1], 1 / 240, np.random.default_rng(4), block=100)
    ya, yb, yc = a.generate(), b.generate(), c.generate()
    assert np.array_equal(ya, yb) and not np.allclose(ya, yc)
    assert ya.shape == (6, 100)
