"""The one MCAP reader behind ``pyflyt replay``, the plots and :func:`read_metrics`.

:func:`read_mcap` reads a whole file in one sequential pass, record by record, validating
every chunk's CRC, every attachment's CRC and the data-section CRC.  It does not need the
summary section, so a file cut short (a killed writer) is read up to its last complete chunk
and flagged ``truncated``.

Damage inside the file (a flipped byte: a chunk whose CRC does not match or that does not
decompress, a record whose length field is wrong) is an error by default.  With
``skip_damage=True`` the reader skips what is damaged and reads everything else: a bad chunk
is stepped over by its length; a bad length is stepped over by searching for the next record
that parses whole (a chunk only if its CRC matches).  What was lost is reported
(``damage``, ``lost_chunks``, ``lost_messages``) and warned about with a
:class:`CorruptRecordingWarning`.  Anything that is not a readable MCAP file (empty, no MCAP
magic, nothing readable after the magic) raises :class:`~pyflyt_engine.errors.TelemetryError`
with a message naming the file and the problem.
"""

from __future__ import annotations

import dataclasses
import os
import re
import struct
import warnings
import zlib
from collections import Counter
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path
from typing import Any

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import (
    Attachment,
    AttachmentIndex,
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    Message,
    MessageIndex,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)
from mcap.stream_reader import breakup_chunk

from pyflyt_engine.errors import TelemetryError
from pyflyt_engine.safe_load import check_regular, json_data, json_loads, read_bytes

MAGIC = bytes([137, 77, 67, 65, 80, 48, 13, 10])
#: the largest uncompressed chunk read [bytes]: a writer here closes a chunk at 256 KiB
#: (``_io.DEFAULT_CHUNK_SIZE``) or holds one larger message in it (a ``/scene`` with an embedded
#: mesh: a few MiB); the size a chunk declares is checked before it is decompressed
MAX_CHUNK_BYTES = 64 << 20

#: opcode -> reader of the record body (Message also needs the body length)
_PARSERS: dict[int, Any] = {
    Opcode.HEADER: Header.read,
    Opcode.FOOTER: Footer.read,
    Opcode.SCHEMA: Schema.read,
    Opcode.CHANNEL: Channel.read,
    Opcode.CHUNK: Chunk.read,
    Opcode.MESSAGE_INDEX: MessageIndex.read,
    Opcode.CHUNK_INDEX: ChunkIndex.read,
    Opcode.ATTACHMENT: Attachment.read,
    Opcode.ATTACHMENT_INDEX: AttachmentIndex.read,
    Opcode.STATISTICS: Statistics.read,
    Opcode.METADATA: Metadata.read,
    Opcode.METADATA_INDEX: MetadataIndex.read,
    Opcode.SUMMARY_OFFSET: SummaryOffset.read,
    Opcode.DATA_END: DataEnd.read,
}
# Where reading resumes after a damaged length: the start of a record of one of these kinds whose
# length field has its three high bytes zero (no record here is 2**40 bytes long).  Messages,
# schemas and channels are left out: they also sit, framed alike, inside uncompressed chunks.
_RESYNC_OPCODES = (
    Opcode.HEADER,
    Opcode.FOOTER,
    Opcode.CHUNK,
    Opcode.MESSAGE_INDEX,
    Opcode.ATTACHMENT,
    Opcode.METADATA,
    Opcode.DATA_END,
)
_RESYNC = re.compile(b"(?=[" + b"".join(re.escape(bytes([op])) for op in _RESYNC_OPCODES) + rb"][\s\S]{5}\x00\x00\x00)")
_FOOTER_SIZE = 1 + 8 + 20
_SUMMARY_DAMAGED = "the summary section (the index after the data) is damaged; the data was read without it"


class TruncatedRecordingWarning(UserWarning):
    """A file ended before its footer (e.g. its writer was killed); it was read up to its last complete chunk."""


class CorruptRecordingWarning(UserWarning):
    """Part of a file is damaged (or a file is unreadable) and was skipped; everything else was read."""


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
    #: damaged parts that were skipped (``skip_damage=True``), one description each
    damage: list[str] = field(default_factory=list)
    #: chunks that could not be read
    lost_chunks: int = 0
    #: messages lost with them or because their channel was lost; None if not all could be counted
    lost_messages: int | None = 0

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
                return json_data(schema.data, source=f"{self.path}: the schema of {topic}", error=TelemetryError)
        return None

    def require_metadata(self, name: str) -> dict[str, str]:
        if name not in self.metadata:
            cut = " (the file is truncated)" if self.truncated else ""
            raise TelemetryError(
                f"{self.path}: missing metadata record {name!r}{cut}; it was not written by pyflyt's recorder"
            )
        return self.metadata[name]

    def loss(self) -> str:
        """What was lost to damage, in words ("" if nothing)."""
        if not self.damage:
            return ""
        n = self.lost_messages
        messages = "an unknown number of messages" if n is None else f"{n} message{'s' * (n != 1)}"
        chunks = f" in {self.lost_chunks} chunk{'s' * (self.lost_chunks != 1)}" if self.lost_chunks else ""
        return f"lost {messages}{chunks} ({'; '.join(self.damage)})"


class _Body(ReadDataStream):
    """A record's body: reading past its end is an error (the mcap stream returns short reads)."""

    def read(self, length: int) -> bytes:
        out = super().read(length)
        if len(out) != length:
            raise EOFError(f"{length} bytes wanted, {len(out)} left in the record")
        return out


class _Damage(Exception):
    """A record that cannot be read as it is (internal); ``past_end``: it runs past the end of the file."""

    def __init__(self, message: str, past_end: bool = False) -> None:
        super().__init__(message)
        self.past_end = past_end


def _parse(data: bytes, pos: int, *, exact: bool) -> tuple[int, Any, int]:
    """(opcode, record or None for an unknown opcode, end offset) of the record at ``pos``.

    Raises:
        _Damage: the record runs past the end of ``data``, or its body does not parse
            (``exact``: or does not fill its length exactly).
    """
    opcode = data[pos]
    (length,) = struct.unpack_from("<Q", data, pos + 1)
    end = pos + 9 + length
    if end > len(data):
        raise _Damage(f"a record at byte {pos} claims {length} bytes, past the end of the file", past_end=True)
    parser = _PARSERS.get(opcode)
    if parser is None and opcode != Opcode.MESSAGE:
        if exact:
            raise _Damage(f"unknown record kind {opcode} at byte {pos}")
        return opcode, None, end  # a record kind of a later MCAP version: skipped, as the spec says
    stream = _Body(BytesIO(data[pos + 9 : end]))
    try:
        # (parser is None for a message alone: _PARSERS holds every other kind this reader knows)
        record = Message.read(stream, length) if parser is None else parser(stream)
    except Exception as exc:  # noqa: BLE001 - any failure to decode a record's body is damage
        raise _Damage(f"a {Opcode(opcode).name.lower()} record at byte {pos} does not parse ({exc!r})") from None
    if stream.count > length or (exact and stream.count != length):
        raise _Damage(f"a {Opcode(opcode).name.lower()} record at byte {pos} does not fill its length")
    if opcode == Opcode.ATTACHMENT:
        (crc,) = struct.unpack_from("<I", data, end - 4)
        if crc and crc != zlib.crc32(data[pos + 9 : end - 4]):
            raise _Damage(f"the attachment {record.name!r} at byte {pos}: CRC mismatch")
    return opcode, record, end


def _decompressed(chunk: Chunk, pos: int) -> bytes:
    """A chunk's records, decompressed, never more than the size it declares (itself at most
    :data:`MAX_CHUNK_BYTES`): a few kB of zstd can declare, and expand to, gigabytes."""
    size = chunk.uncompressed_size
    if size > MAX_CHUNK_BYTES:
        raise _Damage(
            f"the chunk at byte {pos} declares {size} bytes uncompressed, more than the {MAX_CHUNK_BYTES >> 20} MiB "
            "a recording's chunk may hold"
        )
    if chunk.compression in ("", "none"):
        data = bytes(chunk.data)
    elif chunk.compression == "zstd":
        import zstandard

        with zstandard.ZstdDecompressor().stream_reader(BytesIO(chunk.data)) as reader:
            data = reader.read(size + 1)
    elif chunk.compression == "lz4":
        import lz4.frame

        data = lz4.frame.LZ4FrameDecompressor().decompress(chunk.data, max_length=size + 1)
    else:
        raise _Damage(f"the chunk at byte {pos} is compressed with {chunk.compression!r}, which no writer here uses")
    if len(data) != size:
        raise _Damage(
            f"the chunk at byte {pos} decompresses to {'more' if len(data) > size else len(data)} bytes, not the {size} it declares"
        )
    return data


def _chunk_records(chunk: Chunk, pos: int) -> list[Any]:
    try:
        plain = dataclasses.replace(chunk, compression="", data=_decompressed(chunk, pos))
        return breakup_chunk(plain, validate_crc=True)
    except _Damage:
        raise
    except Exception as exc:  # noqa: BLE001 - bad CRC, bad compression, inner records cut: damage
        raise _Damage(f"the chunk at byte {pos}: {exc}") from None


def _resync(data: bytes, start: int) -> int | None:
    """Offset of the first record at or after ``start`` that parses whole (a chunk: with a matching CRC)."""
    for match in _RESYNC.finditer(data, start):
        pos = match.start()
        try:
            opcode, record, _ = _parse(data, pos, exact=True)
            if opcode == Opcode.CHUNK:
                _chunk_records(record, pos)
        except _Damage:
            continue
        return pos
    return None


def _footer(data: bytes) -> tuple[int, Footer] | None:
    """(offset, record) of the footer if ``data`` ends with an intact one."""
    at = len(data) - len(MAGIC) - _FOOTER_SIZE
    if at < len(MAGIC) or data[-len(MAGIC) :] != MAGIC or data[at] != Opcode.FOOTER:
        return None
    try:
        return at, _parse(data, at, exact=True)[1]
    except _Damage:
        return None


def _summary(data: bytes) -> tuple[list[Any], str]:
    """Schema, channel and statistics records of the summary section, if the file has an intact one."""
    found = _footer(data)
    if found is None or not found[1].summary_start:
        return [], ""
    footer_at, footer = found
    start = footer.summary_start
    if not len(MAGIC) <= start <= footer_at:
        return [], _SUMMARY_DAMAGED
    if footer.summary_crc and footer.summary_crc != zlib.crc32(data[start : footer_at + 1 + 8 + 16]):
        return [], _SUMMARY_DAMAGED
    records, pos = [], start
    try:
        while pos < footer_at:
            opcode, record, pos = _parse(data, pos, exact=False)
            if opcode in (Opcode.SCHEMA, Opcode.CHANNEL, Opcode.STATISTICS):
                records.append(record)
    except _Damage:
        return [], _SUMMARY_DAMAGED
    return records, ""


def read_mcap(
    path: str | os.PathLike[str], *, decode: bool = True, warn: bool = True, skip_damage: bool = False
) -> McapContents:
    """Read every record of an MCAP file; see the module docstring.

    Args:
        path: the ``.mcap`` file.
        decode: parse JSON message payloads (else ``data`` holds the raw bytes).
        warn: emit a :class:`TruncatedRecordingWarning` for a truncated file and a
            :class:`CorruptRecordingWarning` for damage skipped.
        skip_damage: skip damaged chunks and records, read the rest and report the loss
            (``damage``, ``lost_chunks``, ``lost_messages``); otherwise damage is an error.

    Raises:
        TelemetryError: missing file, not an MCAP file, a file truncated before any data, nothing
            readable in it, or (without ``skip_damage``) corrupt data (CRC mismatch, bad record).
    """
    path = Path(path)
    if not path.exists():
        from pyflyt_engine.suggest import did_you_mean_path

        raise TelemetryError(f"{path}: no such file.{did_you_mean_path(path)}".removesuffix("."))
    if path.is_dir():
        raise TelemetryError(f"{path} is a directory, not an .mcap file")
    # a FIFO or a device is refused before it is opened: reading one may never end; the magic is
    # read first, so a large file that is not MCAP is refused without being read
    check_regular(path, what="recording", error=TelemetryError)
    try:
        with open(path, "rb") as head:
            start = head.read(len(MAGIC))
    except OSError as exc:
        raise TelemetryError(f"{path}: cannot read the recording: {exc.strerror or exc}") from None
    if start != MAGIC:
        what = "it is empty" if not start else "it does not start with the MCAP magic bytes"
        raise TelemetryError(f"{path} is not an MCAP file ({what})")
    data = read_bytes(path, limit=None, what="recording", error=TelemetryError)
    if data[: len(MAGIC)] != MAGIC:  # replaced between the two reads
        raise TelemetryError(f"{path} is not an MCAP file (it does not start with the MCAP magic bytes)")
    out = McapContents(path=path)
    statistics = None
    if skip_damage:  # channels defined in a damaged chunk are repeated there
        records, problem = _summary(data)
        if problem:
            out.damage.append(problem)
        for record in records:
            if isinstance(record, Statistics):
                statistics = record
            else:
                _take(out, record, decode)
    _scan(out, data, decode, skip_damage)
    if out.damage and statistics is not None:  # the summary knows how many messages were written
        out.lost_messages = max(0, statistics.message_count - len(out.messages))
    if not out.channels and not out.metadata and not out.messages:
        if out.truncated and not out.damage:
            raise TelemetryError(f"{path} is truncated before any data: nothing to read")
        if out.damage:
            raise TelemetryError(f"{path} is corrupt: nothing readable ({'; '.join(out.damage)})")
    if warn and out.truncated:
        warnings.warn(f"{path}: truncated: {out.truncation}", TruncatedRecordingWarning, stacklevel=2)
    if warn and out.damage:
        warnings.warn(f"{path}: damaged, {out.loss()}", CorruptRecordingWarning, stacklevel=2)
    return out


def _scan(out: McapContents, data: bytes, decode: bool, skip_damage: bool) -> None:
    """Read the data section of ``data`` into ``out`` (see :func:`read_mcap`)."""
    pos = len(MAGIC)
    after_lost_chunk = False  # the message indexes that follow a lost chunk count its messages
    footer_seen = data_end_seen = False
    damage_before = len(out.damage)
    unreadable_messages: Counter[str] = Counter()
    while len(data) - pos >= 9:  # fewer bytes left: a record cut in its opcode or length (truncation)
        try:
            opcode, record, end = _parse(data, pos, exact=False)
        except _Damage as exc:
            if data_end_seen and skip_damage:  # every message is read: only the summary is hit
                if _SUMMARY_DAMAGED not in out.damage:
                    out.damage.append(_SUMMARY_DAMAGED)
                footer_seen = _footer(data) is not None
                break
            resume = _resync(data, pos + 1) if skip_damage else None
            if resume is None and exc.past_end:
                break  # the last record was cut by the end of the file: truncation
            if not skip_damage:
                raise TelemetryError(f"{out.path} is corrupt: {exc}") from None
            resume = len(data) if resume is None else resume
            out.damage.append(f"{exc}: bytes {pos}-{resume} skipped")
            out.lost_messages = None  # whatever those bytes held cannot be counted
            pos = resume
            continue
        if opcode == Opcode.CHUNK:
            try:
                inner = _chunk_records(record, pos)
            except _Damage as exc:
                if not skip_damage:
                    raise TelemetryError(f"{out.path} is corrupt: {exc}") from None
                out.damage.append(str(exc))
                out.lost_chunks += 1
                after_lost_chunk = True
                pos = end
                continue
            after_lost_chunk = False
            for item in inner:
                _take_or_lose(out, item, decode, skip_damage, unreadable_messages)
        elif opcode == Opcode.MESSAGE_INDEX:
            if after_lost_chunk and out.lost_messages is not None:
                out.lost_messages += len(record.records)
        elif opcode == Opcode.FOOTER:
            footer_seen = True
            break
        elif opcode == Opcode.DATA_END:
            data_end_seen = True
            after_lost_chunk = False
            crc = record.data_section_crc
            if crc and len(out.damage) == damage_before and crc != zlib.crc32(data[:pos]):
                problem = "the data section CRC does not match: a byte outside the chunks changed"
                if not skip_damage:
                    raise TelemetryError(f"{out.path} is corrupt: {problem}")
                out.damage.append(problem)
        elif not data_end_seen and record is not None:  # the summary section repeats the data section's records
            _take_or_lose(out, record, decode, skip_damage, unreadable_messages)
        pos = end
    out.damage.extend(f"{count} {reason}" for reason, count in unreadable_messages.items())
    if not footer_seen:
        out.truncated = True
        where = "before its summary" if data_end_seen else "after its last complete chunk"
        out.truncation = f"file ends {where} (no footer): its writer did not finish it, e.g. it was killed"


def _take_or_lose(out: McapContents, record: Any, decode: bool, skip_damage: bool, lost: Counter[str]) -> None:
    """:func:`_take`, or with ``skip_damage`` count a message that cannot be read in ``lost`` (by reason)."""
    try:
        _take(out, record, decode)
    except TelemetryError:
        if not skip_damage:
            raise
        channel = out.channels.get(record.channel_id)
        if channel is None:
            lost[f"messages on channel {record.channel_id}, whose definition was lost"] += 1
        else:
            lost[f"messages on {channel.topic} that are not valid JSON"] += 1
        if out.lost_messages is not None:
            out.lost_messages += 1


def _take(out: McapContents, record: Any, decode: bool) -> None:
    if isinstance(record, Message):
        channel = out.channels.get(record.channel_id)
        if channel is None:
            raise TelemetryError(f"{out.path} is corrupt: a message refers to unknown channel {record.channel_id}")
        schema = out.schemas.get(channel.schema_id)
        data: Any = record.data
        if decode and channel.message_encoding == "json":
            try:
                data = json_loads(
                    record.data,
                    source=f"{out.path}: a message on {channel.topic}",
                    error=TelemetryError,
                    strict_numbers=True,
                )
            except TelemetryError:
                raise
            except ValueError as exc:
                raise TelemetryError(f"{out.path}: a message on {channel.topic} is not valid JSON ({exc})") from None
            except RecursionError:  # nested deeper than any message a writer makes
                raise TelemetryError(f"{out.path}: a message on {channel.topic} is nested too deeply") from None
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
