"""Standard normal draws in compiled code: the same numbers as ``Generator.standard_normal``.

The batched backend draws its noise (the motors', the sensors', the range sensors') from
numpy generators inside compiled loops, through each bit generator's ``ctypes`` interface
(``next_uint64`` and ``next_double``, which numpy exposes for compiled callers, as
:func:`pyflyt_engine.batched.bookkeeping.spawn_rows` draws its uniforms), called by their
addresses (:func:`interface`, :data:`next_uint64_at`, :data:`next_double_at`).
:func:`standard_normal` is numpy's sampler (``random_standard_normal`` in numpy's
``random/src/distributions/distributions.c``): the 256-layer ziggurat of Marsaglia and Tsang
("The ziggurat method for generating random variables", J. Stat. Softw. 5(8), 2000), with
numpy's tables, which numba ships for its own generator:

* one 64-bit word: its low 8 bits pick the layer ``i``, the next bit the sign, the next 52
  bits the magnitude ``u``; ``x = u * WI[i]`` (negated by the sign) is the draw when
  ``u < KI[i]`` (99.3 % of words);
* otherwise, in the base layer (``i = 0``), the tail beyond ``R``: ``a = -log1p(-U1) / R``,
  ``b = -log1p(-U2)`` until ``2 b > a^2``; the draw is ``R + a``, negative when bit 8 of
  ``u`` is set;
* otherwise, in layer ``i``: ``x`` is the draw when ``(FI[i - 1] - FI[i]) U + FI[i] <
  exp(-x^2 / 2)``, else a new word.

The stream advances exactly as ``standard_normal`` advances it, so a generator's state
(and a checkpoint of it) is the same either way.  ``tests/batched/test_normals.py`` holds
the draws and the generator's state afterwards equal to ``standard_normal``'s, bit for
bit, over millions of draws, the tail included.

Why the motors' noise is drawn here and not by ``Generator.standard_normal(out=...)``: a
quadrotor's step draws 32 normals per env (4 motors, 8 physics steps); numpy's fill costs
~11 ns a draw on the 2-core AMD EPYC VM, a third of the physics' time, and the compiled
loop ~4 ns (:func:`noise_factors`, with the ``1 + ratio eta`` it also computes;
``python experiments/speed_normals.py``).
"""

from __future__ import annotations

import ctypes
from typing import Any
import math

import numpy as np
from llvmlite import ir  # type: ignore[import-untyped]
from numba import types
from numba.extending import intrinsic
from numba.np.random import _constants as _zig

from pyflyt_engine.batched.compiled import njit

# numpy's ziggurat tables and constants (numba's copy of them, the same values)
WI = np.ascontiguousarray(_zig.wi_double, dtype=np.float64)
KI = np.ascontiguousarray(_zig.ki_double, dtype=np.uint64)
FI = np.ascontiguousarray(_zig.fi_double, dtype=np.float64)
R = float(_zig.ziggurat_nor_r)
INV_R = float(_zig.ziggurat_nor_inv_r)
_LAYER = np.uint64(0xFF)
_MANTISSA = np.uint64(0x000FFFFFFFFFFFFF)
_ONE = np.uint64(1)
_EIGHT = np.uint64(8)


def _bit_generator_call(name: str, result: ir.Type, result_type: types.Type):
    """An intrinsic calling one of a bit generator's functions, ``result (*)(void *state)``, by
    the function's and the state's addresses (integers): what calling numpy's ``ctypes``
    function objects compiles to, without their typing on every call from Python (~1 us
    each: a step of a plain env passed two of them, ``experiments/speed_step_parts.py``)."""

    def typer(typingctx, function, state):
        if not (isinstance(function, types.Integer) and isinstance(state, types.Integer)):
            return None

        def codegen(context, builder, signature, args):
            pointer = ir.IntType(8).as_pointer()
            called = builder.inttoptr(args[0], ir.FunctionType(result, [pointer]).as_pointer())
            return builder.call(called, [builder.inttoptr(args[1], pointer)])

        return result_type(function, state), codegen

    typer.__name__ = typer.__qualname__ = name
    return intrinsic(typer)


#: ``next_uint64(state)`` of a bit generator (:func:`interface`'s addresses)
next_uint64_at = _bit_generator_call("next_uint64_at", ir.IntType(64), types.uint64)
#: ``next_double(state)`` of a bit generator (:func:`interface`'s addresses)
next_double_at = _bit_generator_call("next_double_at", ir.DoubleType(), types.float64)


@njit(cache=True, inline="always")
def standard_normal(state, next_uint64, next_double) -> float:
    """One ``Generator.standard_normal()`` from the bit generator at ``state`` (the module
    docstring); compiled into its caller, the rare words outside a layer's rectangle
    handled by :func:`_outside`."""
    while True:
        word = next_uint64_at(next_uint64, state)
        layer = word & _LAYER
        word = word >> _EIGHT
        u = (word >> _ONE) & _MANTISSA
        x = float(u) * WI[layer]
        if (word & _ONE) != 0:
            x = -x
        if u < KI[layer]:
            return x
        done, y = _outside(state, next_double, layer, u, x)
        if done:
            return y


@njit(cache=True)
def _outside(state, next_double, layer, u, x):
    """A word outside its layer's rectangle: (True, the draw) from the tail or under the
    density, or (False, x) when a new word is to be drawn."""
    if layer == 0:
        while True:
            a = -INV_R * math.log1p(-next_double_at(next_double, state))
            b = -math.log1p(-next_double_at(next_double, state))
            if b + b > a * a:
                return True, -(R + a) if ((u >> _EIGHT) & _ONE) != 0 else R + a
    if (FI[layer - _ONE] - FI[layer]) * next_double_at(next_double, state) + FI[layer] < math.exp(-0.5 * x * x):
        return True, x
    return False, x


@njit(cache=True)
def fill(state, next_uint64, next_double, out) -> None:
    """``out`` (C-contiguous) filled with standard normal draws in its memory order, as
    ``Generator.standard_normal(out=out)`` fills it."""
    flat = out.reshape(-1)
    for k in range(flat.shape[0]):
        flat[k] = standard_normal(state, next_uint64, next_double)


@njit(cache=True)
def fill_factors(state, next_uint64, next_double, ratio, out) -> None:
    """``out`` (..., n) C-contiguous: ``1 + ratio[m] * eta`` per motor ``m`` along the last
    axis, ``eta`` the standard normal draws in ``out``'s memory order: the motors'
    multiplicative noise, ``eta * ratio`` then ``+ 1`` as numpy's two passes round them."""
    n = ratio.shape[0]
    rows = out.reshape(-1, n)
    for k in range(rows.shape[0]):
        for m in range(n):
            rows[k, m] = standard_normal(state, next_uint64, next_double) * ratio[m] + 1.0


def address(function: Any) -> int:
    """The address of a ``ctypes`` function object (a bit generator's ``next_uint64``, ...)."""
    return int(ctypes.cast(function, ctypes.c_void_p).value or 0)


#: id of a bit generator -> (the bit generator, its :func:`interface`); the generator kept
#: alive while it is here, so that its id is not reused for another
_INTERFACES: dict[int, tuple] = {}
_KEPT = 256


def interface(rng: np.random.Generator) -> tuple[int, int, int]:
    """``(state, next_uint64, next_double)`` of ``rng``'s bit generator, as the compiled draws
    (:func:`fill`, :func:`fill_factors`) take them: the addresses of numpy's ctypes interface
    (its state and its two functions), looked up once per bit generator."""
    bits = rng.bit_generator
    kept = _INTERFACES.get(id(bits))
    if kept is not None and kept[0] is bits:
        return kept[1]
    c = bits.ctypes
    found = (int(c.state_address), address(c.next_uint64), address(c.next_double))
    if len(_INTERFACES) >= _KEPT:  # the oldest let go
        del _INTERFACES[next(iter(_INTERFACES))]
    _INTERFACES[id(bits)] = (bits, found)
    return found


def standard_normal_fill(rng: np.random.Generator, out: np.ndarray) -> np.ndarray:
    """``rng.standard_normal(out=out)``: the same numbers, and ``rng`` left in the same state."""
    if not (out.dtype == np.float64 and out.flags.c_contiguous):
        raise ValueError("standard_normal_fill takes a C-contiguous float64 array")
    state, next_uint64, next_double = interface(rng)
    fill(state, next_uint64, next_double, out)
    return out


def noise_factors(rng: np.random.Generator, ratio: np.ndarray, out: np.ndarray) -> np.ndarray:
    """``1 + ratio * rng.standard_normal(out=out)`` (``ratio`` (n,) along ``out``'s last axis)
    in one compiled pass, the same numbers as the numpy expression; returns ``out``."""
    if not (out.dtype == np.float64 and out.flags.c_contiguous and np.ndim(ratio) == 1 and out.shape[-1] == len(ratio)):
        raise ValueError(
            "noise_factors takes one noise ratio per motor (1-D) and a C-contiguous float64 array ending in the motors' axis"
        )
    state, next_uint64, next_double = interface(rng)
    fill_factors(state, next_uint64, next_double, np.ascontiguousarray(ratio, dtype=np.float64), out)
    return out
