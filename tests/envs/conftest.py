"""Fixtures for the environment tests: envs that are always closed."""

from __future__ import annotations

import warnings

import gymnasium
import pytest

import pyflyt_engine  # noqa: F401  (registers the ids)
from pyflyt_engine.envs import ENVS

ENV_IDS = list(ENVS)


@pytest.fixture
def make():
    """``make(env_id, **kwargs)`` -> the unwrapped env; closed after the test."""
    made = []

    def _make(env_id: str, **kwargs):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            env = gymnasium.make(env_id, **kwargs).unwrapped
        made.append(env)
        return env

    yield _make
    for env in made:
        env.close()
