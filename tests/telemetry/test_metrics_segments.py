"""Append-only metrics: resume markers, damaged and unreadable segments, setting them aside, and
a kill at every step of creating a resumed segment.  All on real files."""

from __future__ import annotations

import gc
import shutil
import warnings
from pathlib import Path
from typing import Any

import pytest

import pyflyt_engine.telemetry._io as mcap_io
from pyflyt_engine.errors import TelemetryError
from pyflyt_engine.telemetry import (
    CorruptRecordingWarning,
    MetricsWriter,
    TruncatedRecordingWarning,
    read_mcap,
    read_metrics,
    set_aside_unreadable,
)
from pyflyt_engine.telemetry.metrics import FILE_INFO, read_metrics_metadata, segment_paths
from tests.telemetry.conftest import chunk_spans, flip_byte


def _log(writer: MetricsWriter, step: int) -> None:
    """What a run logs at ``step``: a function of the step only (so reruns log the same records)."""
    writer.log("/train/episode", step, {"return": step / 2, "length": step}, wall_time=1000.0 + step)
    if step % 5 == 0:
        writer.log("/eval", step, {"mean_return": float(step)}, wall_time=1000.5 + step)


def _segment(run: Path, steps: range, resumed_from: int | None = None, chunk_every: int = 0) -> Path:
    """Log ``steps`` in the next segment of ``run``'s metrics (a chunk closed every ``chunk_every`` steps)."""
    with MetricsWriter(run, {"algo": "ppo"}, append=True, resumed_from=resumed_from) as m:
        for step in steps:
            _log(m, step)
            if chunk_every and step % chunk_every == 0:
                m.flush()
    return m.path


def _curves(run: Path) -> dict[str, list[dict[str, Any]]]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return dict(read_metrics(run))


def _steps(curves: dict[str, list[dict[str, Any]]], topic: str = "/train/episode") -> list[int]:
    return [r["step"] for r in curves.get(topic, [])]


@pytest.fixture
def uninterrupted(tmp_path) -> dict[str, list[dict[str, Any]]]:
    """Steps 1-20 logged by one writer."""
    _segment(tmp_path / "straight", range(1, 21))
    return _curves(tmp_path / "straight")


# ---------------------------------------------------------------------------- markers


def test_two_resumes_read_exactly_like_an_uninterrupted_run(tmp_path, uninterrupted):
    run = tmp_path / "run"
    _segment(run, range(1, 11))  # killed at step 10, last checkpoint at 6
    _segment(run, range(7, 16), resumed_from=6)  # killed at 15, last checkpoint at 12
    _segment(run, range(13, 21), resumed_from=12)
    curves = read_metrics(run)
    assert dict(curves) == uninterrupted
    # superseded: steps 7-10 (+ eval 10) of the first segment, 13-15 (+ eval 15) of the second
    assert curves.superseded == 5 + 4
    assert [p.name for p in curves.segments] == ["metrics.mcap", "metrics-1.mcap", "metrics-2.mcap"]
    assert curves.metadata == [{"algo": "ppo"}] * 3
    assert curves.unreadable == [] and curves.damaged == [] and curves.truncated == []


def test_a_restart_from_step_0_supersedes_the_whole_earlier_run(tmp_path):
    run = tmp_path / "run"
    _segment(run, range(1, 11))
    _segment(run, range(1, 4), resumed_from=0)
    curves = read_metrics(run)
    assert _steps(curves) == [1, 2, 3] and curves.get("/eval", []) == []
    assert curves.superseded == 12


def test_a_segment_without_marker_is_appended_as_it_is(tmp_path):
    run = tmp_path / "run"
    _segment(run, range(1, 4))
    _segment(run, range(2, 5))  # append=True without resumed_from: nothing superseded
    curves = read_metrics(run)
    assert _steps(curves) == [1, 2, 3, 2, 3, 4] and curves.superseded == 0


def test_the_marker_is_on_disk_as_soon_as_the_segment_exists(tmp_path):
    run = tmp_path / "run"
    _segment(run, range(1, 11))
    writer = MetricsWriter(run, append=True, resumed_from=4)
    try:
        on_disk = tmp_path / "copy"  # what a kill now would leave
        shutil.copytree(run, on_disk)
        assert read_mcap(on_disk / "metrics-1.mcap", warn=False).metadata[FILE_INFO]["resumed_from"] == "4"
        with pytest.warns(TruncatedRecordingWarning):
            assert _steps(read_metrics(on_disk)) == [1, 2, 3, 4]
        assert writer.resumed_from == 4 and writer.segment == 1
    finally:
        writer.close()


@pytest.mark.parametrize("bad", [-1, 2.0, True, "3"])
def test_resumed_from_must_be_a_step_count(tmp_path, bad):
    with pytest.raises(TelemetryError, match="resumed_from"):
        MetricsWriter(tmp_path, resumed_from=bad)
    assert segment_paths(tmp_path) == []  # nothing created


# ---------------------------------------------------------------------------- damage


@pytest.mark.parametrize(
    ("chunk", "lost"),
    [(0, range(1, 6)), (1, range(6, 11))],
    ids=["first chunk, which defines the channels", "a middle chunk"],
)
def test_a_flipped_byte_in_a_chunk_loses_that_chunk_only(tmp_path, chunk, lost):
    run = tmp_path / "run"
    path = _segment(run, range(1, 16), chunk_every=5)  # chunks: steps 1-5, 6-10, 11-15
    start, length = chunk_spans(path)[chunk]
    flip_byte(path, start + length - 20)  # inside the compressed records: CRC mismatch / bad zstd frame
    with pytest.raises(TelemetryError, match="corrupt"):
        read_mcap(path)  # damage is an error for a plain read
    with pytest.warns(CorruptRecordingWarning, match="lost 6 messages in 1 chunk"):
        curves = read_metrics(run)
    assert _steps(curves) == [s for s in range(1, 16) if s not in lost]
    assert _steps(curves, "/eval") == [s for s in (5, 10, 15) if s not in lost]
    assert [p for p, _ in curves.damaged] == [path] and "lost 6 messages in 1 chunk" in curves.damaged[0][1]
    assert curves.unreadable == []


@pytest.mark.parametrize(
    ("chunk", "kept", "loss"),
    [
        (1, [1, 2, 3, 4, 5, 11, 12, 13, 14, 15], "lost 6 messages in 1 chunk"),
        # no summary repeats the channel definitions: the later messages cannot be attributed
        (0, [], "lost 18 messages in 1 chunk (the chunk at byte"),
    ],
    ids=["a middle chunk", "the chunk defining the channels"],
)
def test_a_damaged_chunk_in_a_truncated_segment(tmp_path, chunk, kept, loss):
    run = tmp_path / "run"
    m = MetricsWriter(run)
    for step in range(1, 16):
        _log(m, step)
        if step % 5 == 0:
            m.flush()
    killed = (run / "metrics.mcap").read_bytes()  # no summary: the message indexes count the loss
    m.close()
    cut = tmp_path / "cut"
    cut.mkdir()
    (cut / "metrics.mcap").write_bytes(killed)
    start, length = chunk_spans(run / "metrics.mcap")[chunk]
    flip_byte(cut / "metrics.mcap", start + length - 20)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        curves = read_metrics(cut)
    assert _steps(curves) == kept
    assert curves.truncated == [cut / "metrics.mcap"] and loss in curves.damaged[0][1]
    if not kept:
        # one line per channel, not per message
        assert "10 messages on channel 1, whose definition was lost; 2 messages on channel 2" in curves.damaged[0][1]
    assert {w.category for w in caught} == {TruncatedRecordingWarning, CorruptRecordingWarning}


def test_a_damaged_record_length_is_stepped_over(tmp_path):
    run = tmp_path / "run"
    path = _segment(run, range(1, 16), chunk_every=5)
    start, _ = chunk_spans(path)[1]
    flip_byte(path, start + 1 + 6)  # the chunk's length field: it now runs past the end of the file
    with pytest.warns(CorruptRecordingWarning, match="6 messages"):  # counted by the summary's statistics
        curves = read_metrics(run)
    assert _steps(curves) == [1, 2, 3, 4, 5, 11, 12, 13, 14, 15]


# ---------------------------------------------------------------------------- unreadable segments


def _garbage_segments(run: Path) -> tuple[Path, Path, Path]:
    """A series: steps 1-10, a zero-byte segment, a text file, a header cut by garbage, then a resume from 6."""
    _segment(run, range(1, 11))
    empty = run / "metrics-1.mcap"
    empty.touch()  # a writer killed right after creating its file
    text = run / "metrics-2.mcap"
    text.write_text("not an mcap file")
    header = run / "metrics-3.mcap"
    header.write_bytes(bytes([137, 77, 67, 65, 80, 48, 13, 10]) + bytes(range(200)))
    _segment(run, range(7, 13), resumed_from=6)
    return empty, text, header


def test_unreadable_segments_are_skipped_and_reported(tmp_path):
    run = tmp_path / "run"
    empty, text, header = _garbage_segments(run)
    with pytest.warns(CorruptRecordingWarning) as caught:
        curves = read_metrics(run)
    assert _steps(curves) == list(range(1, 13)) and curves.superseded == 5
    assert [p for p, _ in curves.unreadable] == [empty, text, header]
    reasons = [why for _, why in curves.unreadable]
    assert reasons[0] == "not an MCAP file (it is empty)"
    assert reasons[1] == "not an MCAP file (it does not start with the MCAP magic bytes)"
    assert reasons[2] == "truncated before any data: nothing to read"
    assert sum("skipped" in str(w.message) for w in caught) == 3
    assert [p.name for p in curves.segments] == ["metrics.mcap", "metrics-4.mcap"]
    assert read_metrics_metadata(run) == [{"algo": "ppo"}] * 2


def test_nothing_readable_is_an_error_that_says_why(tmp_path):
    (tmp_path / "metrics.mcap").touch()
    with pytest.warns(CorruptRecordingWarning), pytest.raises(TelemetryError, match="no readable metrics.*empty"):
        read_metrics(tmp_path)
    with pytest.raises(TelemetryError, match="no readable metrics.*empty"):
        read_metrics_metadata(tmp_path)


def test_set_aside_unreadable_renames_without_overwriting(tmp_path):
    run = tmp_path / "run"
    empty, text, header = _garbage_segments(run)
    (run / "metrics-2.mcap.unreadable").write_bytes(b"set aside earlier")
    before = {p: p.read_bytes() for p in (empty, text, header)}
    moved = set_aside_unreadable(run)
    assert [(old, new.name) for old, new, _ in moved] == [
        (empty, "metrics-1.mcap.unreadable"),
        (text, "metrics-2.mcap.unreadable-1"),
        (header, "metrics-3.mcap.unreadable"),
    ]
    assert all(why for _, _, why in moved)
    for old, new, _ in moved:
        assert not old.exists() and new.read_bytes() == before[old]  # renamed, content intact
    assert (run / "metrics-2.mcap.unreadable").read_bytes() == b"set aside earlier"
    assert [p.name for p in segment_paths(run)] == ["metrics.mcap", "metrics-4.mcap"]
    curves = read_metrics(run)  # no warning now
    assert curves.unreadable == [] and _steps(curves) == list(range(1, 13))
    assert set_aside_unreadable(run) == []
    # the next resume continues the series
    assert _segment(run, range(11, 15), resumed_from=10).name == "metrics-5.mcap"
    assert _steps(read_metrics(run)) == list(range(1, 15))


def test_truncated_and_damaged_segments_are_readable_so_they_stay(tmp_path):
    run = tmp_path / "run"
    path = _segment(run, range(1, 16), chunk_every=5)
    start, length = chunk_spans(path)[1]
    flip_byte(path, start + length - 20)
    m = MetricsWriter(run, append=True, resumed_from=15)
    _log(m, 16)
    m.flush()  # and then killed: the segment has no footer
    cut = tmp_path / "copy"
    shutil.copytree(run, cut)
    m.close()
    assert set_aside_unreadable(cut) == []
    assert [p.name for p in segment_paths(cut)] == ["metrics.mcap", "metrics-1.mcap"]


# ---------------------------------------------------------------------------- a kill while resuming


class _Killed(BaseException):
    """The process dies here: what is on disk is what a kill at this instant leaves."""


class _Stream:
    """A file whose every operation is a point where the process may be killed."""

    def __init__(self, f: Any, step: Any) -> None:
        self._f = f
        self._step = step

    def __getattr__(self, name: str) -> Any:
        attr = getattr(self._f, name)
        if not callable(attr):
            return attr

        def call(*args: Any, **kwargs: Any) -> Any:
            self._step()
            return attr(*args, **kwargs)

        return call


@pytest.mark.long
def test_a_kill_at_any_step_of_creating_a_resumed_segment_leaves_before_or_after(tmp_path, monkeypatch, uninterrupted):
    run = tmp_path / "run"
    _segment(run, range(1, 11))
    _segment(run, range(7, 15), resumed_from=6)
    checkpoint = 9
    before = _curves(run)
    after = {t: [r for r in recs if r["step"] <= checkpoint] for t, recs in before.items()}
    assert after != before
    seen = {"before": 0, "after": 0}
    point = 0
    while True:
        live = tmp_path / f"live{point}"
        shutil.copytree(run, live)
        state = {"ops": 0, "fired": False}

        def step(point=point, state=state, live=live) -> None:
            if not state["fired"] and state["ops"] == point:
                state["fired"] = True
                shutil.copytree(live, tmp_path / f"killed{point}")  # the bytes the OS holds now
                raise _Killed
            state["ops"] += 1

        def killable_open(*args: Any, step=step, **kwargs: Any) -> _Stream:
            step()
            stream = open(*args, **kwargs)  # noqa: SIM115 - handed to the writer
            step()
            return _Stream(stream, step)

        with monkeypatch.context() as patch:
            patch.setattr(mcap_io, "open", killable_open, raising=False)
            try:
                MetricsWriter(live, {"algo": "ppo"}, append=True, resumed_from=checkpoint).close()
            except _Killed:
                pass
        if not state["fired"]:
            break  # the segment was created without reaching this point: every point was tried
        gc.collect()  # a writer dropped by the exception is finished by its exit hook
        killed = _curves(tmp_path / f"killed{point}")
        assert killed in (before, after), f"kill at operation {point}"
        seen["before" if killed == before else "after"] += 1
        assert _curves(live) in (before, after), f"exception at operation {point}"
        # the run is resumed again from the same checkpoint and completed
        set_aside_unreadable(live)
        _segment(live, range(checkpoint + 1, 21), resumed_from=checkpoint)
        assert _curves(live) == uninterrupted, f"resume after a kill at operation {point}"
        point += 1
    assert seen["before"] >= 2 and seen["after"] >= 1, seen  # kills before and after the flush were tried
