"""A full disk during ``pyflyt eval`` is one line and exit 2; it leaves no cut recording, and nothing an
earlier evaluation wrote is changed.

Written from the reproduction: with the disk full during ``pyflyt eval``, the command ended in an
``OSError`` traceback and left a cut (or empty) ``episodes/ep_*.mcap``.  Tests run as root, for whom
permissions stop no write, so the full disk is injected: the file the recorder opens accepts a
given number of bytes, then every write fails with ENOSPC, as on a full file system; and, in a
subprocess, a real file-size limit (``RLIMIT_FSIZE``: writes past it fail with EFBIG).
"""

from __future__ import annotations

import errno
import hashlib
import io
import os
import resource
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from pyflyt_cli.main import app
from pyflyt_engine.telemetry import _io, load_episode

from .conftest import ROOT, cli_env

runner = CliRunner()


class _FullDisk(io.FileIO):
    """A file on a disk with ``room`` bytes left: a write past them is cut, then fails with ENOSPC."""

    room = 0

    def write(self, data) -> int:
        left = _FullDisk.room - self.tell()
        if left <= 0:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return super().write(memoryview(data)[:left])


def full_disk_from_file(monkeypatch, nth: int, room: int) -> None:
    """The ``nth`` recording (0: the first) and every later one get ``room`` bytes of disk."""
    opened = []

    def fake_open(path, mode="r", *args, **kwargs):
        assert mode == "xb"
        opened.append(path)
        if len(opened) - 1 < nth:
            return open(path, mode)
        _FullDisk.room = room
        return io.BufferedWriter(_FullDisk(path, "x"))

    monkeypatch.setattr(_io, "open", fake_open, raising=False)


def digest_of(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}  # fmt: skip


def one_line_exit_2(result, *fragments: str) -> str:
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    lines = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert len(lines) == 1, result.output
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    return lines[0]


@pytest.mark.parametrize("room", [0, 3000, 40_000])  # at the header, in the metadata, in the messages
def test_a_full_disk_during_an_oracle_eval_leaves_only_complete_recordings(tmp_path, monkeypatch, room):
    run = tmp_path / "oracle"
    full_disk_from_file(monkeypatch, nth=1, room=room)  # the second episode's file meets the full disk
    result = runner.invoke(app, ["eval", "oracle:rocket_lander", "episodes=3", "seed=3", f"run_dir={run}"])
    monkeypatch.undo()
    one_line_exit_2(
        result,
        f"cannot write {run / 'episodes' / 'ep_0001.mcap'}",
        "No space left on device",
        "the unfinished recording was removed",
    )
    assert sorted(p.name for p in (run / "episodes").iterdir()) == ["ep_0000.mcap"]  # nothing cut, no temp file
    first = load_episode(run / "episodes" / "ep_0000.mcap", warn=False)
    assert not first.truncated and first.length > 0
    assert not (run / "eval.json").exists()  # no summary of episodes that were not all flown


def test_a_full_disk_before_the_first_recording_leaves_no_oracle_directory(tmp_path, monkeypatch):
    run = tmp_path / "oracle"
    full_disk_from_file(monkeypatch, nth=0, room=100)
    result = runner.invoke(app, ["eval", "oracle:rocket_lander", "episodes=2", "seed=3", f"run_dir={run}"])
    monkeypatch.undo()
    one_line_exit_2(result, "ep_0000.mcap", "No space left on device")
    assert not run.exists()


@pytest.fixture(scope="module")
def evaluated(tmp_path_factory) -> Path:
    """A tiny trained PPO run, evaluated once (its eval.json and two recordings)."""
    from pyflyt_cli.training import train

    from .conftest import TINY_PPO, load

    run = train(load(TINY_PPO, tmp_path_factory.mktemp("runs"))).run_dir
    result = runner.invoke(app, ["eval", str(run), "episodes=2"])
    assert result.exit_code == 0, result.output
    return run


def test_a_full_disk_during_eval_changes_nothing_an_earlier_evaluation_wrote(evaluated, monkeypatch):
    before = digest_of(evaluated)
    full_disk_from_file(monkeypatch, nth=0, room=20_000)
    result = runner.invoke(app, ["eval", str(evaluated), "episodes=2", "seed=7"])
    monkeypatch.undo()
    one_line_exit_2(result, "ep_0002.mcap", "No space left on device")
    assert digest_of(evaluated) == before  # eval.json and both earlier recordings as they were, nothing added
    again = runner.invoke(app, ["eval", str(evaluated), "episodes=2", "seed=7"])  # room again: it just works
    assert again.exit_code == 0, again.output
    assert sorted(p.name for p in (evaluated / "episodes").iterdir())[-2:] == ["ep_0002.mcap", "ep_0003.mcap"]


@pytest.mark.long
def test_eval_past_a_real_file_size_limit_is_one_line_and_leaves_no_cut_file(tmp_path):
    run = tmp_path / "oracle"

    def limit() -> None:  # writes past 40 kB fail with EFBIG (Python ignores SIGXFSZ)
        resource.setrlimit(resource.RLIMIT_FSIZE, (40_000, 40_000))

    proc = subprocess.run(  # noqa: PLW1510
        [sys.executable, "-m", "pyflyt_cli.main", "eval", "oracle:rocket_lander", "episodes=2", "seed=0",
         f"run_dir={run}"],
        cwd=ROOT, env=cli_env(), capture_output=True, text=True, preexec_fn=limit, timeout=300,
    )  # fmt: skip
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert "cannot write" in proc.stderr and "File too large" in proc.stderr
    left = sorted(p.name for p in run.rglob("*.mcap")) if run.exists() else []
    for name in left:
        assert not load_episode(run / "episodes" / name, warn=False).truncated
