"""The boosters' fuel mass properties (plain floats, at the control rate) against oracles:
the parallel-axis theorem by hand, and the array formula they replaced, bit for bit."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from pyflyt_engine.components.booster import Boosters, tank_inertia, tank_mass_properties
from pyflyt_engine.components.noise import NoiseSource
from tests.components.test_booster import DT, make_params


def _bits(values) -> list[int]:
    return [struct.unpack("<q", struct.pack("<d", float(v)))[0] for v in values]


def _array_formula(params, fuel: np.ndarray) -> tuple[float, list[float]]:
    """The fuel's mass and inertia diagonal about the origin, as arrays (the formula of
    ``Vehicle._update_mass`` before it ran on floats)."""
    fuel_mass, inertia = tank_mass_properties(params, fuel)
    r = params.fuel_tank_positions
    parallel = fuel_mass[:, None] * (np.sum(r * r, axis=1)[:, None] - r * r)
    return float(fuel_mass.sum()), (inertia + parallel).sum(axis=0).tolist()


def test_one_tank_by_the_parallel_axis_theorem():
    # full tank of 410.9 kg at (0, 0, 2) m: J = J_full + m (r^2 - r_i^2) = (1678 + 4 m, 1678 + 4 m, 7.01)
    params = make_params()
    boosters = Boosters(params, DT, NoiseSource(np.random.default_rng(0)), 1.0)
    mass, (jx, jy, jz) = boosters.fuel_mass_properties()
    assert mass == 410.9
    assert (jx, jy, jz) == pytest.approx((1678.0 + 4.0 * 410.9, 1678.0 + 4.0 * 410.9, 7.01), rel=1e-15)


def test_empty_tanks_add_nothing():
    params = make_params(n=2)
    boosters = Boosters(params, DT, NoiseSource(np.random.default_rng(0)), 0.0)
    assert boosters.fuel_mass_properties() == (0.0, (0.0, 0.0, 0.0))


@pytest.mark.parametrize("n", [1, 2, 3, 5, 7])
def test_equals_the_array_formula_bit_for_bit(n):
    rng = np.random.default_rng(n)
    for _ in range(200):
        params = make_params(
            n=n,
            fuel_tank_positions=rng.normal(0.0, 2.0, (n, 3)),
            total_fuel=rng.uniform(1.0, 500.0, n),
            inertia_full=rng.uniform(0.0, 2000.0, (n, 3)),
        )
        boosters = Boosters(params, DT, NoiseSource(np.random.default_rng(0)), 1.0)
        boosters.fuel = (rng.uniform(0.0, 1.0, n) * params.total_fuel).tolist()
        mass, inertia = boosters.fuel_mass_properties()
        want_mass, want_inertia = _array_formula(params, np.array(boosters.fuel))
        assert _bits([mass, *inertia]) == _bits([want_mass, *want_inertia])


def test_tank_inertia_is_linear_in_fuel():
    assert tank_inertia(0.0, 10.0, (1.0, 2.0, 3.0)) == (0.0, 0.0, 0.0)
    assert tank_inertia(5.0, 10.0, (1.0, 2.0, 3.0)) == (0.5, 1.0, 1.5)
    assert tank_inertia(10.0, 10.0, (1.0, 2.0, 3.0)) == (1.0, 2.0, 3.0)
