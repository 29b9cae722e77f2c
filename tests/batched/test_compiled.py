"""How the batched backend compiles: NumPy's error model, the physics step's switches, and
the contact check's early out (kernels.lowest_reach), which must never miss a contact."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pyflyt_engine.batched import kernels
from pyflyt_engine.batched.compiled import njit
from pyflyt_engine.batched.model import batched_model
from pyflyt_engine.spec import load_uav_spec

from tests.batched.test_laws import CONTROL_DT, DT, FLOWN


@njit
def _divided(a, b):
    return a / b


def test_the_decorator_compiles_with_numpys_error_model():
    # Python's model would raise ZeroDivisionError here
    assert _divided(1.0, 0.0) == math.inf
    assert math.isnan(_divided(0.0, 0.0))
    assert _divided(1.0, 4.0) == 0.25


def test_an_explicit_error_model_is_kept():
    strict = njit(error_model="python")(_divided.py_func)
    with pytest.raises(ZeroDivisionError):
        strict(1.0, 0.0)


def test_switches_are_true_or_none():
    assert kernels.switch(True) is True and kernels.switch(False) is None
    wind = np.zeros((4, 20))
    assert kernels.wind_on(wind) is None
    wind[2, 0] = 1.0
    assert kernels.wind_on(wind) is True
    wind[2, 0] = np.nan  # not off: tested per env as before
    assert kernels.wind_on(wind) is True


def _unit_quaternions(rng: np.random.Generator, count: int) -> np.ndarray:
    q = rng.standard_normal((count, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    # and the attitudes that put a feature straight down: upright, inverted, on each side
    s = math.sqrt(0.5)
    fixed = np.array([[0, 0, 0, 1], [1, 0, 0, 0], [0, 1, 0, 0], [s, 0, 0, s], [0, s, 0, s], [-s, 0, 0, s]])
    return np.vstack([q, fixed])


def _corners_of_every_kind(rng: np.random.Generator) -> np.ndarray:
    """(1, 12, 8) features: points, spheres and discs at random places with random normals."""
    c = np.zeros((1, 12, 8))
    c[0, :, :3] = rng.uniform(-0.4, 0.4, (12, 3))
    c[0, 4:8, 3] = rng.uniform(0.0, 0.1, 4)  # spheres' radii
    c[0, 8:, 4] = rng.uniform(0.0, 0.2, 4)  # discs' radii
    normal = rng.standard_normal((4, 3))
    c[0, 8:, 5:] = normal / np.linalg.norm(normal, axis=1, keepdims=True)
    return c


@pytest.mark.parametrize("name", FLOWN)
def test_no_feature_reaches_the_ground_from_above_the_reach(name):
    corners = batched_model(load_uav_spec(name), DT, CONTROL_DT).corners[np.newaxis]
    _check_reach(corners, np.random.default_rng(0))


def test_no_feature_of_any_kind_reaches_the_ground_from_above_the_reach():
    rng = np.random.default_rng(1)
    for _ in range(20):
        _check_reach(_corners_of_every_kind(rng), rng)


def _check_reach(corners: np.ndarray, rng: np.random.Generator) -> None:
    reach = kernels.lowest_reach(corners, 0)
    r = np.empty(9)
    lowest = math.inf  # the lowest feature over every attitude, the centre at height 0
    for qx, qy, qz, qw in _unit_quaternions(rng, 2000):
        kernels.rotation_rows(qx, qy, qz, qw, r)
        just_above = math.nextafter(reach, math.inf)
        assert kernels.lowest_row(just_above, r[6], r[7], r[8], corners, 0) >= 0.0
        lowest = min(lowest, kernels.lowest_row(0.0, r[6], r[7], r[8], corners, 0))
    # and the reach is not loose: some attitude brings a feature within 15 % of it
    assert -lowest <= reach and -lowest >= 0.85 * reach


def test_feature_reaches_are_each_vehicles_lowest_reach():
    rng = np.random.default_rng(3)
    corners = rng.normal(size=(9, 8, 8))
    reaches = kernels.feature_reaches(corners)
    assert reaches.shape == (9,)
    assert [float(r) for r in reaches] == [kernels.lowest_reach(corners, v) for v in range(9)]
