"""`pyflyt replay`: summary, --verify (passes on every env, fails on an altered action),
--plot and --video; bad files exit 2 with a message and never a traceback."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
import yaml
from mcap.writer import Writer
from PIL import Image
from typer.testing import CliRunner

from pyflyt_cli.main import app
from pyflyt_engine.errors import TelemetryError
from pyflyt_engine.telemetry import CorruptRecordingWarning, MetricsWriter, load_episode, read_mcap
from pyflyt_engine.telemetry.replay import summarize, verify
from tests.telemetry.conftest import ENV_IDS, chunk_spans, flip_byte, record, rewrite_mcap

runner = CliRunner()


def replay(*args: str):
    result = runner.invoke(app, ["replay", *map(str, args)])
    assert "Traceback" not in result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_verify_passes_on_a_recorded_episode(env_id, recorded):
    result = replay(recorded[env_id], "--verify", "--tolerance", "0")
    assert result.exit_code == 0, result.output
    assert "verify    OK" in result.output
    assert "largest state deviation 0," in result.output


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_verify_passes_for_episodes_after_an_unseeded_reset(env_id, tmp_path):
    env, _ = record(env_id, tmp_path, episodes=3, max_steps=40)
    for path in env.paths[1:]:
        episode = load_episode(path)
        assert episode.seed is None
        result = verify(episode, tolerance=0.0)
        assert result.ok and result.max_deviation == 0.0 and result.max_reward_deviation == 0.0, result


def test_verify_fails_when_a_recorded_action_is_altered(recorded, tmp_path):
    source = recorded["PyFlyt/QuadX-Waypoints-v0"]
    altered = tmp_path / "altered.mcap"

    def bump(topic: str, data: dict) -> dict | None:
        if topic == "/uav/0/action" and data["step"] == 10:
            data["applied"][3] = min(1.0, data["applied"][3] + 0.2)
            return data
        return None

    rewrite_mcap(source, altered, bump)
    result = replay(altered, "--verify")
    assert result.exit_code == 1, result.output
    assert "verify    FAILED" in result.output
    deviation = float(result.output.split("largest state deviation ")[1].split()[0])
    assert deviation > 1e-4
    # the first deviation shows at the altered step
    episode = load_episode(altered)
    assert verify(episode).worst_step >= 10
    # and the unaltered copy still verifies (the rewrite itself changes nothing else)
    same = tmp_path / "same.mcap"
    rewrite_mcap(source, same, lambda topic, data: None)
    assert replay(same, "--verify", "--tolerance", "0").exit_code == 0


def test_summary_reports_return_success_and_reward_terms(recorded):
    path = recorded["PyFlyt/QuadX-Hover-v0"]
    episode = load_episode(path)
    summary = summarize(episode)
    assert summary["vehicles"] == ["quadx_cf2x"]
    assert summary["return"] == pytest.approx(float(np.sum(episode.rewards)))
    assert sum(summary["reward_terms"].values()) == pytest.approx(summary["return"])
    assert summary["duration_s"] == pytest.approx(episode.length / 30.0)
    result = replay(path, "--json")
    assert result.exit_code == 0
    printed = json.loads(result.output)["summary"]
    assert printed["steps"] == episode.length and printed["end"] in (
        "crash",
        "collision",
        "out_of_bounds",
        "time_limit",
        "complete",
        "failed",
    )
    text = replay(path).output
    for key in ("vehicles  1: quadx_cf2x", "duration", "return", "reward terms", "attitude_error"):
        assert key in text


def test_plot_and_gif(recorded, tmp_path):
    path = recorded["PyFlyt/QuadX-Waypoints-v0"]
    png, gif = tmp_path / "p.png", tmp_path / "v.gif"
    result = replay(path, "--plot", png, "--video", gif, "--size", "64x48")
    assert result.exit_code == 0, result.output
    assert Image.open(png).size[0] > 500
    frames = Image.open(gif)
    assert frames.size == (64, 48) and frames.n_frames == load_episode(path).length + 1


def test_mp4(recorded, tmp_path):
    out = tmp_path / "v.mp4"
    result = replay(recorded["PyFlyt/QuadX-Hover-v0"], "--video", out, "--size", "64x48")
    assert result.exit_code == 0, result.output
    assert out.read_bytes()[4:8] == b"ftyp"


# ------------------------------------------------------------------------- bad input


def _bad(result, *phrases: str) -> None:
    assert result.exit_code == 2, result.output
    for phrase in phrases:
        assert phrase in result.output, result.output


def test_not_an_mcap(tmp_path):
    path = tmp_path / "x.mcap"
    path.write_text("hello")
    _bad(replay(path), "not an MCAP file")
    empty = tmp_path / "empty.mcap"
    empty.write_bytes(b"")
    _bad(replay(empty), "not an MCAP file", "empty")
    _bad(replay(tmp_path / "missing.mcap"), "no such file")
    _bad(replay(tmp_path), "is a directory")


def test_truncated_before_any_data(recorded, tmp_path):
    data = recorded["PyFlyt/QuadX-Hover-v0"].read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[:20])
    _bad(replay(cut), "truncated before any data")


def test_truncated_file_is_summarised_with_a_warning_and_verifies_its_prefix(recorded, tmp_path):
    from mcap.reader import make_reader

    src = recorded["PyFlyt/QuadX-Waypoints-v0"]
    with open(src, "rb") as f:
        chunks = make_reader(f).get_summary().chunk_indexes
    assert len(chunks) >= 3
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(src.read_bytes()[: chunks[len(chunks) // 2].chunk_start_offset + 50])  # mid-chunk
    result = replay(cut, "--verify", "--tolerance", "0")
    assert result.exit_code == 0, result.output
    assert "TRUNCATED" in result.output and "warning" in result.output
    episode = load_episode(cut, warn=False)
    assert episode.truncated and 0 < episode.length < load_episode(recorded["PyFlyt/QuadX-Waypoints-v0"]).length


def test_corrupt_chunk_is_reported(recorded, tmp_path):
    data = bytearray(recorded["PyFlyt/QuadX-Hover-v0"].read_bytes())
    data[len(data) // 2] ^= 0xFF  # inside a compressed chunk
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    _bad(replay(bad), "corrupt")


def test_a_damaged_chunk_is_skipped_on_request_and_the_loss_counted(recorded, tmp_path):
    path = recorded["PyFlyt/QuadX-Hover-v0"]
    whole = read_mcap(path)
    bad = tmp_path / "bad.mcap"
    shutil.copy(path, bad)
    start, length = chunk_spans(bad)[0]
    flip_byte(bad, start + length // 2)
    with pytest.raises(TelemetryError, match="corrupt"):
        read_mcap(bad)  # an episode with a hole cannot be re-simulated: an error unless asked
    with pytest.warns(CorruptRecordingWarning, match="in 1 chunk"):
        contents = read_mcap(bad, skip_damage=True)
    assert contents.lost_chunks == 1 and len(contents.damage) == 1
    assert len(contents.messages) + contents.lost_messages == len(whole.messages) > len(contents.messages)
    assert contents.metadata == whole.metadata and contents.channels == whole.channels


def test_missing_metadata(tmp_path):
    path = tmp_path / "plain.mcap"
    with open(path, "wb") as f:
        w = Writer(f)
        w.start()
        sid = w.register_schema("x", "jsonschema", b"{}")
        cid = w.register_channel("/x", "json", sid)
        w.add_message(cid, 0, b"{}", 0)
        w.finish()
    _bad(replay(path), "missing the 'pyflyt' metadata record")


def test_metadata_without_env_record(recorded, tmp_path):
    src = recorded["PyFlyt/QuadX-Hover-v0"]
    from mcap.reader import make_reader

    path = tmp_path / "noenv.mcap"
    with open(src, "rb") as f:
        reader = make_reader(f)
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
    with open(path, "wb") as f:
        w = Writer(f)
        w.start()
        w.add_metadata("pyflyt", meta["pyflyt"])
        w.finish()
    _bad(replay(path), "missing metadata record 'env'")


def test_wrong_schema(recorded, tmp_path):
    # a metrics file is an MCAP file of another kind
    metrics = tmp_path / "metrics.mcap"
    with MetricsWriter(metrics) as m:
        m.log("/eval", 1, {"mean_return": 1.0})
    _bad(replay(metrics), "metrics file, not an episode recording")

    # an episode whose state channel declares another schema
    src = recorded["PyFlyt/QuadX-Hover-v0"]
    from mcap.reader import make_reader

    renamed = tmp_path / "renamed.mcap"
    with open(src, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        meta = list(reader.iter_metadata())
        messages = list(reader.iter_messages(log_time_order=False))
    with open(renamed, "wb") as f:
        w = Writer(f)
        w.start()
        for m in meta:
            w.add_metadata(m.name, m.metadata)
        sids = {
            i: w.register_schema(
                "foxglove.PosesInFrame" if s.name == "pyflyt.VehicleState" else s.name, s.encoding, s.data
            )
            for i, s in summary.schemas.items()
        }
        cids = {
            i: w.register_channel(c.topic, c.message_encoding, sids[c.schema_id]) for i, c in summary.channels.items()
        }
        for _, c, msg in messages:
            w.add_message(cids[c.id], msg.log_time, msg.data, msg.publish_time)
        w.finish()
    _bad(replay(renamed), "/uav/0/state", "wrong schema")

    # a state message missing its fields
    stripped = tmp_path / "stripped.mcap"

    def strip(topic: str, data: dict) -> dict | None:
        if topic == "/uav/0/state":
            return {k: v for k, v in data.items() if k != "lin_pos"}
        return None

    rewrite_mcap(src, stripped, strip)
    _bad(replay(stripped), "no valid 'lin_pos'")


def test_never_writes_over_the_input(recorded, tmp_path):
    src = recorded["PyFlyt/QuadX-Hover-v0"]
    copy = tmp_path / "ep.png"  # an MCAP file misnamed .png
    copy.write_bytes(src.read_bytes())
    before = copy.read_bytes()
    _bad(replay(copy, "--plot", copy), "input recording")
    assert copy.read_bytes() == before
    _bad(replay(src, "--video", src), "--video")
    _bad(replay(src, "--plot", tmp_path / "out.txt"), ".png")
    other = tmp_path / "notes.png"
    other.write_text("not a picture")
    _bad(replay(src, "--plot", other), "refusing to overwrite")
    _bad(replay(src, "--video", tmp_path / "v.gif", "--size", "big"), "WIDTHxHEIGHT")
    _bad(replay(src, "--plot", tmp_path / "nodir" / "p.png"), "does not exist")


def test_verify_uses_the_recorded_airframe_when_its_file_changed_or_is_gone(tmp_path):
    """A user airframe with channels (whose order matters) is rebuilt from the recording."""
    from pyflyt_engine.envs import UAVEnv, env_config_data
    from pyflyt_engine.paths import conf_dir
    from pyflyt_engine.telemetry import RecordEpisode

    airframe = tmp_path / "my_quadplane.yaml"
    spec = yaml.safe_load((conf_dir() / "uav" / "quadplane.yaml").read_text())
    spec["name"] = "my_quadplane"
    spec["channels"] = dict(reversed(list(spec["channels"].items())))  # not in alphabetical order
    airframe.write_text(yaml.safe_dump(spec, sort_keys=False))
    channels = list(spec["channels"])
    env_cfg = env_config_data("quadx_hover")  # its bases' keys too: the action below replaces the whole section
    env_cfg.update(
        uav=str(airframe),
        action={
            "mode": "rates_thrust",
            "names": ["p", "q", "r", "thrust", *channels],
            "low": [-3.0, -3.0, -3.0, 0.0] + [spec["channels"][c][0] for c in channels],
            "high": [3.0, 3.0, 3.0, 1.0] + [spec["channels"][c][1] for c in channels],
        },
    )
    env = RecordEpisode(UAVEnv(env_cfg), tmp_path / "eps")
    env.reset(seed=2)
    rng = np.random.default_rng(0)
    for _ in range(40):
        a = rng.uniform(env.action_space.low, env.action_space.high)
        a[:3] *= 0.1
        a[3] = 0.3
        if any(env.step(a)[2:4]):
            break
    env.close()
    episode = load_episode(env.paths[0])
    assert verify(episode, tolerance=0.0).max_deviation == 0.0
    spec["drag"]["coefficients"] = [2.0, 2.0, 2.0]
    airframe.write_text(yaml.safe_dump(spec))  # changed (and its keys sorted)
    assert verify(episode, tolerance=0.0).max_deviation == 0.0
    assert verify(episode, tolerance=0.0).max_deviation == 0.0
    airframe.unlink()  # gone
    assert verify(episode, tolerance=0.0).max_deviation == 0.0


# ---------------------------------------------------------------- what a recording decides


def _with_airframe(src, dst, **changes):
    """A copy of recording ``src`` whose recorded airframe spec has ``changes``."""
    from pyflyt_engine.telemetry.recorder import ENV_INFO

    def metadata(name, record):
        if name == ENV_INFO:
            spec = json.loads(record["airframe_spec"])
            spec.update(changes)
            record["airframe_spec"] = json.dumps(spec)
        return record

    rewrite_mcap(src, dst, lambda topic, data: None, metadata)
    return dst


@pytest.fixture
def private_temp(tmp_path, monkeypatch):
    """The system temp directory as an empty folder of tmp_path (URDFs cached elsewhere)."""
    import tempfile

    temp = tmp_path / "temp" / "t"
    temp.mkdir(parents=True)
    monkeypatch.setattr(tempfile, "tempdir", str(temp))
    monkeypatch.setenv("PYFLYT_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "temp"


def test_a_path_in_the_recorded_airframe_name_is_refused(recorded, tmp_path, private_temp):
    evil = _with_airframe(recorded["PyFlyt/QuadX-Hover-v0"], tmp_path / "evil.mcap", name="../../evil")
    _bad(replay(evil, "--verify"), "recorded airframe spec is invalid", "name: must be a plain identifier")
    _bad(replay(evil, "--video", tmp_path / "v.gif"), "name: must be a plain identifier")
    assert not [p for p in private_temp.rglob("*") if p.is_file()]
    assert not list(tmp_path.rglob("evil.yaml")) and not (tmp_path / "v.gif").exists()


def test_replay_writes_only_where_the_user_points(recorded, tmp_path, private_temp):
    """A recorded airframe that differs from the shipped one is flown from memory: no file
    is written for it, in the temp directory or anywhere else."""
    renamed = _with_airframe(recorded["PyFlyt/QuadX-Hover-v0"], tmp_path / "renamed.mcap", name="renamed_quad")
    gif, png = tmp_path / "out" / "v.gif", tmp_path / "out" / "p.png"
    gif.parent.mkdir()
    result = replay(renamed, "--verify", "--tolerance", "0", "--video", gif, "--size", "32x24", "--plot", png)
    assert result.exit_code == 0, result.output
    assert "verify    OK" in result.output
    written = {p for p in tmp_path.rglob("*") if p.is_file()} - {renamed}
    assert {p for p in written if "cache" not in p.parts} == {gif, png}


def test_a_recorded_reward_preset_must_be_inline(recorded, tmp_path):
    from pyflyt_engine.telemetry.recorder import ENV_INFO

    def metadata(name, record):
        if name == ENV_INFO:
            record["reward_preset"] = json.dumps("/etc/some/reward.yaml")
        return record

    path = tmp_path / "named_reward.mcap"
    rewrite_mcap(recorded["PyFlyt/QuadX-Hover-v0"], path, lambda topic, data: None, metadata)
    _bad(replay(path, "--verify"), "metadata 'reward_preset' is not a mapping")


def test_a_recording_from_before_rotary_min_span_replays_with_rotary_gusts_on_every_vehicle(tmp_path):
    """Recordings made before ``turbulence.rotary_min_span`` existed flew the rotary gusts on
    the 5.6 cm quad; their metadata lacks the key, and replay flies them as recorded."""
    import gymnasium

    from pyflyt_engine.telemetry import RecordEpisode

    wind = {"preset": "dryden_light", "turbulence": {"rotary_min_span": 0.0}}
    env = RecordEpisode(gymnasium.make("PyFlyt/QuadX-Hover-v0", wind=wind).unwrapped, tmp_path / "eps")
    env.reset(seed=3)
    for _ in range(40):
        if any(env.step(np.full(env.action_space.shape, 0.0))[2:4]):
            break
    env.close()

    def without_key(span):
        def metadata(name, data):
            if name != "env":
                return data
            recorded = json.loads(data["wind"])
            assert recorded["turbulence"]["rotary_min_span"] == 0.0
            if span is None:
                del recorded["turbulence"]["rotary_min_span"]
            else:
                recorded["turbulence"]["rotary_min_span"] = span
            return {**data, "wind": json.dumps(recorded)}

        return metadata

    old, changed = tmp_path / "old.mcap", tmp_path / "changed.mcap"
    rewrite_mcap(env.paths[0], old, lambda topic, data: None, without_key(None))
    assert verify(load_episode(old), tolerance=0.0).max_deviation == 0.0
    # the check can fail: the same recording flown with the current default (no rotary gusts)
    rewrite_mcap(env.paths[0], changed, lambda topic, data: None, without_key(1.0))
    assert verify(load_episode(changed), tolerance=0.0).max_deviation > 0.0
