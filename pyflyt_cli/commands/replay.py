"""``pyflyt replay FILE``: summary, re-simulation check, video and plot of a recorded episode.

The CLI in :mod:`pyflyt_cli.main` only parses arguments; :func:`run_replay` does the work
and returns the exit code (0 ok, 1 ``--verify`` found a deviation above the tolerance);
user errors raise :class:`~pyflyt_engine.errors.PyFlytError` (exit 2, one message).

Nothing here writes over its input: outputs must be new files or files of the same kind.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import typer

from pyflyt_cli.config import CLIError

_MAGIC = {
    ".png": (b"\x89PNG",),
    ".gif": (b"GIF8",),
    ".pdf": (b"%PDF",),
    ".svg": (b"<?xml", b"<svg"),
    ".mp4": (),  # checked below: 'ftyp' at offset 4
}


def parse_size(text: str) -> tuple[int, int]:
    """``"640x480"`` -> (640, 480), each side 16 ... 4096 pixels."""
    match = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not match:
        raise CLIError(f"--size '{text}': write WIDTHxHEIGHT in pixels, e.g. 640x480")
    width, height = int(match.group(1)), int(match.group(2))
    if not (16 <= width <= 4096 and 16 <= height <= 4096):
        raise CLIError(f"--size {width}x{height}: each side must be between 16 and 4096 pixels")
    return width, height


def check_output(path: Path, option: str, suffixes: tuple[str, ...], source: Path) -> Path:
    """Refuse an output that has the wrong suffix, is the input, or would replace another kind of file."""
    suffix = path.suffix.lower()
    if suffix not in suffixes:
        raise CLIError(f"{option} {path}: give a file name ending in {' or '.join(suffixes)}")
    if path.is_dir():
        raise CLIError(f"{option} {path}: is a directory; give a file name ending in {' or '.join(suffixes)}")
    if path.exists():
        if path.resolve() == source.resolve():
            raise CLIError(f"{option} {path}: that is the input recording; refusing to overwrite it")
        head = path.read_bytes()[:16]
        same_kind = head[4:8] == b"ftyp" if suffix == ".mp4" else any(head.startswith(m) for m in _MAGIC[suffix])
        if not same_kind:
            raise CLIError(
                f"{option} {path}: the file exists and is not a {suffix[1:].upper()} file; refusing to overwrite it "
                "(choose another name or delete it)"
            )
    if not path.parent.is_dir():
        raise CLIError(f"{option} {path}: the directory {path.parent} does not exist; create it first")
    return path


def run_replay(
    file: Path,
    *,
    verify: bool = False,
    tolerance: float = 1e-6,
    video: Path | None = None,
    size: str | None = None,
    plot: Path | None = None,
    as_json: bool = False,
) -> int:
    """Print the summary of ``file`` and do what the options ask; return the exit code."""
    from pyflyt_engine.telemetry import load_episode
    from pyflyt_engine.telemetry.plots import PLOT_SUFFIXES, VIDEO_SUFFIXES
    from pyflyt_engine.telemetry.replay import format_summary, summarize

    if not tolerance >= 0:
        raise CLIError(f"--tolerance must be >= 0, got {tolerance}")
    # check every output before any work (and before reading a large file)
    if video is not None:
        check_output(video, "--video", VIDEO_SUFFIXES, file)
    if plot is not None:
        check_output(plot, "--plot", PLOT_SUFFIXES, file)
    if video is not None and plot is not None and video.resolve() == plot.resolve():
        raise CLIError("--video and --plot name the same file")
    dims = parse_size(size) if size is not None else None
    if dims is not None and video is None:
        raise CLIError("--size applies to --video; give --video out.mp4 too")

    episode = load_episode(file, warn=False)
    summary = summarize(episode)
    report: dict = {"summary": summary}
    if not as_json:
        typer.echo(format_summary(summary))
        if episode.truncated:
            typer.secho(
                f"warning: {file} is truncated ({episode.truncation}); read up to its last complete chunk",
                err=True,
                fg=typer.colors.YELLOW,
            )

    code = 0
    if verify:
        from pyflyt_engine.telemetry.replay import verify as verify_episode

        result = verify_episode(episode, tolerance)
        report["verify"] = {
            "ok": result.ok,
            "steps": result.steps,
            "max_deviation": result.max_deviation,
            "worst_step": result.worst_step,
            "worst_field": result.worst_field,
            "max_reward_deviation": result.max_reward_deviation,
            "tolerance": tolerance,
            "per_field": result.per_field,
            "diverged_termination": result.diverged_termination,
            "version_notes": result.version_notes,
        }
        if not as_json:
            verdict = "OK" if result.ok else "FAILED"
            where = f" (step {result.worst_step}, {result.worst_field})" if result.max_deviation > 0 else ""
            typer.echo(
                f"verify    {verdict}: re-simulated {result.steps} steps; largest state deviation "
                f"{result.max_deviation:.3g}{where}, tolerance {tolerance:g}; largest reward deviation "
                f"{result.max_reward_deviation:.3g}"
            )
            if result.diverged_termination:
                typer.echo(f"          {result.diverged_termination}")
            for note in result.version_notes:
                typer.echo(f"          note: versions differ from the recording's: {note}")
        if not result.ok:
            code = 1
    if plot is not None:
        from pyflyt_engine.telemetry.plots import plot_episode

        plot_episode(episode, plot)
        report["plot"] = str(plot)
        if not as_json:
            typer.echo(f"plot      {plot}")
    if video is not None:
        from pyflyt_engine.telemetry.plots import render_video

        render_video(episode, video, size=dims)
        report["video"] = str(video)
        if not as_json:
            typer.echo(f"video     {video}")
    if as_json:
        typer.echo(json.dumps(report, indent=2))
    return code
