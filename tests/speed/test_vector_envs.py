"""Every registered env runs in subprocess vector envs, deterministically under seeds.

``gymnasium.make_vec(id, n, vectorization_mode="async")`` and SB3's ``SubprocVecEnv``
with 2 workers, a few steps each, compared with the same envs stepped in this process
(``SyncVectorEnv`` / ``DummyVecEnv``) from the same seeds and actions: the workers must
produce bitwise the same observations and rewards.

Waypoint envs observe ``Dict(attitude, target_deltas: Sequence)``, whose size varies, so
Gymnasium's shared observation memory cannot hold it: pass
``vector_kwargs={"shared_memory": False}`` (or wrap with ``FlattenWaypointEnv``).  SB3
needs fixed-size observations: wrap those envs with ``FlattenWaypointEnv``.
"""

from __future__ import annotations

import functools
import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium import spaces

import pyflyt_engine  # noqa: F401  (registers the ids)
from pyflyt_engine.envs import ENVS, FlattenWaypointEnv
from tests.conftest import default_subset

#: kept in the default suite: a fixed-size and a variable-size observation
DEFAULT = ("PyFlyt/QuadX-Hover-v0", "PyFlyt/QuadX-Waypoints-v0")

STEPS = 5
SEED = 7


def variable_size(env_id: str) -> bool:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = gymnasium.make(env_id)
    space = env.observation_space
    env.close()
    return isinstance(space, spaces.Dict) and any(isinstance(s, spaces.Sequence) for s in space.spaces.values())


def actions_for(space: spaces.Space, n: int) -> list[np.ndarray]:
    space.seed(SEED)
    return [space.sample() for _ in range(n)]


def rollout_gymnasium(envs: gymnasium.vector.VectorEnv) -> list:
    obs, _ = envs.reset(seed=SEED)
    out = [obs]
    for action in actions_for(envs.action_space, STEPS):
        obs, reward, terminated, truncated, _ = envs.step(action)
        out += [obs, reward, terminated, truncated]
    envs.close()
    return out


def assert_same(a, b) -> None:
    if isinstance(a, dict):
        assert a.keys() == b.keys()
        for key in a:
            assert_same(a[key], b[key])
    elif isinstance(a, (tuple, list)) and not isinstance(a, np.ndarray):
        assert len(a) == len(b)
        for x, y in zip(a, b):
            assert_same(x, y)
    else:
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


@pytest.mark.parametrize("env_id", default_subset(ENVS, lambda e: e in DEFAULT))
def test_make_vec_async_matches_sync(env_id):
    kwargs = {"shared_memory": False} if variable_size(env_id) else {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        async_envs = gymnasium.make_vec(env_id, 2, vectorization_mode="async", vector_kwargs=kwargs)
        sync_envs = gymnasium.make_vec(env_id, 2, vectorization_mode="sync")
    assert async_envs.num_envs == 2
    got, expected = rollout_gymnasium(async_envs), rollout_gymnasium(sync_envs)
    assert_same(got, expected)
    # the two workers were seeded differently (seed, seed + 1): different first observations
    first = got[0]["attitude"] if isinstance(got[0], dict) else got[0]
    assert not np.array_equal(first[0], first[1])


def test_waypoint_env_flattened_uses_shared_memory():
    env_id = next(e for e in ENVS if variable_size(e))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        envs = gymnasium.make_vec(env_id, 2, vectorization_mode="async", wrappers=[FlattenWaypointEnv])
    obs, _ = envs.reset(seed=SEED)
    assert isinstance(obs, np.ndarray) and obs.shape == (2, *envs.single_observation_space.shape)
    for action in actions_for(envs.action_space, STEPS):
        obs, *_ = envs.step(action)
    assert np.isfinite(obs).all()
    envs.close()


def make_for_sb3(env_id: str, flatten: bool) -> gymnasium.Env:
    env = gymnasium.make(env_id)  # workers import this module, which registers the ids
    return FlattenWaypointEnv(env) if flatten else env


def rollout_sb3(vec_env) -> list:
    vec_env.seed(SEED)
    obs = vec_env.reset()
    out = [obs]
    for action in actions_for(vec_env.action_space, STEPS):
        obs, reward, done, _ = vec_env.step(np.stack([action, action]))
        out += [obs, np.float32(reward), done]  # DummyVecEnv stores rewards as float32
    vec_env.close()
    return out


@pytest.mark.parametrize("env_id", default_subset(ENVS, lambda e: e == "PyFlyt/QuadX-Hover-v0"))
def test_sb3_subproc_vec_env_matches_dummy(env_id):
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    factory = functools.partial(make_for_sb3, env_id, variable_size(env_id))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        subproc = SubprocVecEnv([factory, factory])
        dummy = DummyVecEnv([factory, factory])
    space = subproc.observation_space  # a Box, or a Dict of Boxes with a camera image
    assert isinstance(space, spaces.Box) or all(isinstance(s, spaces.Box) for s in space.spaces.values())
    got, expected = rollout_sb3(subproc), rollout_sb3(dummy)
    assert_same(got, expected)
    first = got[0]["attitude"] if isinstance(got[0], dict) else got[0]
    assert not np.array_equal(first[0], first[1])  # workers seeded SEED and SEED + 1
