"""Training and evaluation curves in MCAP: :class:`MetricsWriter` and :func:`read_metrics`.

A run's metrics live in ``<run>/metrics.mcap``.  Each topic (``/train/episode``, ``/eval``,
``/train/progress`` ...) is one JSON channel whose messages are flat records
``{"step": int, "wall_time": float, <name>: number | string | bool, ...}``.

* **Log time** of every message is its ``wall_time`` (Unix time, ns); the x-axis a user plots
  against is usually ``step`` (the environment step count), which is in the payload.
* **Append-only segments**: nothing is ever rewritten.  Resuming writes the next *segment*
  ``metrics-1.mcap``, ``metrics-2.mcap`` ... next to ``metrics.mcap``
  (``MetricsWriter(path, append=True, resumed_from=N)``), whose *marker* ``resumed_from=N``
  says it continues the run from its checkpoint at step ``N``: :func:`read_metrics`
  concatenates the segments in order and drops, at each marker, the earlier records at steps
  ``> N`` (the continuation logs them again), so an interrupted and resumed run reads exactly
  like an uninterrupted one.  Creating a segment is the only step of a resume, and a kill at
  any instant of it leaves the series reading as before or as after it.
* **Damage is skipped, never fatal**: an unreadable segment (empty, not MCAP, no readable
  metadata) is left out, a damaged chunk is stepped over, and both are reported; only a
  series with nothing readable raises.  :func:`set_aside_unreadable` renames unreadable
  segments out of the series (it never deletes).
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
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from pyflyt_engine import numerics
from pyflyt_engine.errors import TelemetryError
from pyflyt_engine.telemetry._io import DEFAULT_FLUSH_INTERVAL, McapFileWriter, to_ns
from pyflyt_engine.telemetry.reader import (
    CorruptRecordingWarning,
    McapContents,
    TruncatedRecordingWarning,
    read_mcap,
)

METRICS_FILE = "metrics.mcap"
#: metadata record naming the file kind and its segment index
FILE_INFO = "pyflyt"
#: metadata record holding the caller's ``metadata`` dict
RUN_INFO = "run"
#: key of the ``FILE_INFO`` record: the checkpoint step a resumed segment continues from
RESUMED_FROM = "resumed_from"
#: suffix given to a segment set aside by :func:`set_aside_unreadable`
UNREADABLE_SUFFIX = ".unreadable"
SCHEMA_NAME = "pyflyt.Metrics"
_RESERVED = ("step", "wall_time")
_SEGMENT = re.compile(r"^(?P<base>.+?)(?:-(?P<n>\d+))?\.mcap$")


class MetricsResult(dict):
    """``topic -> records`` as returned by :func:`read_metrics`, plus where the records came from."""

    #: the segment files read, in order (unreadable ones are not among them)
    segments: list[Path]
    #: the ``metadata`` given to each of their writers, in the same order
    metadata: list[dict[str, str]]
    #: the segments that were cut short (their writer was killed); empty if all are complete
    truncated: list[Path]
    #: segments with damaged parts that were skipped, and what was lost with them
    damaged: list[tuple[Path, str]]
    #: segments left out because nothing in them could be read, and why
    unreadable: list[tuple[Path, str]]
    #: records dropped because a later segment's marker says the run was resumed before them
    superseded: int


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
        resumed_from: the step of the checkpoint this segment continues the run from (0 for
            a run restarted from scratch): readers drop the records of earlier segments at
            steps above it.  The marker is on disk when the constructor returns.
        flush_interval: longest wall time (s) a logged record waits in memory before it is
            written to the OS (bounded loss if the process is killed).

    Use as a context manager (or call :meth:`close`); the file is also finished at
    interpreter exit.  Thread-safe.

    Raises:
        TelemetryError: the file exists and ``append`` is False, it cannot be created, or
            ``resumed_from`` is not a non-negative integer.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        metadata: dict[str, str] | None = None,
        *,
        append: bool = False,
        resumed_from: int | None = None,
        flush_interval: float = DEFAULT_FLUSH_INTERVAL,
    ) -> None:
        if resumed_from is not None and not (
            isinstance(resumed_from, (int, np.integer)) and not isinstance(resumed_from, bool) and resumed_from >= 0
        ):
            raise TelemetryError(f"resumed_from must be a step count (an integer >= 0) or None, got {resumed_from!r}")
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

        info = {"kind": "metrics", "segment": str(index), "pyflyt_engine": __version__, "log_time": "wall_time"}
        if resumed_from is not None:
            info[RESUMED_FROM] = str(int(resumed_from))
        self.resumed_from = None if resumed_from is None else int(resumed_from)
        try:  # the marker reaches the disk with the file's first bytes, before anything is logged
            self._file.metadata(FILE_INFO, info, flush=False)
            self._file.metadata(RUN_INFO, {str(k): str(v) for k, v in (metadata or {}).items()}, flush=False)
            self._file.metadata(numerics.MCAP_RECORD, numerics.mcap_record(), flush=False)
            self._file.flush(sync=True)
        except BaseException:
            self._file.close()
            raise
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


def _without_path(message: str, path: Path) -> str:
    """A reader's error about ``path`` as a reason: "<path> is not an MCAP file" -> "not an MCAP file"."""
    return message.removeprefix(str(path)).lstrip(": ").removeprefix("is ")


def _read_segment(path: Path) -> tuple[McapContents | None, int | None, str]:
    """(contents, resumed_from marker, "") of a readable metrics segment; (None, None, why) otherwise."""
    try:
        contents = read_mcap(path, warn=False, skip_damage=True)
    except TelemetryError as exc:
        return None, None, _without_path(str(exc), path)
    info = contents.metadata.get(FILE_INFO, {})
    if info.get("kind") != "metrics":
        kind = info.get("kind")
        what = f"a pyflyt {kind} file" if kind else "no readable metadata record of MetricsWriter"
        return None, None, f"not a metrics file ({what})"
    marker = info.get(RESUMED_FROM)
    if marker is None:
        return contents, None, ""
    if not marker.isdigit():
        return None, None, f"its {RESUMED_FROM} marker is damaged ({marker!r})"
    return contents, int(marker), ""


def _series_paths(path: str | os.PathLike[str]) -> list[Path]:
    segments = segment_paths(path)
    if segments:
        return segments
    p = Path(path)
    if p.is_file():
        return [p]
    where = p if p.is_dir() else p.parent
    raise TelemetryError(f"no metrics file at {p} (expected {where / METRICS_FILE})")


def read_metrics(path: str | os.PathLike[str]) -> MetricsResult:
    """Read a run's metrics: ``topic -> [record, ...]`` over all segments, in log order.

    Args:
        path: a run directory, ``metrics.mcap``, or any of its segments ``metrics-<n>.mcap``
            (all segments of the series are read either way).

    Each record holds ``step``, ``wall_time`` and the logged values (``null`` read as ``nan``).
    Segments are concatenated in order; a segment whose marker is ``resumed_from=N`` first
    drops the records of the segments before it at steps ``> N`` (counted in
    ``result.superseded``).  Nothing readable is left out, and everything left out is reported
    (see :class:`MetricsResult`):

    * a segment cut short (killed writer) is read up to its last complete chunk, listed in
      ``result.truncated`` and warned about (:class:`TruncatedRecordingWarning`);
    * a damaged chunk or record is skipped and the rest of its segment read; the segment and
      what was lost are listed in ``result.damaged`` (:class:`CorruptRecordingWarning`);
    * a segment with nothing readable (empty, not MCAP, not a metrics file) is skipped and
      listed in ``result.unreadable`` with the reason (:class:`CorruptRecordingWarning`).

    Raises:
        TelemetryError: no metrics file there, or no segment of it is readable.
    """
    result = MetricsResult()
    result.segments, result.metadata, result.truncated, result.damaged, result.unreadable = [], [], [], [], []
    result.superseded = 0
    for seg, contents, marker in _readable_segments(path, result.unreadable):
        result.segments.append(seg)
        result.metadata.append(contents.metadata.get(RUN_INFO, {}))
        if marker is not None:
            for topic, records in result.items():
                kept = [r for r in records if r["step"] <= marker]
                result.superseded += len(records) - len(kept)
                result[topic] = kept
        _add_records(result, seg, contents)
    for seg, problem in result.unreadable:
        warnings.warn(f"{seg}: skipped, unreadable: {problem}", CorruptRecordingWarning, stacklevel=2)
    if not result.segments:
        raise _nothing_readable(path, result.unreadable)
    return result


def _add_records(result: MetricsResult, seg: Path, contents: McapContents) -> None:
    """Append a segment's records to ``result`` and report what it lacks (truncation, damage)."""
    if contents.truncated:
        result.truncated.append(seg)
        warnings.warn(
            f"{seg}: truncated ({contents.truncation}); read up to its last complete chunk",
            TruncatedRecordingWarning,
            stacklevel=3,
        )
    malformed = 0
    for msg in contents.messages:
        if not isinstance(msg.data, dict) or not isinstance(msg.data.get("step"), int):
            malformed += 1  # not a record MetricsWriter writes: skipped like damage
            continue
        rec = {k: (math.nan if v is None else v) for k, v in msg.data.items()}
        result.setdefault(msg.topic, []).append(rec)
    loss = contents.loss()
    if malformed:
        loss = "; ".join(filter(None, [loss, f"{malformed} messages that are not metrics records skipped"]))
    if loss:
        result.damaged.append((seg, loss))
        warnings.warn(f"{seg}: damaged, {loss}", CorruptRecordingWarning, stacklevel=3)


def _readable_segments(
    path: str | os.PathLike[str], unreadable: list[tuple[Path, str]]
) -> Iterator[tuple[Path, McapContents, int | None]]:
    """(path, contents, marker) of each readable segment of the series; the others go to ``unreadable``."""
    for seg in _series_paths(path):
        contents, marker, problem = _read_segment(seg)
        if contents is None:
            unreadable.append((seg, problem))
        else:
            yield seg, contents, marker


def _nothing_readable(path: str | os.PathLike[str], unreadable: list[tuple[Path, str]]) -> TelemetryError:
    why = "; ".join(f"{p.name}: {problem}" for p, problem in unreadable)
    return TelemetryError(f"no readable metrics at {Path(path)}: {why}")


def read_metrics_metadata(path: str | os.PathLike[str]) -> list[dict[str, str]]:
    """The ``metadata`` given to each readable segment's writer, in segment order.

    Unreadable segments are left out (as by :func:`read_metrics`, without a warning).

    Raises:
        TelemetryError: no metrics file there, or no segment of it is readable.
    """
    unreadable: list[tuple[Path, str]] = []
    found = [contents.metadata.get(RUN_INFO, {}) for _, contents, _ in _readable_segments(path, unreadable)]
    if not found:
        raise _nothing_readable(path, unreadable)
    return found


def set_aside_unreadable(path: str | os.PathLike[str]) -> list[tuple[Path, Path, str]]:
    """Rename every unreadable segment of a run's metrics out of the series; never deletes a file.

    Args:
        path: a run directory, ``metrics.mcap`` or any segment of the series.

    Each segment :func:`read_metrics` would skip as unreadable becomes ``<name>.unreadable``
    (``<name>.unreadable-1``, ... if that exists: nothing is overwritten) and is no longer part
    of the series.  Segments that are truncated or partly damaged are readable and stay.
    Call it before creating the next writer, never while another process writes the series
    (the segment it has just created is empty until its first flush).

    Returns:
        ``(old path, new path, why it is unreadable)`` for each segment set aside, in order.
    """
    moved = []
    for seg in segment_paths(path):
        contents, _, problem = _read_segment(seg)
        if contents is None:
            moved.append((seg, _rename_aside(seg), problem))
    return moved


def _rename_aside(path: Path) -> Path:
    """Give ``path`` the first free name ``<name>.unreadable[-k]`` without replacing any file."""
    k = 0
    while True:
        target = path.with_name(path.name + UNREADABLE_SUFFIX + (f"-{k}" if k else ""))
        k += 1
        try:
            os.link(path, target)  # fails if the target exists: never overwrites
        except FileExistsError:
            if not os.path.samefile(path, target):  # (the same file: linked by a call cut short)
                continue
        except OSError:  # no hard links on this file system
            if target.exists():
                continue
            os.rename(path, target)
            return target
        os.unlink(path)  # the data stays under the new name
        return target
