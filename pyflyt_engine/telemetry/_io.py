"""Crash-safe MCAP writing with JSON-schema channels (the one writer every telemetry file uses).

Guarantees (see ``docs/mcap.md``, "Crash safety"):

* **Never overwrites**: the file is created with ``O_EXCL`` under its final name; an existing
  file is an error.
* **Always finished**: :meth:`McapFileWriter.close` writes the summary and footer; it is
  called by the owners' context managers, and by a ``weakref.finalize`` hook that also runs at
  interpreter exit (normal exit, unhandled exception, Ctrl-C).  A forked child never
  finishes its parent's file.
* **Never left half-way through a record**: Python runs signal handlers in the main thread
  between two bytecodes, so a handler that raises (``KeyboardInterrupt`` on Ctrl-C) could stop
  the ``mcap`` writer in the middle of a record and the file finished afterwards would be
  corrupt.  :meth:`McapFileWriter.write` therefore only queues the message; the ``mcap`` writer
  runs in short sections (:func:`signals_held`) during which SIGINT/SIGTERM handlers wait and
  run right after.
* **Small loss on a hard kill** (SIGKILL, power cut of the process): messages are grouped in
  chunks that are closed and flushed to the OS when the owner asks (:meth:`flush`, e.g. every
  simulated second), when a chunk reaches ``chunk_size`` bytes, and by a background thread
  when buffered messages are older than ``flush_interval`` seconds of wall time.  A file cut
  short therefore stays readable up to its last complete chunk.
* **Never left cut by a failed write** (``discard_on_error=True``, episode recordings): a
  write the OS refuses (a full disk, a file-size limit, a read-only disk) closes the file,
  removes it, and raises one :class:`TelemetryError` naming it and the reason; the writer
  refuses everything after.  Without it (the metrics, whose earlier records a resume
  needs) the ``OSError`` reaches the caller as it is.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import signal
import threading
import time
import weakref
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from mcap.writer import CompressionType, Writer

from pyflyt_engine.errors import TelemetryError

try:  # the C module behind `signal`, without its enum conversions (~50x faster per call)
    import _signal as _sig
except ImportError:  # pragma: no cover - other Python implementations
    _sig = signal

#: Default upper bound on one chunk's uncompressed size (bytes).
DEFAULT_CHUNK_SIZE = 256 * 1024
#: Default longest wall time (s) a logged message may stay in memory before reaching the OS.
DEFAULT_FLUSH_INTERVAL = 1.0


def to_ns(seconds: float) -> int:
    """Seconds (float) -> MCAP timestamp: non-negative integer nanoseconds."""
    return max(0, round(seconds * 1e9))


def _finite(obj: Any) -> Any:
    """Replace non-finite floats by None (JSON has no NaN/Infinity), recursively."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    return obj


def _plain(obj: Any) -> Any:
    """numpy arrays/scalars the fast path could not take, as Python values."""
    if hasattr(obj, "tolist"):
        return obj.tolist()
    raise TypeError(f"{type(obj).__name__} is not JSON serializable")


def _encode_stdlib(message: dict[str, Any]) -> bytes:
    try:
        return json.dumps(message, separators=(",", ":"), allow_nan=False, default=_plain).encode()
    except ValueError:  # NaN / Infinity somewhere
        return json.dumps(
            _finite(json.loads(json.dumps(message, default=_plain))), separators=(",", ":"), allow_nan=False
        ).encode()


try:  # orjson: ~15x faster on float-heavy messages; same text (shortest round-trip floats)
    import orjson

    _ORJSON_OPTIONS = orjson.OPT_SERIALIZE_NUMPY

    def encode_json(message: dict[str, Any]) -> bytes:
        """Compact, strict JSON (non-finite floats become ``null``; numpy values accepted)."""
        try:
            return orjson.dumps(message, option=_ORJSON_OPTIONS, default=_plain)
        except TypeError:  # e.g. a non-contiguous array, non-string keys: the slow, general path
            return _encode_stdlib(message)

except ImportError:  # pragma: no cover - orjson is a dependency; the stdlib path stays correct
    encode_json = _encode_stdlib


_SCHEMA_TEXT: dict[int, tuple[dict[str, Any], str]] = {}


def _schema_text(schema: dict[str, Any]) -> str:
    """Canonical JSON text of a schema, cached for the module-level schema dicts."""
    cached = _SCHEMA_TEXT.get(id(schema))
    if cached is not None and cached[0] is schema:
        return cached[1]
    text = json.dumps(schema, separators=(",", ":"), sort_keys=True)
    if len(_SCHEMA_TEXT) < 256:
        _SCHEMA_TEXT[id(schema)] = (schema, text)  # keeps the dict alive, so its id stays unique
    return text


#: signals whose Python handlers wait while the mcap writer is between two records
HELD_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class _Hold:
    """The handler installed by :func:`signals_held`: notes a signal, or passes it on once the section ended."""

    def __init__(self) -> None:
        self.active = True
        self.replaced: dict[int, Any] = {}
        self.fired: list[int] = []

    def __call__(self, signum: int, frame: Any) -> None:
        if self.active:
            self.fired.append(signum)
        else:  # left installed by an exception during the restore: behave as the handler it replaced
            self.replaced[signum](signum, frame)


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """Run the block with the Python handlers of :data:`HELD_SIGNALS` held; those that fired run after it.

    Only the main thread runs signal handlers, so elsewhere this does nothing.  Signals left at
    the default or ignored disposition are not touched (a default SIGTERM still ends the
    process at once, like a kill).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    hold = _Hold()
    try:
        for sig in HELD_SIGNALS:
            handler = _sig.getsignal(sig)
            if callable(handler):
                hold.replaced[sig] = handler  # before installing: an exception in between loses nothing
                _sig.signal(sig, hold)
        yield
    finally:
        hold.active = False
        for signum, handler in hold.replaced.items():
            _sig.signal(signum, handler)
        for signum in hold.fired:
            hold.replaced[signum](signum, None)


class _Flusher:
    """One daemon thread per process that flushes writers whose buffered data got old."""

    def __init__(self) -> None:
        self._writers: weakref.WeakSet[McapFileWriter] = weakref.WeakSet()
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._pid = os.getpid()

    def add(self, writer: McapFileWriter) -> None:
        with self._lock:
            if self._pid != os.getpid():  # forked: the parent's thread does not exist here
                self._writers = weakref.WeakSet()
                self._thread = None
                self._pid = os.getpid()
            self._writers.add(writer)
            if self._thread is None or not self._thread.is_alive():
                self._thread = threading.Thread(target=self._run, name="pyflyt-mcap-flush", daemon=True)
                self._thread.start()

    def _run(self) -> None:
        while True:
            time.sleep(0.2)
            with self._lock:
                writers = list(self._writers)
            for writer in writers:
                writer._flush_if_stale()


_FLUSHER = _Flusher()


class _OpenFile:
    """An open file and its ``mcap`` writer: all the exit hook needs (it must not hold the McapFileWriter)."""

    def __init__(self, writer: Writer, stream: Any, path: Path, discard_on_error: bool) -> None:
        self.writer = writer
        self.stream = stream
        self.path = path
        self.discard_on_error = discard_on_error
        #: the write the OS refused (``discard_on_error`` only); the file is then closed and removed
        self.failed: OSError | None = None
        #: whether that failure was raised to a caller already (the exit hook then stays quiet)
        self.reported = False
        self.lock = threading.RLock()
        self.pid = os.getpid()
        #: messages queued by ``write``: (channel id, log time, payload, sequence)
        self.queued: list[tuple[int, int, bytes, int]] = []
        self.queued_bytes = 0

    def commit(self) -> None:
        """Give the queued messages to the ``mcap`` writer (call with the lock and signals held)."""
        queued, self.queued, self.queued_bytes = self.queued, [], 0
        for channel_id, log_time, data, sequence in queued:
            self.writer.add_message(channel_id, log_time, data, log_time, sequence)

    def finish(self) -> None:
        if os.getpid() != self.pid:  # a forked child must not finish (and corrupt) its parent's file
            return
        with signals_held(), self.lock:
            if not self.discard_on_error:
                try:
                    self.commit()
                    self.writer.finish()
                finally:
                    self.stream.close()
                return
            try:
                try:
                    if self.failed is None:
                        self.commit()
                        self.writer.finish()
                finally:
                    self.stream.close()  # closes the descriptor even when its last flush fails
            except OSError as exc:
                if self.failed is None:
                    self.failed = exc
            if self.failed is not None:
                self.path.unlink(missing_ok=True)  # created by this writer (O_EXCL): nothing else is removed
                if not self.reported:
                    self.reported = True
                    raise self.error() from None

    def error(self) -> TelemetryError:
        """The one-line error for :attr:`failed`."""
        exc = self.failed
        reason = (exc.strerror if exc is not None else None) or str(exc)
        return TelemetryError(f"cannot write {self.path}: {reason}; the unfinished recording was removed")


class McapFileWriter:
    """An MCAP file of JSON messages on JSON-schema channels, written crash-safely.

    Args:
        path: file to create; must not exist (parent directories are created).
        chunk_size: close a chunk once its uncompressed data reaches this many bytes.
        flush_interval: longest wall time (s) buffered messages wait before being flushed.
        compression: ``"zstd"`` (default), ``"lz4"`` or ``"none"``.
        discard_on_error: a write the OS refuses (full disk, file-size limit) closes and
            removes the file and raises :class:`TelemetryError` (once; the writer then
            refuses every call), instead of passing the ``OSError`` on and leaving the file.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        chunk_size: int = DEFAULT_CHUNK_SIZE,
        flush_interval: float = DEFAULT_FLUSH_INTERVAL,
        compression: str = "zstd",
        discard_on_error: bool = False,
    ) -> None:
        self.path = Path(path)
        if self.path.is_dir():
            raise TelemetryError(f"{self.path} is a directory, not an .mcap file to create")
        comp = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "none": CompressionType.NONE}
        if compression not in comp:
            raise TelemetryError(f"compression must be one of {sorted(comp)}, got {compression!r}")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        try:
            stream = open(self.path, "xb")  # O_EXCL: never write over a file
        except FileExistsError:
            raise TelemetryError(
                f"{self.path} already exists; refusing to overwrite it (choose another name)"
            ) from None
        except OSError as exc:
            raise TelemetryError(f"cannot create {self.path}: {exc.strerror}") from None
        writer = Writer(stream, chunk_size=chunk_size, compression=comp[compression], enable_data_crcs=True)
        self._file = _OpenFile(writer, stream, self.path, discard_on_error)
        self._lock = self._file.lock
        # The mcap package closes chunks by size only; its (name-mangled) chunk finaliser lets
        # us also close them by time.  Without it (other mcap versions) size is the only policy.
        self._finalize_chunk = getattr(writer, "_Writer__finalize_chunk", None)
        self._chunk_size = chunk_size
        self._schemas: dict[tuple[str, str], int] = {}
        self._channels: dict[str, int] = {}
        self._sequence: dict[int, int] = {}
        self._flush_interval = flush_interval
        self._dirty_since: float | None = None
        self._closed = False
        self._pid = os.getpid()
        self._finalizer = weakref.finalize(self, _OpenFile.finish, self._file)
        with self._writing():
            writer.start(profile="", library="pyflyt_engine")
        _FLUSHER.add(self)

    @contextlib.contextmanager
    def _writing(self) -> Iterator[None]:
        """A section that hands records to the file: signals held, the lock taken; with
        ``discard_on_error`` an ``OSError`` in it closes and removes the file, then raises once."""
        with signals_held(), self._lock:
            if not self._file.discard_on_error:
                yield
                return
            try:
                yield
            except OSError as exc:
                self._file.failed = exc
                self._file.reported = True
                self._closed = True
                self._finalizer()  # closes and removes the file (the failure is raised here, not there)
                raise self._file.error() from None

    # ------------------------------------------------------------------ channels
    def channel(
        self, topic: str, schema_name: str, schema: dict[str, Any], metadata: dict[str, str] | None = None
    ) -> int:
        """Register (once) a JSON channel on ``topic`` with a JSON schema; return its id."""
        cid = self._channels.get(topic)
        if cid is not None:
            return cid
        with self._writing():
            if topic in self._channels:
                return self._channels[topic]
            self._check_open()
            text = _schema_text(schema)
            key = (schema_name, text)
            if key not in self._schemas:
                self._schemas[key] = self._file.writer.register_schema(schema_name, "jsonschema", text.encode())
            cid = self._file.writer.register_channel(topic, "json", self._schemas[key], metadata or {})
            self._sequence[cid] = 0
            self._channels[topic] = cid
            return cid

    def has_channel(self, topic: str) -> bool:
        return topic in self._channels

    # ------------------------------------------------------------------ records
    def write(self, channel_id: int, log_time_ns: int, message: dict[str, Any]) -> None:
        """Append one JSON message (``log_time_ns`` also used as publish time)."""
        self.write_raw(channel_id, log_time_ns, encode_json(message))

    def write_raw(self, channel_id: int, log_time_ns: int, data: bytes) -> None:
        """Queue one message; it reaches the file at the next flush (or once a chunk's worth is queued)."""
        file = self._file
        with self._lock:
            self._check_open()
            seq = self._sequence[channel_id]
            self._sequence[channel_id] = seq + 1
            file.queued.append((channel_id, log_time_ns, data, seq))
            file.queued_bytes += len(data)
            if self._dirty_since is None:
                self._dirty_since = time.monotonic()
            full = file.queued_bytes >= self._chunk_size
        if full:
            self.flush()

    def metadata(self, name: str, data: dict[str, str], *, flush: bool = True) -> None:
        """Write a metadata record (handed to the OS now unless ``flush=False``)."""
        bad = [k for k, v in data.items() if not isinstance(k, str) or not isinstance(v, str)]
        if bad:
            raise TelemetryError(f"metadata {name!r}: keys and values must be strings; bad entries: {bad}")
        with self._writing():
            self._check_open()
            self._file.writer.add_metadata(name, dict(data))
            if flush:
                self._file.stream.flush()

    def attachment(self, name: str, media_type: str, data: bytes, log_time_ns: int = 0) -> None:
        """Write an attachment (reaches the OS at the next :meth:`flush`)."""
        with self._writing():
            self._check_open()
            self._file.writer.add_attachment(time.time_ns(), log_time_ns, name, media_type, data)

    def flush(self, *, sync: bool = False) -> None:
        """Close the current chunk (if it holds messages) and hand the bytes to the OS.

        Args:
            sync: also ask the OS to write them to the disk (``fsync``) before returning.
        """
        with self._writing():
            if self.closed:
                if self._file.failed is not None:
                    raise self._file.error()
                return
            self._file.commit()
            if self._finalize_chunk is not None:
                self._finalize_chunk()
            self._file.stream.flush()
            if sync:
                os.fsync(self._file.stream.fileno())
            self._dirty_since = None

    def _flush_if_stale(self) -> None:
        since = self._dirty_since
        if since is not None and time.monotonic() - since >= self._flush_interval and self._pid == os.getpid():
            try:
                self.flush()
            except Exception:  # noqa: BLE001 - never let the background thread die loudly
                pass

    # ------------------------------------------------------------------ closing
    @property
    def closed(self) -> bool:
        """True once finished (by :meth:`close` or by the exit hook)."""
        return self._closed or not self._finalizer.alive

    def close(self) -> None:
        """Write the summary and footer and close the file (idempotent)."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
        self._finalizer()

    @property
    def discarded(self) -> bool:
        """True once a failed write removed the file (``discard_on_error``)."""
        return self._file.failed is not None

    def _check_open(self) -> None:
        if self._file.failed is not None:
            raise self._file.error()
        if self.closed:
            raise TelemetryError(f"{self.path} is already closed")

    def __enter__(self) -> McapFileWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
