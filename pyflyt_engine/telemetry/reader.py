"""The one MCAP reader behind ``pyflyt replay``, the plots and :func:`read_metrics`.

:func:`read_mcap` reads a whole file in one sequential pass, validating every chunk's CRC
and the data-section CRC.  It does not need the summary section, so a file cut short (a
killed writer) is read up to its last complete chunk and flagged ``truncated``; anything
that is not a readable MCAP file raises :class:`~pyflyt_engine.errors.TelemetryError` with a
message naming the file and the problem.
"""

from __future__ import annotations

import json
import os
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.exceptions import EndOfFile
from mcap.records import Attachment, Channel, Chunk, DataEnd, Footer, Message, Metadata, Schema
from mcap.stream_reader import CRCValidationError, StreamReader, breakup_chunk

from pyflyt_engine.errors import TelemetryError

MAGIC = bytes([137, 77, 67, 65, 80, 48, 13, 10])


class TruncatedRecordingWarning(UserWarning):
    """A file ended before its footer (e.g. its writer was killed); it was read up to its last complete chunk."""


@dataclass(frozen=True)
class McapMessage:
    """One decoded message: ``data`` is the parsed JSON object (or raw bytes for other encodings)."""

    topic: str
    log_time: int  #: nanoseconds (simulation time for episodes, Unix wall time for metrics)
    sequence: int
    schema_name: str
    data: Any


@dataclass
class McapContents:
    """Everything read from one file, messages in file (= write) order."""

    path: Path
    messages: list[McapMessage] = field(default_factory=list)
    channels: dict[int, Channel] = field(default_factory=dict)
    schemas: dict[int, Schema] = field(default_factory=dict)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    attachments: list[Attachment] = field(default_factory=list)
    truncated: bool = False
    #: why reading stopped early ("" for a complete file)
    truncation: str = ""

    def topics(self) -> list[str]:
        return sorted({c.topic for c in self.channels.values()})

    def on(self, topic: str) -> list[McapMessage]:
        """Messages on one topic, in order."""
        return [m for m in self.messages if m.topic == topic]

    def schema_of(self, topic: str) -> dict[str, Any] | None:
        """The JSON schema declared for ``topic`` (None if it has none)."""
        for channel in self.channels.values():
            if channel.topic == topic:
                schema = self.schemas.get(channel.schema_id)
                if schema is None or schema.encoding != "jsonschema":
                    return None
                return json.loads(schema.data)
        return None

    def require_metadata(self, name: str) -> dict[str, str]:
        if name not in self.metadata:
            cut = " (the file is truncated)" if self.truncated else ""
            raise TelemetryError(
                f"{self.path}: missing metadata record {name!r}{cut}; it was not written by pyflyt's recorder"
            )
        return self.metadata[name]


class _StrictStream:
    """A binary file whose short reads raise :class:`EndOfFile` (a record cut by the end of the file)."""

    def __init__(self, f: Any) -> None:
        self._f = f

    def read(self, n: int = -1) -> bytes:
        data = self._f.read(n)
        if n is not None and n > 0 and len(data) < n:
            raise EndOfFile()
        return data


def _records(f: Any) -> Iterator[Any]:
    reader = StreamReader(_StrictStream(f), validate_crcs=True, emit_chunks=True, record_size_limit=2**31)
    yield from reader.records


def read_mcap(path: str | os.PathLike[str], *, decode: bool = True, warn: bool = True) -> McapContents:
    """Read every record of an MCAP file; see the module docstring.

    Args:
        path: the ``.mcap`` file.
        decode: parse JSON message payloads (else ``data`` holds the raw bytes).
        warn: emit a :class:`TruncatedRecordingWarning` for a truncated file.

    Raises:
        TelemetryError: missing file, not an MCAP file, corrupt data (CRC mismatch), or a file
            truncated before any data.
    """
    path = Path(path)
    if not path.exists():
        raise TelemetryError(f"{path}: no such file")
    if path.is_dir():
        raise TelemetryError(f"{path} is a directory, not an .mcap file")
    out = McapContents(path=path)
    with open(path, "rb") as f:
        head = f.read(len(MAGIC))
        if head != MAGIC:
            what = "it is empty" if not head else "it does not start with the MCAP magic bytes"
            raise TelemetryError(f"{path} is not an MCAP file ({what})")
        f.seek(0)
        footer_seen = False
        data_end_seen = False
        try:
            for record in _records(f):
                if isinstance(record, Chunk):
                    for inner in breakup_chunk(record, validate_crc=True):
                        _take(out, inner, decode)
                elif isinstance(record, Footer):
                    footer_seen = True
                elif isinstance(record, DataEnd):
                    data_end_seen = True
                elif not data_end_seen:  # records of the summary section repeat the data section's
                    _take(out, record, decode)
        except EndOfFile:
            pass  # a record cut by the end of the file: truncation, reported below
        except TelemetryError:
            raise
        except CRCValidationError as exc:
            raise TelemetryError(f"{path} is corrupt: {exc}") from None
        except Exception as exc:  # noqa: BLE001 - any decoding failure of a complete record is corruption
            raise TelemetryError(f"{path} is corrupt at byte {f.tell()}: {type(exc).__name__}: {exc}") from None
        if not footer_seen:
            out.truncated = True
            where = "before its summary" if data_end_seen else "after its last complete chunk"
            out.truncation = f"file ends {where} (no footer): its writer did not finish it, e.g. it was killed"
            if warn:
                warnings.warn(f"{path}: truncated: {out.truncation}", TruncatedRecordingWarning, stacklevel=2)
    if out.truncated and not out.channels and not out.metadata:
        raise TelemetryError(f"{path} is truncated before any data: nothing to read")
    return out


def _take(out: McapContents, record: Any, decode: bool) -> None:
    if isinstance(record, Message):
        channel = out.channels.get(record.channel_id)
        if channel is None:
            raise TelemetryError(f"{out.path} is corrupt: a message refers to unknown channel {record.channel_id}")
        schema = out.schemas.get(channel.schema_id)
        data: Any = record.data
        if decode and channel.message_encoding == "json":
            try:
                data = json.loads(record.data)
            except ValueError as exc:
                raise TelemetryError(f"{out.path}: a message on {channel.topic} is not valid JSON ({exc})") from None
        out.messages.append(
            McapMessage(
                topic=channel.topic,
                log_time=record.log_time,
                sequence=record.sequence,
                schema_name=schema.name if schema else "",
                data=data,
            )
        )
    elif isinstance(record, Channel):
        out.channels[record.id] = record
    elif isinstance(record, Schema):
        out.schemas[record.id] = record
    elif isinstance(record, Metadata):
        out.metadata[record.name] = dict(record.metadata)
    elif isinstance(record, Attachment):
        out.attachments.append(record)
