"""Telemetry in MCAP: training metrics, episode recordings, and the reader behind ``pyflyt replay``.

* :class:`MetricsWriter` / :func:`read_metrics` / :func:`set_aside_unreadable` — training and
  evaluation curves (``metrics.mcap`` and its append-only segments).
* :class:`RecordEpisode` — a Gymnasium wrapper writing one ``.mcap`` file per episode.
* :func:`load_episode` — an episode recording as arrays; :func:`read_mcap` — any MCAP file.
* :mod:`.replay` (summary, rebuild, verify) and :mod:`.plots` (figure, video) back ``pyflyt replay``.

See ``docs/mcap.md`` for the files' layout.  Importing this package does not import PyBullet.
"""

from __future__ import annotations

from typing import Any

from pyflyt_engine.errors import TelemetryError
from pyflyt_engine.telemetry.metrics import MetricsResult, MetricsWriter, read_metrics, set_aside_unreadable
from pyflyt_engine.telemetry.reader import (
    CorruptRecordingWarning,
    McapContents,
    TruncatedRecordingWarning,
    read_mcap,
)

__all__ = [
    "CorruptRecordingWarning",
    "Episode",
    "McapContents",
    "MetricsResult",
    "MetricsWriter",
    "RecordEpisode",
    "TelemetryError",
    "TruncatedRecordingWarning",
    "load_episode",
    "read_mcap",
    "read_metrics",
    "set_aside_unreadable",
]


def __getattr__(name: str) -> Any:
    # lazy: the recorder pulls in Gymnasium, the episode reader the recorder's constants
    if name == "RecordEpisode":
        from pyflyt_engine.telemetry.recorder import RecordEpisode

        return RecordEpisode
    if name in ("Episode", "load_episode"):
        from pyflyt_engine.telemetry import episode

        return getattr(episode, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
