"""Per-step work does not grow with the number of resets.

Not timed: after 10 resets and after 500 more, every registered env holds the same
PyBullet bodies, constraints and saved states, the same tracked contact bodies, and
(within a small allowance for interpreter caches) the same number of Python objects;
resident memory stays flat.  A leak here -- a saveState per reset, a body per episode,
a growing list -- would make long training runs slower and larger over time.
"""

from __future__ import annotations

import gc
import warnings

import gymnasium
import pybullet as p
import pytest

import pyflyt_engine  # noqa: F401  (registers the ids)
from pyflyt_cli.speed.protocols import rss_mb
from pyflyt_engine.envs import ENVS
from tests.conftest import default_subset
from pyflyt_engine.world import VehicleConfig, World


def live_saved_states(client: int) -> int:
    """Saved states PyBullet holds: state ids are allocated lowest-free-first."""
    probe = p.saveState(physicsClientId=client)
    p.removeState(probe, physicsClientId=client)
    return probe


def footprint(env: gymnasium.Env) -> dict:
    world = env.unwrapped.world
    cid = world.client
    return {
        "bodies": p.getNumBodies(physicsClientId=cid),
        "constraints": p.getNumConstraints(physicsClientId=cid),
        "saved_states": live_saved_states(cid),
        "vehicles": len(world.vehicles),
        "tracked_bodies": len(world.contact_bodies),
    }


def cycle(env: gymnasium.Env, resets: int, seed0: int) -> None:
    for i in range(resets):
        env.reset(seed=seed0 + i if i % 2 else None)
        for _ in range(3):
            _, _, terminated, truncated, _ = env.step(env.action_space.sample())
            if terminated or truncated:
                break


@pytest.mark.parametrize("env_id", default_subset(ENVS, lambda e: e == "PyFlyt/QuadX-Hover-v0"))
def test_env_state_is_the_same_after_10_and_510_resets(env_id):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = gymnasium.make(env_id)
    env.action_space.seed(0)
    cycle(env, 10, seed0=0)
    before = footprint(env)
    gc.collect()
    objects_before = len(gc.get_objects())
    cycle(env, 500, seed0=100)
    after = footprint(env)
    gc.collect()
    objects_after = len(gc.get_objects())
    env.close()
    assert after == before
    assert before["saved_states"] == 1  # the one snapshot every reset restores
    assert objects_after - objects_before < 200, (
        f"{objects_after - objects_before} Python objects more after 500 resets"
    )


def test_adding_a_body_replaces_the_snapshot_instead_of_keeping_both():
    world = World([VehicleConfig("quadx_cf2x", (0.0, 0.0, 1.0))], seed=0)
    world.reset()
    assert live_saved_states(world.client) == 1
    for k in range(3):
        world.add_vehicle("quadx_cf2x", (2.0 + k, 0.0, 1.0))
        assert live_saved_states(world.client) == 0
        world.reset()
        assert live_saved_states(world.client) == 1
    world.close()


def test_resident_memory_is_flat_over_many_resets():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = gymnasium.make("PyFlyt/QuadX-Hover-v0")
    env.action_space.seed(0)
    cycle(env, 200, seed0=0)
    gc.collect()
    before = rss_mb()
    for i in range(3000):
        env.reset(seed=i)
    gc.collect()
    growth = rss_mb() - before
    env.close()
    assert growth < 8.0, f"resident memory grew {growth:.1f} MB over 3000 resets"
