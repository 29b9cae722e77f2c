"""Output files (pictures, plots, videos, reports) are written all at once: a failed write
(full disk, read-only directory, file-size limit) is one message naming the path and the
reason, exits 2, leaves no partial or empty file behind, and a retry then succeeds.

Tests run as root, so permissions cannot make a directory read-only: failures are
injected (a writer that writes part of the file, then raises ENOSPC or EROFS), or come
from a real file-size limit (RLIMIT_FSIZE) in a subprocess.
"""

from __future__ import annotations

import errno
import os
import resource
import subprocess
import sys
import warnings
from pathlib import Path

import gymnasium
import numpy as np
import pytest
import yaml
from matplotlib.figure import Figure
from PIL import Image
from typer.testing import CliRunner

from pyflyt_cli.errors import UsageError
from pyflyt_cli.main import app
from pyflyt_cli.outputs import atomic_output
from pyflyt_engine.telemetry import RecordEpisode

ROOT = Path(__file__).resolve().parents[2]
runner = CliRunner()


def invoke(*args):
    result = runner.invoke(app, [str(a) for a in args])
    assert "Traceback" not in result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result


def failing(code: int, method: bool = True):
    """A stand-in for a writer: writes part of the file, then fails like a full or read-only disk."""

    def write(target, *args, **kwargs):
        Path(target).write_bytes(b"\x89PNG partial")
        raise OSError(code, os.strerror(code), str(target))

    return (lambda self, target, *args, **kwargs: write(target)) if method else write


def files_in(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def fails_cleanly_then_succeeds(monkeypatch, args, writer: str, stand_in, option: str, out: Path, code: int) -> None:
    """``args`` with ``writer`` replaced by ``stand_in`` exits 2 naming ``option``, ``out`` and the
    reason, leaves nothing in ``out``'s folder; the same command then succeeds."""
    with monkeypatch.context() as patch:
        patch.setattr(writer, stand_in)
        result = invoke(*args)
    assert result.exit_code == 2, result.output
    assert f"error: {option} {out}: cannot write the file: {os.strerror(code)}" in result.output
    assert files_in(out.parent) == []
    result = invoke(*args)
    assert result.exit_code == 0, result.output


# ------------------------------------------------------------------ the helper


def test_atomic_output_replaces_the_file_only_when_the_write_completes(tmp_path):
    out = tmp_path / "fig.png"
    out.write_bytes(b"old")
    with atomic_output(out, "--png") as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".png" and tmp != out
        tmp.write_bytes(b"new")
        assert out.read_bytes() == b"old"  # not yet
    assert out.read_bytes() == b"new" and files_in(tmp_path) == ["fig.png"]

    with pytest.raises(UsageError) as info:
        with atomic_output(out, "--png") as tmp:
            tmp.write_bytes(b"half")
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(tmp))
    assert str(info.value) == f"--png {out}: cannot write the file: No space left on device; the file was not changed"
    assert out.read_bytes() == b"new" and files_in(tmp_path) == ["fig.png"]

    with pytest.raises(ZeroDivisionError):  # not an OS failure: propagates, still cleaned up
        with atomic_output(tmp_path / "other.png") as tmp:
            tmp.write_bytes(b"half")
            raise ZeroDivisionError
    assert files_in(tmp_path) == ["fig.png"]


# ------------------------------------------------------------------ pyflyt uav show


@pytest.mark.long
@pytest.mark.parametrize("option, writer, code", [
    ("--png", "PIL.Image.Image.save", errno.ENOSPC),
    ("--curves", "matplotlib.figure.Figure.savefig", errno.EROFS),
])  # fmt: skip
def test_uav_show_write_failure_is_one_message_and_a_retry_succeeds(tmp_path, monkeypatch, option, writer, code):
    out = tmp_path / "pic.png"
    args = ("uav", "show", "fixedwing", option, out, "--size", "64x48")
    fails_cleanly_then_succeeds(monkeypatch, args, writer, failing(code), option, out, code)
    assert Image.open(out).format == "PNG"


# ------------------------------------------------------------------ pyflyt replay


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("recording")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = RecordEpisode(gymnasium.make("PyFlyt/QuadX-Hover-v0"), folder)
    env.reset(seed=1)
    for _ in range(15):
        env.step(np.array([0.0, 0.0, 0.0, 0.13]))
    env.close()
    return env.paths[0]


@pytest.mark.parametrize("option, name, writer, code", [
    ("--plot", "p.png", "matplotlib.figure.Figure.savefig", errno.EROFS),
    ("--video", "v.gif", "imageio.v2.mimsave", errno.ENOSPC),
])  # fmt: skip
def test_replay_write_failure_is_one_message_and_a_retry_succeeds(
    recording, tmp_path, monkeypatch, option, name, writer, code
):
    out = tmp_path / name
    args = ("replay", recording, option, out, *(("--size", "32x24") if option == "--video" else ()))
    stand_in = failing(code, method=writer.endswith("savefig"))
    fails_cleanly_then_succeeds(monkeypatch, args, writer, stand_in, option, out, code)
    assert out.stat().st_size > 100


def _limited(limit: int):
    def apply() -> None:  # in the child: writes past `limit` bytes fail with EFBIG (Python ignores SIGXFSZ)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return apply


@pytest.mark.long
@pytest.mark.parametrize("option, name, reason", [
    ("--plot", "plot.png", "File too large"),
    ("--video", "video.mp4", "the video encoder (ffmpeg) stopped before the video was complete"),
])  # fmt: skip
def test_replay_output_past_a_file_size_limit_leaves_nothing_and_a_retry_succeeds(
    recording, tmp_path, option, name, reason
):
    out = tmp_path / "out" / name
    out.parent.mkdir()
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONDONTWRITEBYTECODE": "1", "MPLBACKEND": "Agg",
           "PYFLYT_CACHE_DIR": str(tmp_path / "cache")}  # fmt: skip
    args = ("replay", recording, option, out, *(("--size", "160x120") if option == "--video" else ()))
    limited = subprocess.run(
        [sys.executable, "-m", "pyflyt_cli.main", *map(str, args)],
        capture_output=True,
        text=True,
        env=env,
        preexec_fn=_limited(8_000),
        timeout=600,
        check=False,
    )
    assert limited.returncode == 2, limited.stderr
    assert f"error: {option} {out}: cannot write the file: {reason}" in limited.stderr
    assert "Traceback" not in limited.stderr
    assert files_in(out.parent) == []
    result = invoke(*args)
    assert result.exit_code == 0, result.output
    assert out.stat().st_size > 8_000


def test_a_cut_off_mp4_is_recognised(tmp_path):
    import imageio.v2 as imageio

    from pyflyt_engine.telemetry.video import _check_mp4

    good = tmp_path / "good.mp4"
    frames = [np.full((48, 64, 3), 10 * i, dtype=np.uint8) for i in range(20)]
    imageio.mimsave(good, frames, format="FFMPEG", fps=10, macro_block_size=1)
    _check_mp4(good)
    data = good.read_bytes()
    for cut in (8, len(data) // 2, len(data) - 1):
        (tmp_path / "cut.mp4").write_bytes(data[:cut])
        with pytest.raises(OSError, match="stopped before the video was complete"):
            _check_mp4(tmp_path / "cut.mp4")


# ------------------------------------------------------------------ pyflyt plot


@pytest.fixture
def bench(tmp_path) -> Path:
    from pyflyt_engine.telemetry.metrics import MetricsWriter

    root = tmp_path / "bench"
    for algo in ("a", "b"):
        for seed in range(2):
            run = root / "runs" / "quadx_hover" / algo / f"seed{seed}"
            run.mkdir(parents=True)
            with MetricsWriter(run / "metrics.mcap", metadata={"env": "quadx_hover", "algo": algo}) as writer:
                for step in (100, 200, 300):
                    writer.log("/eval", step, {"mean_return": step * (seed + 1.0) + len(algo)})
    (root / "normalisation.yaml").write_text(yaml.safe_dump({"quadx_hover": {"random": 0.0, "reference": 900.0}}))
    return root


@pytest.mark.long
def test_plot_write_failure_is_one_message_and_a_retry_succeeds(bench, tmp_path, monkeypatch):
    out = tmp_path / "report"
    calls = []

    def fail_on_third(self, target, *args, **kwargs):
        calls.append(target)
        if len(calls) == 3:
            Path(target).write_bytes(b"partial")
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(target))
        return save(self, target, *args, **kwargs)

    save = Figure.savefig
    with monkeypatch.context() as patch:
        patch.setattr(Figure, "savefig", fail_on_third)
        result = invoke("plot", bench, "--out", out, "--reps", "20")
    assert result.exit_code == 2, result.output
    assert f"error: {out / 'aggregates.png'}: cannot write the file: No space left on device" in result.output
    assert files_in(out) == ["learning_curves.png", "learning_curves.svg"]  # complete files only
    result = invoke("plot", bench, "--out", out, "--reps", "20")
    assert result.exit_code == 0, result.output
    assert len(files_in(out)) == 10 and not [p for p in out.iterdir() if p.name.startswith(".")]


def test_plot_out_that_is_a_file_exits_2(bench, tmp_path):
    out = tmp_path / "taken"
    out.write_text("mine")
    result = invoke("plot", bench, "--out", out, "--reps", "20")
    assert result.exit_code == 2, result.output
    assert f"--out {out}: is a file, not a directory" in result.output
    assert out.read_text() == "mine"
