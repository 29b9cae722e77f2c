"""Windy episodes in MCAP: the wind channel and arrow, the resolved config, exact re-simulation."""

from __future__ import annotations

import json
import warnings

import gymnasium
import numpy as np
import pytest
from typer.testing import CliRunner

import pyflyt_engine.envs  # noqa: F401  (registers the ids)
from pyflyt_cli.main import app
from pyflyt_engine.telemetry import RecordEpisode, load_episode, read_mcap, schemas
from pyflyt_engine.telemetry.replay import verify

runner = CliRunner()


def _record(directory, env_id: str, wind, episodes: int = 2, steps: int = 45):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = RecordEpisode(gymnasium.make(env_id, wind=wind), directory)
    rng = np.random.default_rng(0)
    for episode in range(episodes):
        env.reset(seed=3 if episode == 0 else None)  # the second continues the RNG streams
        for _ in range(steps):
            action = env.action_space.sample() if "Fixedwing" in env_id else np.array([0.0, 0.0, 0.0, 0.13])
            if "Fixedwing" not in env_id:
                action[:3] = 0.1 * rng.standard_normal(3)
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                break
    env.close()
    return env.paths


@pytest.mark.parametrize(
    "env_id,wind",
    [
        ("PyFlyt/QuadX-Hover-v0", "dryden_moderate"),
        ("PyFlyt/Fixedwing-Waypoints-v0", {"preset": "gust", "gust": {"start": 0.2}}),
    ],
)
def test_windy_episodes_record_the_wind_and_verify_exactly(tmp_path, env_id, wind):
    paths = _record(tmp_path, env_id, wind)
    for path in paths:
        episode = load_episode(path)
        recorded_wind = json.loads(episode.env_info["wind"])
        assert recorded_wind["turbulence" if wind == "dryden_moderate" else "gust"] is not None
        track = episode.vehicles[0]
        assert track.wind.shape == (len(track.time), 6)
        assert np.abs(track.wind[:, :3]).max() > 0.1  # the wind was felt and recorded
        result = verify(episode, tolerance=0.0)
        assert result.ok and result.max_deviation == 0.0 and result.per_field["wind"] == 0.0, result
        assert result.max_reward_deviation == 0.0
    # the scene carries one wind arrow per vehicle
    contents = read_mcap(paths[0])
    arrows = [
        e for m in contents.messages if m.topic == "/scene" for e in m.data["entities"] if e["id"] == "uav_0/wind"
    ]
    assert arrows and any(e["arrows"] for e in arrows)
    jsonschema = pytest.importorskip("jsonschema")
    winds = [m.data for m in contents.messages if m.topic == "/uav/0/wind"]
    assert len(winds) == len(load_episode(paths[0]).vehicles[0].time)
    for message in winds[:5]:
        jsonschema.validate(message, schemas.WIND)
    for entity in arrows[:5]:
        jsonschema.validate({"deletions": [], "entities": [entity]}, schemas.SCENE_UPDATE)
    result = runner.invoke(app, ["replay", str(paths[1]), "--verify", "--tolerance", "0"])
    assert result.exit_code == 0 and "verify    OK" in result.output, result.output


def test_verify_uses_the_recorded_wind_not_the_preset_name(tmp_path):
    """A windy file re-simulated without its wind would not verify: the wind matters."""
    path = _record(tmp_path, "PyFlyt/QuadX-Hover-v0", "dryden_moderate", episodes=1)[0]
    episode = load_episode(path)
    assert verify(episode, tolerance=0.0).ok
    episode.env_info["wind"] = json.dumps({"name": "calm"})
    result = verify(episode, tolerance=1e-6)
    assert not result.ok and result.max_deviation > 1e-3


def test_calm_episodes_have_no_wind_channel(tmp_path):
    path = _record(tmp_path, "PyFlyt/QuadX-Hover-v0", "calm", episodes=1, steps=5)[0]
    topics = {m.topic for m in read_mcap(path).messages}
    assert not any(t.endswith("/wind") for t in topics)
    assert load_episode(path).vehicles[0].wind.shape == (0, 6)
