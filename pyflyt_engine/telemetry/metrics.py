"""Training and evaluation curves in MCAP: :class:`MetricsWriter` and :func:`read_metrics`.

A run's metrics live in ``<run>/metrics.mcap``.  Each topic (``/train/episode``, ``/eval``,
``/train/progress`` ...) is one JSON channel whose messages are flat records
``{"step": int, "wall_time": float, <name>: number | string | bool, ...}``.

* **Log time** of every message is its ``wall_time`` (Unix time, ns); the x-axis a user plots
  against is usually ``step`` (the environment step count), which is in the payload.
* **Resuming** never reopens a finished file: ``MetricsWriter(path, append=True)`` writes the
  next *segment* ``metrics-1.mcap``, ``metrics-2.mcap`` ... next to ``metrics.mcap``, and
  :func:`read_metrics` concatenates the segments in order.
* Non-finite floats are stored as JSON ``null`` and read back as ``nan``.
* Crash safety is that of every telemetry file (``docs/mcap.md``): at most ~1 s of logging is
  lost if the process is killed, and the reader reports the truncation.

Example::

    with MetricsWriter(run_dir / "metrics.mcap", metadata={"algo": "sac", "seed": "3"}) as m:
        m.log("/train/episode", step=1200, values={"return": -31.5, "length": 240})
    curves = read_metrics(run_dir)          # {"/train/episode": [{"step": 1200, ...}], ...}
"""

from __future__ import annotations

import math
import os
import re
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from pyflyt_engine.errors import TelemetryError
from pyflyt_engine.telemetry._io import DEFAULT_FLUSH_INTERVAL, McapFileWriter, to_ns
from pyflyt_engine.telemetry.reader import TruncatedRecordingWarning, read_mcap

METRICS_FILE = "metrics.mcap"
#: metadata record naming the file kind and its segment index
FILE_INFO = "pyflyt"
#: metadata record holding the caller's ``metadata`` dict
RUN_INFO = "run"
SCHEMA_NAME = "pyflyt.Metrics"
_RESERVED = ("step", "wall_time")
_SEGMENT = re.compile(r"^(?P<base>.+?)(?:-(?P<n>\d+))?\.mcap$")


class MetricsResult(dict):
    """``topic -> records`` as returned by :func:`read_metrics`, plus where the records came from."""

    #: the segment files read, in order
    segments: list[Path]
    #: the segments that were cut short (their writer was killed); empty if all are complete
    truncated: list[Path]


def _json_type(value: Any) -> str:
    if isinstance(value, (bool, np.bool_)):
        return "boolean"
    if isinstance(value, (int, float, np.integer, np.floating)):
        return "number"
    if isinstance(value, str):
        return "string"
    raise TelemetryError(f"metric values must be numbers, strings or booleans, got {type(value).__name__} ({value!r})")


def _plain(value: Any) -> Any:
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        value = float(value)
        return value if math.isfinite(value) else None
    return value


def _series(path: Path) -> tuple[Path, str]:
    """(directory, base name) of the segment series ``path`` belongs to."""
    if path.is_dir() or path.suffix != ".mcap":
        if path.suffix and not path.is_dir():
            raise TelemetryError(f"{path}: a metrics file must end in .mcap")
        return path, "metrics"
    m = _SEGMENT.match(path.name)
    assert m is not None
    return path.parent, m["base"]


def segment_paths(path: str | os.PathLike[str]) -> list[Path]:
    """The existing segment files of a metrics series, in order.

    ``path`` is a run directory (reads ``metrics.mcap`` and ``metrics-<n>.mcap``) or any
    segment file of the series.
    """
    folder, base = _series(Path(path))
    found: list[tuple[int, Path]] = []
    if folder.is_dir():
        for p in folder.iterdir():
            m = _SEGMENT.match(p.name)
            if m and m["base"] == base and p.is_file():
                found.append((int(m["n"] or 0), p))
    return [p for _, p in sorted(found)]


class MetricsWriter:
    """Append-only writer of training/evaluation metrics to one MCAP segment file.

    Args:
        path: ``.../metrics.mcap`` (or a run directory, meaning ``<dir>/metrics.mcap``).
        metadata: string key/values stored once in the file (e.g. algorithm, seed, config hash).
        append: if the file already exists, write the next segment (``metrics-<n>.mcap``)
            instead of failing; use it when resuming a run.
        flush_interval: longest wall time (s) a logged record waits in memory before it is
            written to the OS (bounded loss if the process is killed).

    Use as a context manager (or call :meth:`close`); the file is also finished at
    interpreter exit.  Thread-safe.

    Raises:
        TelemetryError: the file exists and ``append`` is False, or it cannot be created.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        metadata: dict[str, str] | None = None,
        *,
        append: bool = False,
        flush_interval: float = DEFAULT_FLUSH_INTERVAL,
    ) -> None:
        path = Path(path)
        if path.is_dir():
            path = path / METRICS_FILE
        folder, base = _series(path)
        existing = segment_paths(path)
        if path.exists() or existing:
            if not append:
                raise TelemetryError(
                    f"{path} already exists; pass append=True to continue the run in a new segment "
                    f"({base}-{len(existing)}.mcap), or choose another file"
                )
            last = _SEGMENT.match(existing[-1].name) if existing else None
            index = int(last["n"] or 0) + 1 if last else 0
        else:
            index = 0
        self.segment = index
        self.path = folder / (f"{base}.mcap" if index == 0 else f"{base}-{index}.mcap")
        self._file = McapFileWriter(self.path, flush_interval=flush_interval, chunk_size=64 * 1024)
        from pyflyt_engine import __version__

        self._file.metadata(
            FILE_INFO,
            {"kind": "metrics", "segment": str(index), "pyflyt_engine": __version__, "log_time": "wall_time"},
        )
        self._file.metadata(RUN_INFO, {str(k): str(v) for k, v in (metadata or {}).items()})
        self._types: dict[str, dict[str, str]] = {}

    def log(
        self,
        topic: str,
        step: int,
        values: dict[str, float | int | str | bool],
        wall_time: float | None = None,
    ) -> None:
        """Record ``values`` at environment step ``step`` on ``topic``.

        Args:
            topic: e.g. ``"/train/episode"``, ``"/eval"``.
            step: environment steps so far (the curve's x-axis).
            values: flat name -> number/string/bool (numpy scalars accepted; NaN/inf stored as null).
            wall_time: Unix time in seconds; default now.  Also the message's MCAP log time.

        Raises:
            TelemetryError: bad topic, reserved or non-string names, unsupported value types, a
                value whose type differs from the first record on the topic, or a closed writer.
        """
        if not isinstance(topic, str) or not topic:
            raise TelemetryError(f"metrics topic must be a non-empty string, got {topic!r}")
        if isinstance(step, (bool, np.bool_)) or not isinstance(step, (int, np.integer)):
            raise TelemetryError(f"{topic}: step must be an integer, got {step!r}")
        for key in values:
            if not isinstance(key, str):
                raise TelemetryError(f"{topic}: metric names must be strings, got {key!r}")
            if key in _RESERVED:
                raise TelemetryError(f"{topic}: {key!r} is reserved (pass it as the argument, not in values)")
        types = {k: _json_type(v) for k, v in values.items()}
        wall = time.time() if wall_time is None else float(wall_time)
        declared = self._types.get(topic)
        if declared is None:
            props: dict[str, Any] = {"step": {"type": "integer"}, "wall_time": {"type": "number"}}
            for k, t in types.items():
                props[k] = {"type": ["number", "null"]} if t == "number" else {"type": t}
            schema = {
                "title": SCHEMA_NAME,
                "description": f"pyflyt metrics on {topic}",
                "type": "object",
                "properties": props,
                "required": ["step", "wall_time"],
                "additionalProperties": {"type": ["number", "string", "boolean", "null"]},
            }
            self._file.channel(topic, SCHEMA_NAME, schema)
            self._types[topic] = declared = dict(types)
        else:
            for k, t in types.items():
                if declared.setdefault(k, t) != t:
                    raise TelemetryError(f"{topic}: {k!r} was logged as a {declared[k]}, now as a {t} ({values[k]!r})")
        record = {"step": int(step), "wall_time": wall}
        record.update({k: _plain(v) for k, v in values.items()})
        cid = self._file.channel(topic, SCHEMA_NAME, {})
        self._file.write(cid, to_ns(wall), record)

    def flush(self) -> None:
        """Push everything logged so far to the OS now."""
        self._file.flush()

    def close(self) -> None:
        """Finish the file (idempotent)."""
        self._file.close()

    def __enter__(self) -> MetricsWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def read_metrics(path: str | os.PathLike[str]) -> MetricsResult:
    """Read a run's metrics: ``topic -> [record, ...]`` over all segments, in log order.

    Args:
        path: a run directory, ``metrics.mcap``, or any of its segments ``metrics-<n>.mcap``
            (all segments of the series are read either way).

    Each record holds ``step``, ``wall_time`` and the logged values (``null`` read as ``nan``).
    A segment cut short (killed writer) is read up to its last complete chunk, listed in
    ``result.truncated`` and reported with a :class:`TruncatedRecordingWarning`.

    Raises:
        TelemetryError: no metrics file there, not an MCAP file, corrupt, or not a metrics file.
    """
    segments = segment_paths(path)
    if not segments:
        p = Path(path)
        if p.is_file():
            segments = [p]
        else:
            where = p if p.is_dir() else p.parent
            raise TelemetryError(f"no metrics file at {p} (expected {where / METRICS_FILE})")
    result = MetricsResult()
    result.segments = segments
    result.truncated = []
    for seg in segments:
        contents = read_mcap(seg, warn=False)
        info = contents.metadata.get(FILE_INFO, {})
        if info.get("kind") != "metrics":
            kind = info.get("kind")
            what = f"a pyflyt {kind} file" if kind else "not written by MetricsWriter"
            raise TelemetryError(f"{seg} is not a metrics file ({what})")
        if contents.truncated:
            result.truncated.append(seg)
            warnings.warn(
                f"{seg}: truncated ({contents.truncation}); read up to its last complete chunk",
                TruncatedRecordingWarning,
                stacklevel=2,
            )
        for msg in contents.messages:
            if not isinstance(msg.data, dict):
                raise TelemetryError(f"{seg}: a message on {msg.topic} is not a JSON object")
            rec = {k: (math.nan if v is None else v) for k, v in msg.data.items()}
            result.setdefault(msg.topic, []).append(rec)
    return result


def read_metrics_metadata(path: str | os.PathLike[str]) -> list[dict[str, str]]:
    """The ``metadata`` dict given to each segment's writer, in segment order."""
    return [read_mcap(p, warn=False).metadata.get(RUN_INFO, {}) for p in segment_paths(path) or [Path(path)]]
