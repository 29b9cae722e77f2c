"""A vehicle's physics is the same whatever batch it is stepped in.

``kernels.advance`` steps the vehicles block by block, each physics step of a span for the
whole block before the next (so that the processor overlaps independent vehicles' steps),
and vehicle by vehicle where a turbulence filter exists.  Its numbers must not depend on
that order: here each vehicle of a batch larger than a block, advanced alone (its rows of
every per-vehicle array), ends in the same state bit for bit as in the whole batch.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyflyt_engine.batched import kernels, normals
from pyflyt_engine.batched.env import BatchedUAVEnv
from pyflyt_engine.envs.config import load_env_config

#: more vehicles than a block holds, and not a multiple of it
N = 2 * kernels._BLOCK + 37


def _advance_call(wind: str | None) -> list:
    """The arguments of the next ``kernels.advance`` call of QuadX-Hover after a few steps of
    random actions (every vehicle in its own state), its motor noise drawn."""
    cfg = load_env_config("quadx_hover")
    env = BatchedUAVEnv(cfg.with_overrides(wind=wind) if wind else cfg, num_envs=N, seed=1)
    env.reset(seed=1)
    rng = np.random.default_rng(2)
    for _ in range(4):
        env.step(rng.uniform(-0.4, 0.4, size=(N, env._low.size)))
    normals.noise_factors(env.noise_rng, env._noise_ratio, env._noise_buffer)
    start = int(env.physics_steps[0]) % env.per_control
    env._normals = env.turbulence_normals()
    return list(
        env._advance_args(env.actions, env._noise_buffer, start, env.per_agent, *env._span(start, env.per_agent))
    )


def _rows(value, i: int):
    """Vehicle ``i``'s rows of a per-vehicle array (leading axis N), or of each in a tuple."""
    if isinstance(value, np.ndarray) and value.ndim and value.shape[0] == N:
        return np.array(value[i : i + 1])
    if isinstance(value, tuple):
        return tuple(_rows(v, i) for v in value)
    return value


@pytest.mark.parametrize("wind", [None, "constant", "dryden_moderate"])
def test_each_vehicle_alone_ends_where_it_ends_in_the_batch(wind):
    call = _advance_call(wind)
    assert (call[-1] is None) == (wind is None)  # the calm air compiled as calm, the wind as wind
    alone = [[_rows(a, i) for a in call] for i in range(N)]
    kernels.advance(*call)
    for i, args in enumerate(alone):
        kernels.advance(*args)
        for k in (0, 1, 2, 3, 4, 5, 6, 7, 27, 39):  # state, motors, rate loop, contact, turbulence
            np.testing.assert_array_equal(args[k][0], call[k][i], err_msg=f"vehicle {i}, argument {k}")
    pos = call[0]
    assert np.unique(pos[:, 2]).size == N  # the vehicles were in states of their own
