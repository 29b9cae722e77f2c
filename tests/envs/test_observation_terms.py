"""The observation terms and reset events an env binds come from its config's own sections, and
nothing else: the episode core runs what is bound (the golden trajectories hold the numbers)."""

from __future__ import annotations

import numpy as np
import pytest

from pyflyt_engine.envs.env import UAVEnv
from pyflyt_engine.envs.events import RESET_EVENTS
from pyflyt_engine.envs.observe import OBSERVATION_TERMS

SENSORS = {"imu": {"gyro": {"noise_density": 1e-3}}, "position": {"noise_std": [0.01, 0.01, 0.01]}}


def _bound(name, **overrides):
    env = UAVEnv(name, **overrides)
    try:
        events = [event.name for event in env._parts.events]
        return env.observation.bound, events
    finally:
        env.close()


@pytest.mark.parametrize(
    ("name", "overrides", "observed", "events"),
    [
        ("quadx_hover", {}, (), []),
        ("quadx_hover", {"latency": {"observation_delay": 0.01}}, ("delayed_state",), []),
        ("quadx_hover", {"latency": {"action_delay": 0.01}}, (), []),  # only the action is late
        ("quadx_hover", {"sensors": {**SENSORS, "observe": True}}, ("sensor_state",), []),
        ("quadx_hover", {"sensors": {**SENSORS, "estimator": "complementary"}}, ("estimator_state",), []),
        ("quadx_hover", {"randomize": "moderate"}, (), ["randomize"]),
        ("quadx_gates", {}, ("camera_image",), ["place_payloads"]),
        ("quadx_obstacles", {}, ("range_readings",), ["obstacle_layouts"]),
        ("quadx_ball_in_cup", {}, (), ["place_payloads"]),
    ],
)
def test_what_is_bound_is_what_the_config_declares(name, overrides, observed, events):
    assert _bound(name, **overrides) == (observed, events)


def test_an_observation_delay_drawn_per_episode_binds_the_delayed_state_in_the_episodes_that_have_one():
    env = UAVEnv("quadx_hover", randomize={"observation_delay": {"distribution": "uniform", "low": 0.0, "high": 0.02}})
    try:
        seen = set()
        for seed in range(12):
            env.reset(seed=seed)
            delayed = env.latency_steps[1] > 0
            assert env.observation.bound == (("delayed_state",) if delayed else ()), seed
            seen.add(delayed)
        assert seen == {True, False}  # both kinds of episode were drawn
    finally:
        env.close()


def test_every_registered_term_and_event_says_what_it_does():
    for name, term in OBSERVATION_TERMS.items():
        assert term.slot in ("source", "view", "extra") and term.description, name
    for name, bind in RESET_EVENTS.items():
        assert (bind.__doc__ or "").strip(), name


def test_the_randomization_event_reports_the_draw_at_the_reset():
    env = UAVEnv("quadx_hover", randomize="moderate")
    try:
        _, info = env.reset(seed=3)
        assert info["randomization"] == env.last_randomization and set(info["randomization"]) == set(
            env.config.randomize
        )
        _, again = env.reset(seed=3)
        assert again["randomization"] == info["randomization"]
        assert np.isfinite(list(info["randomization"].values())).all()
    finally:
        env.close()
