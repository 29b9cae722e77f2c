"""The MCAP reader is bounded: the magic is checked before the file is read, and a chunk's declared size is
checked (and never exceeded) before it is decompressed.

Written from the reproductions: a 33 KB zstd chunk declaring 1 GiB hung ``pyflyt replay``; a 2 GiB file
that is not MCAP cost 2 GiB of memory to be told so."""

from __future__ import annotations

import io
import os
import zlib

import pytest
import zstandard
from mcap.data_stream import RecordBuilder
from mcap.records import Chunk, Header

from pyflyt_engine.errors import TelemetryError
from pyflyt_engine.telemetry import read_mcap
from pyflyt_engine.telemetry.reader import MAGIC, MAX_CHUNK_BYTES
from tests.conftest import pyflyt_forked

#: zeros compressed by zstd: a few kB that expand to this many bytes
BOMB_BYTES = MAX_CHUNK_BYTES + (8 << 20)


def zstd_zeros(size: int, *, content_size: bool) -> bytes:
    out = io.BytesIO()
    compressor = zstandard.ZstdCompressor(level=3, write_content_size=content_size)
    block = bytes(1 << 20)
    with compressor.stream_writer(out, size=size if content_size else -1, closefd=False) as writer:
        for _ in range(size >> 20):
            writer.write(block)
    return out.getvalue()


def mcap_with_chunk(path, data: bytes, declared: int, crc: int = 0) -> None:
    builder = RecordBuilder()
    Header(profile="", library="test").write(builder)
    Chunk(
        compression="zstd",
        data=data,
        message_start_time=0,
        message_end_time=0,
        uncompressed_crc=crc,
        uncompressed_size=declared,
    ).write(builder)
    path.write_bytes(MAGIC + builder.end())  # cut after the chunk: no footer needed to reach it


def test_a_chunk_declaring_more_than_the_limit_is_refused_before_decompression(tmp_path):
    path = tmp_path / "declared.mcap"
    bomb = zstd_zeros(BOMB_BYTES, content_size=True)
    assert len(bomb) < 64 << 10  # a few kB
    mcap_with_chunk(path, bomb, declared=BOMB_BYTES)
    with pytest.raises(TelemetryError, match=f"declares {BOMB_BYTES} bytes uncompressed, more than the 64 MiB"):
        read_mcap(path, warn=False)


def test_a_chunk_that_expands_beyond_what_it_declares_is_refused_without_expanding(tmp_path):
    path = tmp_path / "lying.mcap"
    mcap_with_chunk(path, zstd_zeros(BOMB_BYTES, content_size=False), declared=1024, crc=zlib.crc32(bytes(1024)))
    with pytest.raises(TelemetryError, match="decompresses to more bytes, not the 1024 it declares"):
        read_mcap(path, warn=False)


def test_replay_refuses_a_zstd_bomb_in_one_line_within_a_memory_limit(tmp_path):
    path = tmp_path / "bomb.mcap"
    mcap_with_chunk(path, zstd_zeros(1 << 30, content_size=True), declared=1 << 30)  # the reproduction: 1 GiB
    code, output = pyflyt_forked(["replay", str(path), "--verify"], memory=512 << 20)
    assert code == 2, output[-2000:]
    assert "Traceback" not in output and "more than the 64 MiB" in output


def test_a_large_file_that_is_not_mcap_is_refused_without_being_read(tmp_path, monkeypatch):
    path = tmp_path / "big.mcap"
    with open(path, "wb") as f:  # sparse: 2 GiB on disk costs nothing
        f.truncate(2 << 30)
    import pyflyt_engine.telemetry.reader as reader

    def no_whole_read(*args, **kwargs):
        raise AssertionError("the whole file was read before its magic was checked")

    monkeypatch.setattr(reader, "read_bytes", no_whole_read)
    with pytest.raises(TelemetryError, match="does not start with the MCAP magic bytes"):
        read_mcap(path, warn=False)
    os.unlink(path)


@pytest.mark.parametrize("key, values", [("lin_pos", 3_000_000), ("aux", 3_000_000)])
def test_a_state_list_longer_than_its_schema_is_refused_before_it_is_converted(tmp_path, key, values):
    """The reproduction: 3 M-element state lists hung replay (here in one message, which is enough)."""
    from tests.telemetry.conftest import record, rewrite_mcap

    env, _ = record("PyFlyt/QuadX-Hover-v0", tmp_path, episodes=1, max_steps=5)
    long_list = [0.0] * values

    def forge(topic, data):
        return {**data, key: long_list} if topic == "/uav/0/state" and data.get("step") == 2 else None

    forged = tmp_path / "long.mcap"
    rewrite_mcap(env.paths[0], forged, forge)
    code, output = pyflyt_forked(["replay", str(forged), "--verify"], timeout=120, memory=3 << 30)
    assert code == 2 and "Traceback" not in output, output[-2000:]
    expected = "expected 3" if key == "lin_pos" else "above the limit of 10000 values any recorded row holds"
    assert f"message 2 on /uav/0/state: '{key}' has {values} values" in output and expected in output
