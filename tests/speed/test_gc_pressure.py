"""Stepping an env leaves (almost) no container objects for Python's cyclic GC.

Not timed.  The garbage collector runs when the count of live container objects
(lists, dicts, tuples, ...) grows, and a full collection walks every such object in the
process: after ``import stable_baselines3`` (an SB3 ``SubprocVecEnv`` worker) that is
~200 000 objects and ~0.1 s, a stall both workers of a vector env wait for.  Buffers held
across steps must therefore not be built from one container per element: the motor and
booster noise blocks (1 024 rows each) were once lists of lists and triggered a full
collection every ~1 500 steps.  Here every registered env runs 1 000 steps with resets,
with the collector off, and may keep only a handful of the containers it allocated.
"""

from __future__ import annotations

import gc
import warnings

import gymnasium
import pytest

import pyflyt_engine  # noqa: F401  (registers the ids)
from pyflyt_engine.envs import ENVS
from tests.conftest import default_subset

#: containers an env may keep alive after 1 000 steps (state read-outs, iterators, ...)
ALLOWED = 100


@pytest.mark.parametrize("env_id", default_subset(ENVS, lambda e: e == "PyFlyt/QuadX-Hover-v0"))
def test_steps_leave_few_tracked_objects(env_id):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = gymnasium.make(env_id)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(1_200)]

    def run(batch):
        for action in batch:
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()

    run(actions[:200])  # first noise blocks, caches
    enabled = gc.isenabled()
    gc.disable()
    try:
        gc.collect()
        gc.freeze()  # everything alive now is out of the count
        run(actions[200:])
        gc.collect(1)  # the young survivors (and untracking of atomic tuples) into the oldest generation
        kept = gc.get_objects(generation=2)
        assert len(kept) < ALLOWED, sorted({type(o).__name__ for o in kept})
    finally:
        gc.unfreeze()
        if enabled:
            gc.enable()
        env.close()
