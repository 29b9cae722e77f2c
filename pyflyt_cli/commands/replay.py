"""``pyflyt replay FILE``: summary, re-simulation check, video and plot of a recorded episode.

The CLI in :mod:`pyflyt_cli.main` only parses arguments; :func:`run_replay` does the work
and returns the exit code (0 ok, 1 ``--verify`` found a state or reward deviation above the tolerance,
or an outcome -- return, termination, end reason, success -- the re-simulation does not reproduce);
user errors raise :class:`~pyflyt_engine.errors.PyFlytError` (exit 2, one message).

Nothing here writes over its input: outputs must be new files or files of the same kind,
and they are the only files written (each all at once, see
:func:`~pyflyt_cli.outputs.atomic_output`); nothing read from the recording names a file.
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Iterator
from pathlib import Path

import typer

from pyflyt_cli.errors import UsageError
from pyflyt_engine.errors import PyFlytError
from pyflyt_cli.outputs import atomic_output, check_output, parse_size


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
        raise UsageError(f"--tolerance must be >= 0, got {tolerance}")
    # check every output before any work (and before reading a large file)
    if video is not None:
        check_output(video, "--video", VIDEO_SUFFIXES, [file], "the input recording")
    if plot is not None:
        check_output(plot, "--plot", PLOT_SUFFIXES, [file], "the input recording")
    if video is not None and plot is not None and video.resolve() == plot.resolve():
        raise UsageError("--video and --plot name the same file")
    dims = parse_size(size) if size is not None else None
    if dims is not None and video is None:
        raise UsageError("--size applies to --video; give --video out.mp4 too")

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
            "outcome_differences": result.outcome_differences,
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
            if result.max_reward_deviation > tolerance:
                typer.echo(
                    f"          the recorded rewards differ from the re-simulated ones by up to "
                    f"{result.max_reward_deviation:.3g} (NaN or inf counts as differing), above the tolerance"
                )
            for difference in result.outcome_differences:
                typer.echo(f"          {difference}")
            for note in result.version_notes:
                typer.echo(f"          note: versions differ from the recording's: {note}")
        if not result.ok:
            code = 1
    if plot is not None:
        from pyflyt_engine.telemetry.plots import plot_episode

        with atomic_output(plot, "--plot") as tmp, _drawing(file, "--plot", plot):
            plot_episode(episode, tmp)
        report["plot"] = str(plot)
        if not as_json:
            typer.echo(f"plot      {plot}")
    if video is not None:
        from pyflyt_engine.telemetry.video import render_video

        with atomic_output(video, "--video") as tmp, _drawing(file, "--video", video):
            render_video(episode, tmp, size=dims)
        report["video"] = str(video)
        if not as_json:
            typer.echo(f"video     {video}")
    if as_json:
        typer.echo(json.dumps(report, indent=2))
    return code


@contextlib.contextmanager
def _drawing(recording: Path, option: str, out: Path) -> Iterator[None]:
    """Values a recorder never writes but a file may hold (a position of 1e308: matplotlib could not
    lay out its axes) are one line naming the recording, not a traceback; nothing is written."""
    try:
        yield
    except (ValueError, OverflowError, FloatingPointError) as exc:
        if isinstance(exc, PyFlytError):
            raise
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise UsageError(
            f"{option} {out}: cannot draw {recording}: its values cannot be drawn ({first}); "
            "check them with pyflyt replay --verify"
        ) from None
