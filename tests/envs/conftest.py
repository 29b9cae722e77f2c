"""Fixtures for the environment tests: envs that are always closed, and per-env facts.

Every registered id needs an :class:`EnvProfile` in :data:`PROFILES` (a test checks
this), so adding an environment means stating its documented layout and spawn here.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass

import gymnasium
import numpy as np
import pytest

import pyflyt_engine  # noqa: F401  (registers the ids)
from pyflyt_engine.envs import ENVS

ENV_IDS = list(ENVS)


@dataclass(frozen=True)
class EnvProfile:
    """What the env's manual documents, restated independently for the tests.

    Attributes:
        aux: size of the vehicle's auxiliary state in the attitude vector.
        extra: entries after the aux state (the landing task's pad contact flag).
        spawn_centre: mean spawn position [m].
        spawn_halfwidth: half-width of the uniform spawn noise per axis [m].
        neutral: an action that keeps the vehicle roughly as it is for a step.
        policy: random actions that keep the vehicle flying for a while.
    """

    aux: int
    extra: int
    spawn_centre: tuple[float, float, float]
    spawn_halfwidth: tuple[float, float, float]
    neutral: tuple[float, ...]
    policy: Callable[[np.random.Generator], np.ndarray]


def _quadx_policy(rng: np.random.Generator) -> np.ndarray:
    return np.array([*rng.uniform(-0.5, 0.5, 3), rng.uniform(0.1, 0.16)])


def _fixedwing_policy(rng: np.random.Generator) -> np.ndarray:
    return np.array([*rng.uniform(-0.3, 0.3, 3), rng.uniform(0.3, 0.7)])


def _rocket_policy(rng: np.random.Generator) -> np.ndarray:
    return np.array([*rng.uniform(-1, 1, 3), rng.uniform(0, 1), rng.uniform(0, 1), *rng.uniform(-1, 1, 2)])


def _rocket_velocity_policy(rng: np.random.Generator) -> np.ndarray:
    return np.array([*rng.uniform(-3, 3, 2), rng.uniform(-20, 5), rng.uniform(0, 1)])


def _rocket_descent_policy(rng: np.random.Generator) -> np.ndarray:
    return np.array([*rng.uniform(-3, 3, 2), rng.uniform(0, 1), rng.uniform(0, 1)])


def _motors_policy(rng: np.random.Generator) -> np.ndarray:
    # around the pole-carrying f450's hover throttle ((1.2 kg g / 40 N)^0.5 = 0.54)
    return 0.54 + rng.uniform(-0.03, 0.03, 4)


def _ball_in_cup_policy(rng: np.random.Generator) -> np.ndarray:
    # around the hover thrust of the f450 with cup and ball (1.16 kg g / 40 N = 0.28)
    return np.array([*rng.uniform(-0.3, 0.3, 3), rng.uniform(0.26, 0.31)])


PROFILES: dict[str, EnvProfile] = {
    "PyFlyt/QuadX-Hover-v0": EnvProfile(4, 0, (0.0, 0.0, 1.0), (0.1, 0.1, 0.1), (0.0, 0.0, 0.0, 0.125), _quadx_policy),
    "PyFlyt/QuadX-Waypoints-v0": EnvProfile(
        4, 0, (0.0, 0.0, 1.0), (0.1, 0.1, 0.1), (0.0, 0.0, 0.0, 0.125), _quadx_policy
    ),
    # motor throttle + 5 surfaces (main wing, ailerons, tails); spawn 20 x QuadX's
    "PyFlyt/Fixedwing-Waypoints-v0": EnvProfile(
        6, 0, (0.0, 0.0, 20.0), (2.0, 2.0, 2.0), (0.0, 0.0, 0.0, 0.45), _fixedwing_policy
    ),
    # 4 fins + booster (fuel, duty, ignition) + 2 gimbal angles; then the pad contact flag;
    # dropped from 450 m, +-20 m sideways
    "PyFlyt/Rocket-Landing-v0": EnvProfile(9, 1, (0.0, 0.0, 450.0), (20.0, 20.0, 0.0), (0.0,) * 7, _rocket_policy),
    # the same vehicle and task, flown by the velocity mode (ignition 0: free fall)
    "PyFlyt/Rocket-Landing-Velocity-v0": EnvProfile(
        9, 1, (0.0, 0.0, 450.0), (20.0, 20.0, 0.0), (0.0,) * 4, _rocket_velocity_policy
    ),
    # flown by the descent mode (ignition 0: free fall)
    "PyFlyt/Rocket-Landing-Descent-v0": EnvProfile(
        9, 1, (0.0, 0.0, 450.0), (20.0, 20.0, 0.0), (0.0,) * 4, _rocket_descent_policy
    ),
    # 4 motor throttles; then 12 pole values (tip, base positions and velocities, body frame)
    "PyFlyt/QuadX-Pole-Balance-v0": EnvProfile(4, 12, (0.0, 0.0, 1.0), (0.1, 0.1, 0.1), (0.54,) * 4, _motors_policy),
    "PyFlyt/QuadX-Pole-Waypoints-v0": EnvProfile(4, 12, (0.0, 0.0, 1.0), (0.1, 0.1, 0.1), (0.54,) * 4, _motors_policy),
    # 4 motor throttles; then the ball's relative position and velocity (body frame)
    "PyFlyt/QuadX-Ball-In-Cup-v0": EnvProfile(
        4, 6, (0.0, 0.0, 2.0), (0.1, 0.1, 0.1), (0.0, 0.0, 0.0, 0.28), _ball_in_cup_policy
    ),
    # the attitude vector as QuadX-Waypoints; the image and the gate deltas are separate keys
    "PyFlyt/QuadX-Gates-v0": EnvProfile(4, 0, (0.0, 0.0, 1.0), (0.1, 0.1, 0.1), (0.0, 0.0, 0.0, 0.125), _quadx_policy),
    # the attitude vector as QuadX-Waypoints; the goal vector and the LiDAR are separate keys;
    # spawn 4 m behind the forest
    "PyFlyt/QuadX-Obstacles-v0": EnvProfile(
        4, 0, (-4.0, 0.0, 1.0), (0.1, 0.1, 0.1), (0.0, 0.0, 0.0, 0.125), _quadx_policy
    ),
}


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
