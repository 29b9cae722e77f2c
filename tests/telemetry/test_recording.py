"""RecordEpisode: files open with the official reader, every message matches its schema,
recorded states are the env's states, and files are never overwritten."""

from __future__ import annotations

import base64
import io
import json
from collections import Counter
from pathlib import Path

import jsonschema
import numpy as np
import pytest
import yaml
from mcap.reader import make_reader
from PIL import Image

from pyflyt_engine.envs import UAVEnv
from pyflyt_engine.errors import TelemetryError
from pyflyt_engine.paths import uav_dir
from pyflyt_engine.telemetry import RecordEpisode, load_episode, read_mcap
from pyflyt_engine.telemetry._io import McapFileWriter
from pyflyt_engine.telemetry.episode import STATE_FIELDS
from tests.telemetry.conftest import ENV_IDS, hover_action, iter_official, make_env, record


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_recorded_states_equal_the_envs_states(env_id, tmp_path):
    env, seen = record(env_id, tmp_path, episodes=2, max_steps=60)
    assert [p.name for p in env.paths] == ["ep_0000.mcap", "ep_0001.mcap"]
    for path, states in zip(env.paths, seen):
        episode = load_episode(path)
        assert not episode.truncated
        track = episode.vehicles[0]
        assert len(track.time) == len(states)
        for k, per_vehicle in enumerate(states):
            state, aux = per_vehicle[0]
            for name in STATE_FIELDS:
                assert tuple(track.states[name][k]) == tuple(getattr(state, name)), (name, k)
            assert np.array_equal(track.aux[k], aux)
        # log time is simulation time: one agent period per step
        dt = 1.0 / episode.agent_hz
        assert np.allclose(np.diff(track.time), dt)
        assert track.time[0] == 0.0


def test_every_message_validates_against_its_declared_schema(recorded):
    for env_id, path in recorded.items():
        topics: Counter[str] = Counter()
        validators = {}
        for schema, channel, message in iter_official(path):  # CRCs validated
            assert schema.encoding == "jsonschema" and channel.message_encoding == "json"
            if schema.id not in validators:
                declared = json.loads(schema.data)
                jsonschema.Draft202012Validator.check_schema(declared)
                assert declared["title"] == schema.name
                validators[schema.id] = jsonschema.Draft202012Validator(declared)
            errors = list(validators[schema.id].iter_errors(json.loads(message.data)))
            assert not errors, f"{env_id} {channel.topic}: {errors[0].message}"
            topics[channel.topic] += 1
        steps = topics["/uav/0/action"]
        assert steps > 0
        assert topics["/uav/0/state"] == steps + 1
        # at the reset and every step, a frame per vehicle, per onboard camera (the airframe's and
        # an observation camera) and per payload of the env config
        from pyflyt_engine.envs import ENVS
        from pyflyt_engine.envs.config import load_env_config
        from pyflyt_engine.spec import load_uav_spec

        cfg = load_env_config(ENVS[env_id].config)
        cameras = len(load_uav_spec(cfg.uav).cameras) + (cfg.camera_observation is not None)
        frames = 1 + cameras + len(cfg.payloads)
        assert topics["/tf"] == frames * (steps + 1)
        assert topics["/reward"] == steps
        assert topics["/episode"] == 2
        assert topics["/scene"] >= 1


def test_schema_validation_catches_a_bad_message(recorded):
    """The check above can fail: a state with a missing field or a string position is rejected."""
    path = next(iter(recorded.values()))
    for schema, channel, message in iter_official(path):
        if channel.topic == "/uav/0/state":
            validator = jsonschema.Draft202012Validator(json.loads(schema.data))
            bad = json.loads(message.data)
            del bad["aux"]
            bad["lin_pos"][0] = "x"
            assert len(list(validator.iter_errors(bad))) == 2
            break


def test_metadata_holds_what_a_rebuild_needs(recorded):
    path = recorded["PyFlyt/QuadX-Hover-v0"]
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
        attachments = {a.name: a for a in reader.iter_attachments()}
        summary = reader.get_summary()
    assert meta["pyflyt"]["kind"] == "episode"
    config = json.loads(meta["env"]["config"])
    assert config["id"] == "PyFlyt/QuadX-Hover-v0" and config["agent_hz"] == 30
    assert json.loads(meta["env"]["reward_preset"])["terms"]
    assert json.loads(meta["env"]["uav_specs"])[0]["name"] == "quadx_cf2x"
    assert meta["env"]["gym_id"] == "PyFlyt/QuadX-Hover-v0"
    assert meta["episode"]["seed"] == "5"
    rng = json.loads(meta["episode"]["rng_state"])
    assert set(rng) == {"env", "world"}
    for key in ("python", "numpy", "pybullet", "gymnasium", "pyflyt_engine"):
        assert meta["versions"][key]
    assert attachments["uav_0.urdf"].data.startswith(b"<?xml")
    # without mesh obstacles, no mesh table and no mesh copy (such files are as they were before)
    assert "obstacle_meshes" not in meta["env"] and set(attachments) == {"uav_0.urdf"}
    assert summary.statistics.message_count > 0


def test_scene_shows_ground_airframe_and_waypoints(recorded):
    contents = read_mcap(recorded["PyFlyt/QuadX-Waypoints-v0"])
    updates = [m.data for m in contents.on("/scene")]
    first = {e["id"]: e for e in updates[0]["entities"]}
    assert {"ground", "uav_0/airframe"} <= set(first)
    airframe = first["uav_0/airframe"]
    assert airframe["frame_id"] == "uav_0" and airframe["frame_locked"] is True
    assert len(airframe["cubes"]) + len(airframe["cylinders"]) + len(airframe["spheres"]) >= 5  # body, arms, rotors
    waypoints = [e for u in updates for e in u["entities"] if e["id"] == "waypoints"]
    assert len(waypoints[0]["spheres"]) == 5
    tf = contents.on("/tf")[0].data
    assert tf["parent_frame_id"] == "world" and tf["child_frame_id"] == "uav_0"


def test_mid_episode_reset_and_close_are_marked_stopped(tmp_path):
    env = RecordEpisode(make_env("PyFlyt/QuadX-Hover-v0"), tmp_path)
    env.reset(seed=1)
    for _ in range(5):
        env.step(np.array([0.0, 0.0, 0.0, 0.13]))
    env.reset()
    env.step(np.array([0.0, 0.0, 0.0, 0.13]))
    env.close()
    for path, length in zip(env.paths, (5, 1)):
        end = load_episode(path).end
        assert end["event"] == "stopped" and end["reason"] == "stopped" and end["length"] == length


def test_never_overwrites_existing_files(tmp_path):
    (tmp_path / "ep_0000.mcap").write_bytes(b"precious")
    (tmp_path / "ep_0003.mcap").write_bytes(b"precious too")
    env = RecordEpisode(make_env("PyFlyt/QuadX-Hover-v0"), tmp_path)
    env.reset(seed=0)
    env.close()
    assert env.paths == [tmp_path / "ep_0004.mcap"]
    assert (tmp_path / "ep_0000.mcap").read_bytes() == b"precious"
    with pytest.raises(TelemetryError, match="already exists"):
        McapFileWriter(tmp_path / "ep_0003.mcap")
    assert (tmp_path / "ep_0003.mcap").read_bytes() == b"precious too"


def test_a_file_created_meanwhile_by_another_process_is_skipped_not_overwritten(tmp_path, monkeypatch):
    from pyflyt_engine.telemetry import recorder

    env = RecordEpisode(make_env("PyFlyt/QuadX-Hover-v0"), tmp_path)  # numbering starts at 0 here

    def racing_writer(path, **kwargs):  # another recorder takes ep_0000 between the check and the creation
        if path.name == "ep_0000.mcap":
            path.write_bytes(b"the other recording")
        return McapFileWriter(path, **kwargs)

    monkeypatch.setattr(recorder, "McapFileWriter", racing_writer)
    env.reset(seed=0)
    env.close()
    assert env.paths == [tmp_path / "ep_0001.mcap"] and load_episode(env.paths[0]).length == 0
    assert (tmp_path / "ep_0000.mcap").read_bytes() == b"the other recording"


def test_chunks_hold_about_one_simulated_second(tmp_path):
    env = RecordEpisode(make_env("PyFlyt/QuadX-Hover-v0", flight_dome_size=100.0), tmp_path)
    env.reset(seed=0)
    for _ in range(150):  # 5 s at 30 Hz
        *_, terminated, truncated, _ = env.step(hover_action(env.unwrapped.state))
        assert not (terminated or truncated)
    env.close()
    with open(env.paths[0], "rb") as f:
        summary = make_reader(f, validate_crcs=True).get_summary()
    spans = [(c.message_end_time - c.message_start_time) * 1e-9 for c in summary.chunk_indexes]
    assert 6 <= len(spans) <= 7  # the reset, then one per simulated second
    assert max(spans) <= 1.0 + 1e-6


def test_rejects_envs_that_are_not_pyflyt(tmp_path):
    import gymnasium

    with pytest.raises(TelemetryError, match="pyflyt environment"):
        RecordEpisode(gymnasium.make("CartPole-v1"), tmp_path)


def test_camera_images_are_recorded(tmp_path):
    spec = yaml.safe_load((uav_dir() / "quadx_cf2x.yaml").read_text())
    spec["name"] = "cf2x_cam"
    spec["cameras"] = [{"name": "front", "width": 32, "height": 24, "capture_hz": 15, "orientation_deg": [0, 20, 0]}]
    spec_path = tmp_path / "cf2x_cam.yaml"
    spec_path.write_text(yaml.safe_dump(spec))
    env = RecordEpisode(UAVEnv("quadx_hover", uav=str(spec_path)), tmp_path / "eps", cameras=True)
    env.reset(seed=0)
    for _ in range(10):
        env.step(np.array([0.0, 0.0, 0.0, 0.13]))
    env.close()
    contents = read_mcap(env.paths[0])
    images = contents.on("/uav/0/camera/0")
    assert len(images) == 6  # reset + 10 steps at 30 Hz, refreshed at 15 Hz
    for schema, channel, message in iter_official(env.paths[0]):
        jsonschema.validate(json.loads(message.data), json.loads(schema.data))
    picture = Image.open(io.BytesIO(base64.b64decode(images[0].data["data"])))
    assert picture.size == (32, 24) and images[0].data["format"] == "jpeg"
    frames = {m.data["child_frame_id"] for m in contents.on("/tf")}
    assert frames == {"uav_0", "uav_0/camera_0"}
    camera_tf = next(m.data for m in contents.on("/tf") if m.data["child_frame_id"] == "uav_0/camera_0")
    q = camera_tf["rotation"]  # pitched 20 deg down about body +y
    assert q["y"] == pytest.approx(np.sin(np.radians(20) / 2), abs=1e-9)


def test_recording_a_stopped_file_path_is_reported(tmp_path):
    env = RecordEpisode(make_env("PyFlyt/QuadX-Hover-v0"), tmp_path, prefix="run")
    env.reset(seed=0)
    assert env.recording == tmp_path / "run_0000.mcap"
    env.close()
    assert env.recording is None
    assert Path(env.paths[0]).exists()
