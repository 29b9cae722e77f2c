"""A recording process killed mid-episode (SIGKILL), interrupted (SIGINT) or crashing
leaves a readable file: cut at its last complete chunk, or finished by the exit hooks."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from mcap.exceptions import McapError
from mcap.reader import make_reader

from pyflyt_engine.telemetry import TruncatedRecordingWarning, load_episode, read_mcap, read_metrics
from pyflyt_engine.telemetry.replay import verify

ROOT = Path(__file__).resolve().parents[2]

# The child installs Python's own Ctrl-C handler: a process started with SIGINT ignored (any
# background job of a non-interactive shell, e.g. `pytest ... &` in a CI script) inherits the
# ignored disposition, and Python then never raises KeyboardInterrupt.  It prints "ready" once
# everything is written, then blocks until a signal, or until the test closes its stdin.
WRITER = textwrap.dedent(
    """
    import signal, sys, warnings
    signal.signal(signal.SIGINT, signal.default_int_handler)
    warnings.simplefilter("ignore")
    import gymnasium, pyflyt_engine
    from pyflyt_engine.telemetry import RecordEpisode, MetricsWriter
    from tests.telemetry.conftest import hover_action

    folder, steps, ending = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    env = RecordEpisode(gymnasium.make("PyFlyt/QuadX-Hover-v0", flight_dome_size=100.0, max_duration_seconds=60.0), folder)
    metrics = MetricsWriter(folder + "/metrics.mcap")
    env.reset(seed=4)
    for k in range(steps):
        env.step(hover_action(env.unwrapped.state))
        metrics.log("/train/progress", k, {"k": k})
    metrics.flush()
    print("ready", flush=True)
    if ending == "raise":
        raise RuntimeError("boom")
    sys.stdin.read()
    """
)
#: longest wait for a child to exit after the signal; only a hang shows up here (it takes ~1 s)
HANG = 300


def _start(tmp_path: Path, steps: int, ending: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(
        [sys.executable, "-c", WRITER, str(tmp_path), str(steps), ending],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        cwd=ROOT,
    )
    assert proc.stdout is not None
    line = proc.stdout.readline()
    if line.strip() != "ready":
        proc.kill()
        raise AssertionError(f"the writer did not start: {line!r}\n{proc.communicate()[1]}")
    return proc


def _finish(proc: subprocess.Popen) -> str:
    """Close the child's stdin and wait for it to exit; its stderr.

    A signal sent before is handled first: it was delivered when sent, so its handler runs at
    the child's next bytecode at the latest (a child that ignored it exits with status 0).
    """
    try:
        return proc.communicate(timeout=HANG)[1]
    except subprocess.TimeoutExpired:
        proc.kill()
        raise AssertionError(f"the child did not exit within {HANG} s: {proc.communicate()[1]}") from None


def test_sigkill_mid_episode_leaves_the_flight_up_to_the_last_chunk(tmp_path):
    steps = 100  # 3.33 s at 30 Hz: chunks closed at 1, 2 and 3 s of flight
    proc = _start(tmp_path, steps, "wait")
    proc.send_signal(signal.SIGKILL)
    _finish(proc)
    assert proc.returncode == -signal.SIGKILL
    path = tmp_path / "ep_0000.mcap"
    with open(path, "rb") as f, pytest.raises(McapError):  # the official reader needs the footer/summary
        make_reader(f, validate_crcs=True).get_summary()
    with pytest.warns(UserWarning, match="truncated"):
        contents = read_mcap(path)
    assert contents.truncated and "no footer" in contents.truncation
    episode = load_episode(path, warn=False)
    # lost at most one simulated second (30 steps), more is kept if the flusher ran
    assert steps - 30 <= episode.length <= steps
    assert episode.end is None
    # what was recovered still re-simulates exactly
    assert verify(episode, tolerance=0.0).ok
    # and the metrics file was flushed explicitly before the kill
    with pytest.warns(TruncatedRecordingWarning):
        curves = read_metrics(tmp_path)
    assert len(curves["/train/progress"]) == steps and curves.truncated


@pytest.mark.parametrize("ending", ["sigint", "raise"])
def test_interrupt_or_exception_still_finishes_the_file(tmp_path, ending):
    proc = _start(tmp_path, 20, "raise" if ending == "raise" else "wait")
    if ending == "sigint":  # the child is blocked reading stdin, past everything it writes
        proc.send_signal(signal.SIGINT)
    err = _finish(proc)
    # an uncaught KeyboardInterrupt ends Python the way SIGINT would (status -2 to the parent)
    assert proc.returncode == (-signal.SIGINT if ending == "sigint" else 1), err
    assert ("KeyboardInterrupt" if ending == "sigint" else "boom") in err
    path = tmp_path / "ep_0000.mcap"
    with open(path, "rb") as f:  # complete: summary, footer, valid CRCs
        reader = make_reader(f, validate_crcs=True)
        count = sum(1 for _ in reader.iter_messages())
        assert reader.get_summary().statistics.message_count == count
    episode = load_episode(path)
    assert not episode.truncated and episode.length == 20
    curves = read_metrics(tmp_path)
    assert curves.truncated == [] and len(curves["/train/progress"]) == 20


def test_ctrl_c_inside_the_writer_waits_for_the_record_to_be_whole(tmp_path, monkeypatch):
    """Ctrl-C landing at any point of the mcap writer's work: the interrupt comes out of the
    call after the records are whole, and the file is then finished complete."""
    from mcap.data_stream import RecordBuilder

    from pyflyt_engine.telemetry._io import McapFileWriter

    write = RecordBuilder.write
    calls = {"n": 0, "at": -1}

    def write_and_maybe_interrupt(self, data):
        calls["n"] += 1
        if calls["n"] == calls["at"]:
            signal.raise_signal(signal.SIGINT)  # its Python handler runs at the next bytecode
        return write(self, data)

    monkeypatch.setattr(RecordBuilder, "write", write_and_maybe_interrupt)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        at, interrupted = 1, 0
        while True:
            path = tmp_path / f"f{at}.mcap"
            f = McapFileWriter(path)
            cid = f.channel("/t", "pyflyt.Test", {"type": "object"})
            calls.update(n=0, at=at)
            try:
                for k in range(3):
                    f.write(cid, k, {"k": k})
                    f.flush()
                f.metadata("m", {"a": "b"})
            except KeyboardInterrupt:
                interrupted += 1
            try:
                f.close()  # also reached by Ctrl-C: the exit hook
            except KeyboardInterrupt:
                interrupted += 1
            with open(path, "rb") as stream:  # complete, CRCs valid, every queued message kept
                reader = make_reader(stream, validate_crcs=True)
                stats = reader.get_summary().statistics
                assert stats.message_count == sum(1 for _ in reader.iter_messages())
            assert not read_mcap(path).truncated
            if calls["n"] < at:  # the signal came after the last record: every point was tried
                break
            at += 1
    finally:
        signal.signal(signal.SIGINT, previous)
    assert interrupted == at - 1 > 20  # every interrupt reached the caller, none was lost
