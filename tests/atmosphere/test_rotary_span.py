"""Rotary Dryden gusts and the vehicle's span (docs/atmosphere.md, "Rotary gusts and small vehicles").

Oracle: the p-gust spectrum of MIL-F-8785C,
``Phi_p = sigma_w^2 (0.8 / V) (pi / 4b)^(1/3) / (L_w^(2/3) (1 + (4 b w / (pi V))^2))``,
integrates over 0 < w < inf (``int dw / (1 + (a w)^2) = pi / (2 a)``, ``a = 4b / (pi V)``) to

    sigma_p^2 = sigma_w^2 * 0.8 pi^2 / 8 * (pi/4)^(1/3) / (b^(4/3) L_w^(2/3))

independent of V, growing without bound as b -> 0.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pyflyt_engine.atmosphere.config import load_wind_config
from pyflyt_engine.atmosphere.dryden import DrydenProcess, low_altitude_scales
from pyflyt_engine.world import VehicleConfig, World

CF2X_SPAN = 0.056  # [m] twice its 0.028 m motor reach (vehicle_span)


def sigma_p(sigma_w: float, L_w: float, b: float) -> float:
    return math.sqrt(sigma_w**2 * 0.8 * math.pi**2 / 8 * (math.pi / 4) ** (1 / 3) / (b ** (4 / 3) * L_w ** (2 / 3)))


@pytest.mark.parametrize(("preset", "expected"), [("dryden_light", 2.3), ("dryden_moderate", 4.7)])
def test_the_cf2x_would_see_the_documented_rotary_rms(preset, expected):
    turbulence = load_wind_config(preset).turbulence
    scales = low_altitude_scales(turbulence.height, turbulence.wind_speed_20ft)
    analytic = sigma_p(scales.sigma_w, scales.L_w, CF2X_SPAN)
    assert analytic == pytest.approx(expected, abs=0.05)
    # the filter's stationary variance of p (C P C^T) is the spectrum's integral
    process = DrydenProcess(scales, turbulence.advection_speed, [CF2X_SPAN], 1 / 240, np.random.default_rng(0))
    p_row = process.C[3]
    variance = float(sum(p_row[i] * process.P[i, j] * p_row[j] for i in range(p_row.size) for j in range(p_row.size)))
    assert math.sqrt(variance) == pytest.approx(analytic, rel=1e-9)
    # and as b^(-2/3): a 1 m span sees (0.056)^(2/3) = 0.146 of it
    assert sigma_p(scales.sigma_w, scales.L_w, 1.0) == pytest.approx(analytic * CF2X_SPAN ** (2 / 3), rel=1e-12)


def _rotary_rms(uav: str, wind) -> float:
    world = World([VehicleConfig(uav, (0.0, 0.0, 10.0))], seed=0, wind=wind)
    field = world.wind
    samples = []
    for _ in range(4800):  # 20 s
        samples.append(field.at(0, (0.0, 0.0, 10.0))[3])
        field.advance()
    world.close()
    return float(np.sqrt(np.mean(np.square(samples))))


def test_small_vehicles_get_no_rotary_gusts_by_default_and_can_opt_in():
    assert load_wind_config("dryden_light").turbulence.rotary_min_span == 1.0
    assert _rotary_rms("quadx_cf2x", "dryden_light") == 0.0  # 0.056 m < 1 m
    assert _rotary_rms("quadx_f450", "dryden_light") == 0.0  # 0.32 m
    forced = {"preset": "dryden_light", "turbulence": {"rotary_min_span": 0.0}}
    scales = low_altitude_scales(10.0, 7.716667)
    rms = _rotary_rms("quadx_cf2x", forced)
    # 20 s of a process with a 0.01 s time constant: the sample RMS within 10 % of sigma_p
    assert rms == pytest.approx(sigma_p(scales.sigma_w, scales.L_w, CF2X_SPAN), rel=0.1)


def test_aeroplane_spans_keep_their_rotary_gusts():
    scales = low_altitude_scales(10.0, 7.716667)
    rms = _rotary_rms("fixedwing", "dryden_light")  # span 2.4 m
    assert rms == pytest.approx(sigma_p(scales.sigma_w, scales.L_w, 2.4), rel=0.15)


def test_rotary_min_span_is_validated():
    from pyflyt_engine.errors import ConfigError

    with pytest.raises(ConfigError, match="rotary_min_span"):
        load_wind_config({"preset": "dryden_light", "turbulence": {"rotary_min_span": -1.0}})
