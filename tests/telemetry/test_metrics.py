"""MetricsWriter / read_metrics: round trip, segments on resume, types, bad files."""

from __future__ import annotations

import json
import math
import time
import warnings

import jsonschema
import numpy as np
import pytest

from pyflyt_engine.errors import PyFlytError, TelemetryError
from pyflyt_engine.telemetry import CorruptRecordingWarning, MetricsWriter, TruncatedRecordingWarning, read_metrics
from pyflyt_engine.telemetry.metrics import read_metrics_metadata, segment_paths
from tests.telemetry.conftest import iter_official


def test_round_trip(tmp_path):
    path = tmp_path / "metrics.mcap"
    with MetricsWriter(path, metadata={"algo": "sac", "seed": "3"}) as m:
        m.log("/train/episode", 240, {"return": -31.5, "length": 240}, wall_time=1000.0)
        m.log(
            "/eval",
            500,
            {"mean_return": np.float32(2.5), "std_return": 0.25, "success_rate": 0.4, "mean_length": np.int64(80)},
            wall_time=1001.0,
        )
        m.log("/train/episode", 480, {"return": -12.0, "length": 240}, wall_time=1002.0)
        m.log("/train/progress", 500, {"fps": 812.0, "phase": "collect", "done": False}, wall_time=1003.0)
    curves = read_metrics(path)
    assert curves["/train/episode"] == [
        {"step": 240, "wall_time": 1000.0, "return": -31.5, "length": 240},
        {"step": 480, "wall_time": 1002.0, "return": -12.0, "length": 240},
    ]
    assert curves["/eval"][0]["mean_return"] == 2.5 and curves["/eval"][0]["mean_length"] == 80
    assert curves["/train/progress"][0] == {
        "step": 500,
        "wall_time": 1003.0,
        "fps": 812.0,
        "phase": "collect",
        "done": False,
    }
    assert curves.segments == [path] and curves.truncated == []
    assert read_metrics(tmp_path) == curves  # the run directory works too
    assert read_metrics_metadata(path) == [{"algo": "sac", "seed": "3"}]


def test_official_reader_and_schemas(tmp_path):
    path = tmp_path / "metrics.mcap"
    with MetricsWriter(path) as m:
        for step in range(50):
            m.log("/train/episode", step, {"return": float(step), "length": 10})
        m.log("/eval", 50, {"mean_return": float("nan"), "success_rate": 1.0})
    seen = 0
    for schema, channel, message in iter_official(path):  # CRCs validated
        jsonschema.validate(json.loads(message.data), json.loads(schema.data))
        assert message.log_time == round(json.loads(message.data)["wall_time"] * 1e9)
        seen += 1
    assert seen == 51
    assert math.isnan(read_metrics(path)["/eval"][0]["mean_return"])  # NaN stored as null


def test_resume_writes_segments_read_in_order(tmp_path):
    with MetricsWriter(tmp_path) as m:
        m.log("/train/episode", 1, {"return": 1.0})
    with pytest.raises(TelemetryError, match="append=True"):
        MetricsWriter(tmp_path / "metrics.mcap")
    for seg, step in ((1, 2), (2, 3)):
        with MetricsWriter(tmp_path / "metrics.mcap", append=True) as m:
            assert m.path == tmp_path / f"metrics-{seg}.mcap" and m.segment == seg
            m.log("/train/episode", step, {"return": float(step)})
    assert [p.name for p in segment_paths(tmp_path)] == ["metrics.mcap", "metrics-1.mcap", "metrics-2.mcap"]
    for where in (tmp_path, tmp_path / "metrics.mcap", tmp_path / "metrics-2.mcap"):
        assert [r["step"] for r in read_metrics(where)["/train/episode"]] == [1, 2, 3]


def test_segment_numbers_sort_numerically(tmp_path):
    with MetricsWriter(tmp_path) as m:
        m.log("/t", 0, {"v": 0})
    for i in range(1, 12):
        with MetricsWriter(tmp_path, append=True) as m:
            m.log("/t", i, {"v": i})
    assert [r["step"] for r in read_metrics(tmp_path)["/t"]] == list(range(12))


def test_bad_values_are_rejected(tmp_path):
    with MetricsWriter(tmp_path / "metrics.mcap") as m:
        m.log("/eval", 1, {"mean_return": 1.0})
        with pytest.raises(TelemetryError, match="reserved"):
            m.log("/eval", 2, {"step": 3})
        with pytest.raises(TelemetryError, match="numbers, strings or booleans"):
            m.log("/eval", 2, {"x": [1, 2]})
        with pytest.raises(TelemetryError, match="was logged as a number"):
            m.log("/eval", 2, {"mean_return": "high"})
        with pytest.raises(TelemetryError, match="integer"):
            m.log("/eval", 2.5, {"mean_return": 1.0})  # type: ignore[arg-type]
    with pytest.raises(TelemetryError, match="closed"):
        m.log("/eval", 3, {"mean_return": 1.0})
    assert isinstance(TelemetryError("x"), PyFlytError)


def test_bad_files(tmp_path):
    with pytest.raises(TelemetryError, match="no metrics file"):
        read_metrics(tmp_path)
    (tmp_path / "metrics.mcap").write_text("nope")
    with pytest.warns(CorruptRecordingWarning, match="skipped"):
        with pytest.raises(TelemetryError, match="no readable metrics.*not an MCAP file"):
            read_metrics(tmp_path)


def test_truncated_segment_is_read_and_reported(tmp_path):
    path = tmp_path / "metrics.mcap"
    m = MetricsWriter(path)
    for step in range(10):
        m.log("/train/episode", step, {"return": float(step)})
    m.flush()  # what the background flusher does within a second
    for step in range(10, 15):
        m.log("/train/episode", step, {"return": float(step)})
    m.flush()
    data = path.read_bytes()  # as a killed process leaves it: no summary, no footer
    m.close()
    cut = tmp_path / "cut" / "metrics.mcap"
    cut.parent.mkdir()
    cut.write_bytes(data)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        curves = read_metrics(cut)
    assert [r["step"] for r in curves["/train/episode"]] == list(range(15))
    assert curves.truncated == [cut]
    assert any(issubclass(w.category, TruncatedRecordingWarning) and "truncated" in str(w.message) for w in caught)


def test_background_flush_bounds_the_loss(tmp_path):
    path = tmp_path / "metrics.mcap"
    m = MetricsWriter(path, flush_interval=0.2)
    m.log("/eval", 1, {"mean_return": 1.0})
    size = path.stat().st_size
    # the flusher wakes every 0.2 s; the deadline only bounds a failure (a loaded machine is slow)
    deadline = time.monotonic() + 60
    while path.stat().st_size == size and time.monotonic() < deadline:
        time.sleep(0.02)
    grown = path.stat().st_size > size
    m.close()
    assert grown, "the logged record never reached the file"


def test_episode_file_is_not_a_metrics_file(recorded, tmp_path):
    path = next(iter(recorded.values()))
    with pytest.warns(CorruptRecordingWarning), pytest.raises(TelemetryError, match="not a metrics file"):
        read_metrics(path)
