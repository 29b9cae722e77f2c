"""The compiled standard normal draws (:mod:`pyflyt_engine.batched.normals`) are numpy's.

Oracle: ``Generator.standard_normal`` of a generator seeded alike.  The draws must be equal
bit for bit and the generator left in the same state, over enough draws that the rare
branches run: a word outside its layer's rectangle (~0.7 %) and the tail beyond ``R``."""

from __future__ import annotations

import numpy as np
import pytest

from pyflyt_engine.batched import normals


@pytest.mark.parametrize("seed", [0, 1, 12345])
def test_the_draws_are_numpys_and_move_the_stream_as_numpy_does(seed):
    ours, theirs = np.random.default_rng(seed), np.random.default_rng(seed)
    out = normals.standard_normal_fill(ours, np.empty((500, 400)))
    expected = theirs.standard_normal((500, 400))
    assert np.array_equal(out.view(np.uint64), expected.view(np.uint64))
    assert ours.bit_generator.state == theirs.bit_generator.state
    assert np.sum(np.abs(expected) > normals.R) > 10  # the base layer's tail ran (~50 expected)
    # and the two go on alike afterwards, mixed with numpy's own draws
    assert ours.standard_normal() == theirs.standard_normal()
    assert normals.standard_normal_fill(ours, np.empty(7)).tolist() == theirs.standard_normal(7).tolist()


def test_the_motor_noise_factors_are_the_numpy_expression():
    """``1 + ratio * eta`` per motor, as the env computed it with numpy (draw, multiply, add)."""
    ratio = np.array([0.02, 0.1, 0.0, 1.0])
    ours, theirs = np.random.default_rng(3), np.random.default_rng(3)
    for shape in ((64, 8, 4), (1, 1, 4), (300, 2, 4)):
        got = normals.noise_factors(ours, ratio, np.empty(shape))
        eta = theirs.standard_normal(out=np.empty(shape))
        np.multiply(eta, ratio, out=eta)
        np.add(eta, 1.0, out=eta)
        assert np.array_equal(got.view(np.uint64), eta.view(np.uint64))
        assert ours.bit_generator.state == theirs.bit_generator.state
    assert np.all(got[..., 2] == 1.0)  # a motor without noise has factor 1 exactly


def test_any_numpy_bit_generator_is_drawn_from_alike():
    for bit_generator in (np.random.MT19937(5), np.random.SFC64(5), np.random.Philox(5)):
        ours = np.random.Generator(bit_generator)
        theirs = np.random.Generator(type(bit_generator)(5))
        assert np.array_equal(normals.standard_normal_fill(ours, np.empty(20_000)), theirs.standard_normal(20_000))


def test_a_wrong_buffer_is_refused_by_name():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="C-contiguous float64"):
        normals.standard_normal_fill(rng, np.empty(10, dtype=np.float32))
    with pytest.raises(ValueError, match="C-contiguous float64"):
        normals.standard_normal_fill(rng, np.empty((4, 6))[:, ::2])
    with pytest.raises(ValueError, match="motors' axis"):
        normals.noise_factors(rng, np.zeros(4), np.empty((3, 5)))
    with pytest.raises(ValueError, match="motors' axis"):  # one ratio per motor, not per env
        normals.noise_factors(rng, np.zeros((3, 4)), np.empty((3, 4)))
