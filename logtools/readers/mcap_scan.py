"""A forgiving record-level scan of an MCAP file: raw message bytes per channel, plus damage report.

The scan never decodes message payloads. It walks the records of the data section, opens chunks
(zstd, lz4 or uncompressed; CRC-checked when the writer stored a CRC), and collects for every
channel the MCAP ``log_time`` values and the raw payloads, so that decoders can work per channel in
bulk. The summary section is read first through the footer when it is intact: its statistics give
the expected message count per channel and its chunk index lets the scan skip over a damaged
region to the next chunk. What could not be read is described in ``ScanResult.damage``.

Bounds (issue #13): a chunk is decompressed by streaming, never beyond its declared
uncompressed size (zstd frames may declare their own size, which is not trusted) nor beyond
what is left of a budget for the whole file, :data:`DECOMPRESS_BASE_BYTES` +
:data:`DECOMPRESS_RATIO` times the file size; a chunk beyond either is lost with a
:class:`ChunkError` saying why. Opcode 0 is reserved in MCAP: zero-filled bytes are corruption,
not millions of empty records. A second MCAP file appended after the footer and a channel id
defined twice are recorded (``ScanResult.after_footer``, ``channel_conflicts``).
"""

from __future__ import annotations

import mmap
import struct
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field
from io import BytesIO
from typing import Any

import lz4.frame
import zstandard
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, ChunkIndex, Metadata, Schema, Statistics

__all__ = [
    "DECOMPRESS_BASE_BYTES",
    "DECOMPRESS_RATIO",
    "MAGIC",
    "ChannelConflict",
    "ChannelMessages",
    "ChunkError",
    "Damage",
    "ScanResult",
    "scan_mcap",
]

MAGIC = b"\x89MCAP0\r\n"
_RECORD_HEAD = struct.Struct("<BQ")  # opcode, body length
_MESSAGE_HEAD = struct.Struct("<BQHIQQ")  # opcode, length, channel id, sequence, log, publish time
_CHUNK_HEAD = struct.Struct("<QQQI")  # start, end, uncompressed size, uncompressed crc
_FOOTER = struct.Struct("<BQQQI")
_INT64_MAX = 2**63 - 1
DECOMPRESS_BASE_BYTES = 64 * 2**20
"""Decompressed bytes every file may produce, whatever its size (64 MiB)."""
DECOMPRESS_RATIO = 32
"""Further decompressed bytes per byte of file (real logs compress 2-10 times)."""
_STREAM_STEP = 1 << 20


class _CorruptRecordError(Exception):
    """A record whose body does not parse."""


@dataclass
class ChannelMessages:
    """Raw messages of one channel in file order: ``log_time`` (ns) and payload bytes."""

    log_times: list[int] = field(default_factory=list)
    payloads: list[bytes] = field(default_factory=list)


@dataclass(frozen=True)
class ChunkError:
    """A chunk whose body did not decompress (a CRC mismatch is not one: it is only lost).

    Attributes:
        compression: the chunk's compression ("" for none).
        t0_ns: its first message's log time (ns).
        t1_ns: its last message's log time (ns).
        error_type: the decompressor's exception class name.
        error: its text.
    """

    compression: str
    t0_ns: int
    t1_ns: int
    error_type: str
    error: str


@dataclass(frozen=True)
class ChannelConflict:
    """A channel id defined a second time with another topic, encoding or schema.

    Attributes:
        channel_id: the id.
        kept: the topic of the first definition (the one the id's messages are read as).
        other: the topic of the later definition (ignored).
    """

    channel_id: int
    kept: str
    other: str


class _BudgetError(Exception):
    """Decompression beyond the declared size or the file's budget."""


@dataclass
class Damage:
    """What the scan could not read.

    Attributes:
        lost_chunks: (message_start_time, message_end_time) in ns of chunks that failed to open.
        skipped: (start offset, end offset) byte ranges skipped over to reach a later chunk.
        unreadable_tail_bytes: bytes after the last good record that could not be read.
        salvaged_messages: messages recovered from the chunk cut short there (they are read).
        last_good_offset: file offset just after the last record read in full.
        bad_messages: messages dropped for an impossible log_time.
        chunk_errors: chunks whose decompression failed (they are also in ``lost_chunks``).
    """

    lost_chunks: list[tuple[int, int]] = field(default_factory=list)
    skipped: list[tuple[int, int]] = field(default_factory=list)
    unreadable_tail_bytes: int = 0
    last_good_offset: int = 0
    salvaged_messages: int = 0
    bad_messages: int = 0
    chunk_errors: list[ChunkError] = field(default_factory=list)

    @property
    def any(self) -> bool:
        """True when anything at all was lost."""
        return bool(
            self.lost_chunks
            or self.skipped
            or self.unreadable_tail_bytes
            or self.bad_messages
            or self.chunk_errors
        )


@dataclass
class ScanResult:
    """Everything the scan found; ``statistics`` is None when the summary was absent or lost."""

    size: int
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    messages: dict[int, ChannelMessages] = field(default_factory=dict)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    statistics: Statistics | None = None
    chunk_indexes: list[ChunkIndex] = field(default_factory=list)
    reached_footer: bool = False
    damage: Damage = field(default_factory=Damage)
    after_footer: tuple[int, int] | None = None
    """(offset, bytes) of data after the footer's closing magic; None when the file ends there."""
    appended_mcap: bool = False
    """The data after the footer starts with the MCAP magic: a second file was appended."""
    channel_conflicts: list[ChannelConflict] = field(default_factory=list)
    budget: int = 0
    """Decompressed bytes the scan may still produce."""


def scan_mcap(buf: bytes | mmap.mmap) -> ScanResult:
    """Scan an MCAP file held in memory.

    Args:
        buf: the whole file (bytes or memory map); it starts with :data:`MAGIC`.

    Returns:
        The schemas, channels, raw messages per channel, metadata records, summary statistics
        (when readable) and a description of any damage.
    """
    result = ScanResult(size=len(buf), budget=DECOMPRESS_BASE_BYTES + DECOMPRESS_RATIO * len(buf))
    summary_start = _read_summary(buf, result)
    data_end = summary_start or len(buf)  # with a good summary, the data section ends there
    resume_points = sorted(ci.chunk_start_offset for ci in result.chunk_indexes)
    pos = len(MAGIC)
    while True:
        stop = _scan_records(buf, pos, data_end, result, top=True)
        if stop is None:
            result.reached_footer = result.reached_footer or bool(summary_start)
            return result
        resume = next((p for p in resume_points if stop < p < data_end), None)
        if resume is None:
            result.damage.unreadable_tail_bytes = data_end - stop
            result.damage.last_good_offset = stop
            return result
        result.damage.skipped.append((stop, resume))
        result.damage.lost_chunks += [
            (ci.message_start_time, ci.message_end_time)
            for ci in result.chunk_indexes
            if stop <= ci.chunk_start_offset < resume
        ]
        pos = resume


def _read_summary(buf: bytes | mmap.mmap, result: ScanResult) -> int:
    """Read the summary section through the footer; return its start offset (0 if unusable)."""
    n = len(buf)
    at = n - len(MAGIC) - _FOOTER.size
    if at < len(MAGIC) or buf[n - len(MAGIC) :] != MAGIC:
        return 0
    opcode, length, summary_start, _offset_start, _crc = _FOOTER.unpack_from(buf, at)
    if opcode != Opcode.FOOTER or length != 20 or not len(MAGIC) <= summary_start < at:
        return 0
    probe = ScanResult(size=n)
    if _scan_records(buf, summary_start, at, probe) is not None or probe.reached_footer:
        return 0  # a damaged summary is ignored as a whole (a footer inside it: concatenation)
    result.schemas.update(probe.schemas)
    result.channels.update(probe.channels)
    result.channel_conflicts += probe.channel_conflicts
    result.statistics = probe.statistics
    result.chunk_indexes = probe.chunk_indexes
    return summary_start


def _scan_records(
    buf: bytes | mmap.mmap, pos: int, end: int, result: ScanResult, *, top: bool = False
) -> int | None:
    """Read records from ``pos`` up to ``end``; return None when done, else the failing offset.

    ``top``: ``buf`` is the file itself (not a chunk's records or the summary), so bytes after a
    footer are the file's.

    Message records, by far the most frequent, are handled inline (this loop is the reader's hot
    path): one struct unpack, one slice and two list appends per message.
    """
    record_head = _RECORD_HEAD.unpack_from
    message_head = _MESSAGE_HEAD.unpack_from
    head_size = _MESSAGE_HEAD.size
    messages = result.messages
    while pos < end:
        if buf[pos] == Opcode.MESSAGE and pos + head_size <= end:
            _, length, channel_id, _, log_time, _ = message_head(buf, pos)
            body_end = pos + 9 + length
            if body_end > end or length < head_size - 9:
                return pos
            if log_time > _INT64_MAX:
                result.damage.bad_messages += 1
            else:
                msgs = messages.get(channel_id)
                if msgs is None:
                    msgs = messages[channel_id] = ChannelMessages()
                msgs.log_times.append(log_time)
                msgs.payloads.append(buf[pos + head_size : body_end])
            pos = body_end
            continue
        if pos + 9 > end:
            return pos
        opcode, length = record_head(buf, pos)
        body_end = pos + 9 + length
        if body_end > end:
            if opcode == Opcode.CHUNK:
                result.damage.salvaged_messages += _salvage_chunk(buf, pos + 9, end, result)
            return pos
        try:
            if opcode == Opcode.CHUNK:
                _read_chunk(buf, pos + 9, body_end, result)
            elif opcode == Opcode.FOOTER:
                result.reached_footer = True
                if top:
                    _note_after_footer(buf, body_end, result)
                return None
            elif opcode == 0:  # reserved: zero-filled or overwritten bytes
                raise _CorruptRecordError
            elif opcode != Opcode.MESSAGE:
                _read_other(opcode, buf[pos + 9 : body_end], result)
            else:
                raise _CorruptRecordError
        except _CorruptRecordError:
            return pos
        pos = body_end
    return None


def _read_chunk(buf: bytes | mmap.mmap, start: int, end: int, result: ScanResult) -> None:
    """Open one chunk; a chunk that fails to open is recorded as lost, not raised."""
    try:
        t0, t1, size, crc = _CHUNK_HEAD.unpack_from(buf, start)
        compression, at = _chunk_compression(buf, start)
        (rlen,) = struct.unpack_from("<Q", buf, at)
        at += 8
        if at + rlen > end:
            raise _CorruptRecordError
    except (struct.error, UnicodeDecodeError) as err:
        raise _CorruptRecordError from err
    try:
        records = _decompress(compression, buf[at : at + rlen], size, result)
    except (
        ValueError,
        RuntimeError,
        OverflowError,
        zstandard.ZstdError,
        MemoryError,
        _BudgetError,
    ) as err:
        result.damage.lost_chunks.append((t0, t1))
        result.damage.chunk_errors.append(
            ChunkError(compression, t0, t1, type(err).__name__, str(err))
        )
        return
    if crc and zlib.crc32(records) != crc:  # the chunk is lost; its time span says where
        result.damage.lost_chunks.append((t0, t1))
        return
    if _scan_records(records, 0, len(records), result) is not None:
        result.damage.lost_chunks.append((t0, t1))


def _salvage_chunk(buf: bytes | mmap.mmap, start: int, end: int, result: ScanResult) -> int:
    """Messages recovered from a chunk cut short (by the end of the file or a bad length)."""
    try:
        compression, at = _chunk_compression(buf, start)
        (size,) = struct.unpack_from("<Q", buf, start + 16)
        data = buf[at + 8 : end]
        if compression not in ("", "zstd", "lz4"):
            return 0
        records = _decompress(compression, data, size, result, partial=True)
    except (
        struct.error,
        UnicodeDecodeError,
        ValueError,
        RuntimeError,
        OverflowError,
        zstandard.ZstdError,
        MemoryError,
        _BudgetError,
    ):
        return 0
    before = sum(len(m.log_times) for m in result.messages.values())
    _scan_records(records, 0, len(records), result)
    return sum(len(m.log_times) for m in result.messages.values()) - before


def _chunk_compression(buf: bytes | mmap.mmap, start: int) -> tuple[str, int]:
    """The compression of the chunk whose body starts at ``start``, and the offset after it."""
    (clen,) = struct.unpack_from("<I", buf, start + _CHUNK_HEAD.size)
    at = start + _CHUNK_HEAD.size + 4
    return buf[at : at + clen].decode("utf-8"), at + clen


def _decompress(
    compression: str, data: bytes, size: int, result: ScanResult, *, partial: bool = False
) -> bytes:
    """Decompress a chunk's records by streaming, to at most ``size`` bytes and the budget.

    ``partial``: the data is cut short (salvage): what decompresses before the cut is returned.
    """
    if compression == "":
        return data
    if compression not in ("zstd", "lz4"):
        raise ValueError(f"unknown chunk compression {compression!r}")
    if size > result.budget:
        raise _BudgetError(
            f"it declares {size} bytes uncompressed, beyond the {result.budget} bytes left of "
            f"the decompression budget ({DECOMPRESS_BASE_BYTES} + {DECOMPRESS_RATIO} x the "
            "file size): corrupt or a decompression bomb"
        )
    out = bytearray()
    if compression == "zstd":
        reader = zstandard.ZstdDecompressor().stream_reader(data, read_across_frames=True)
        try:
            while len(out) <= size:
                piece = reader.read(min(_STREAM_STEP, size + 1 - len(out)))
                if not piece:
                    break
                out += piece
        except zstandard.ZstdError:
            if not partial:
                raise
    else:
        lz4d = lz4.frame.LZ4FrameDecompressor()
        try:
            out += lz4d.decompress(data, max_length=size + 1)
        except RuntimeError:
            if not partial:
                raise
    if len(out) > size:
        raise _BudgetError(f"it decompresses to more than the {size} bytes it declares")
    result.budget -= len(out)
    return bytes(out)


def _note_after_footer(buf: bytes | mmap.mmap, footer_end: int, result: ScanResult) -> None:
    """Record bytes after the footer and its closing magic."""
    tail = footer_end + len(MAGIC)
    if tail < len(buf):
        result.after_footer = (tail, len(buf) - tail)
        result.appended_mcap = buf[tail : tail + len(MAGIC)] == MAGIC


def _read_other(opcode: int, body: bytes, result: ScanResult) -> None:
    """Parse the non-message records logcal uses; others are skipped."""
    readers: dict[int, Callable[[ReadDataStream], Any]] = {
        Opcode.SCHEMA: Schema.read,
        Opcode.CHANNEL: Channel.read,
        Opcode.METADATA: Metadata.read,
        Opcode.STATISTICS: Statistics.read,
        Opcode.CHUNK_INDEX: ChunkIndex.read,
    }
    read = readers.get(opcode)
    if read is None:
        return
    stream = ReadDataStream(BytesIO(body))
    try:
        record = read(stream)
    except Exception as err:  # mcap's parsers raise struct/Unicode/EndOfFile errors alike
        raise _CorruptRecordError from err
    if stream.count > len(body):
        raise _CorruptRecordError
    if isinstance(record, Schema):
        result.schemas[record.id] = record
    elif isinstance(record, Channel):
        known = result.channels.get(record.id)
        if known is None:
            result.channels[record.id] = record
        elif (known.topic, known.message_encoding, known.schema_id) != (
            record.topic,
            record.message_encoding,
            record.schema_id,
        ):
            result.channel_conflicts.append(ChannelConflict(record.id, known.topic, record.topic))
    elif isinstance(record, Metadata):
        result.metadata[record.name] = dict(record.metadata)
    elif isinstance(record, Statistics):
        result.statistics = record
    else:
        result.chunk_indexes.append(record)
