"""A forgiving record-level scan of an MCAP file: raw message bytes per channel, plus damage report.

The scan never decodes message payloads. It walks the records of the data section, opens chunks
(zstd, lz4 or uncompressed; CRC-checked when the writer stored a CRC), and collects for every
channel the MCAP ``log_time`` values and where its payloads are (:class:`Payloads`: offsets and
lengths into the decompressed bytes, not one ``bytes`` object per message), so that decoders can
work per channel in bulk. The summary section is read first through the footer when it is intact:
its statistics give the expected message count per channel and its chunk index lets the scan skip
over a damaged region to the next chunk. What could not be read is described in
``ScanResult.damage``.

Why hand-written (the ``mcap`` package's reader yields one Python object per message, ~1 µs each):
with an intact summary, every chunk is decompressed into its slot of one preallocated buffer and
its messages are located through the chunk's MessageIndex records with numpy (offsets sorted,
each checked against the record it points at: opcode, channel, log time, length, and records
tiling the chunk without overlap; the bytes between messages, such as schema and channel
records, are read record by record). Whenever the index does not agree with the bytes, or there
is no index, the chunk is walked record by record, which is also the path for unchunked files.

Bounds: a chunk is decompressed by streaming, never beyond its declared
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
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from io import BytesIO
from typing import Any, overload

import lz4.frame
import numpy as np
import zstandard
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, ChunkIndex, Metadata, MetadataIndex, Schema, Statistics

__all__ = [
    "DECOMPRESS_BASE_BYTES",
    "DECOMPRESS_RATIO",
    "MAGIC",
    "ChannelConflict",
    "ChannelMessages",
    "ChunkError",
    "Damage",
    "Payloads",
    "ScanResult",
    "read_metadata_record",
    "read_summary",
    "scan_chunks",
    "scan_mcap",
    "summary_offset",
]

MAGIC = b"\x89MCAP0\r\n"
_RECORD_HEAD = struct.Struct("<BQ")  # opcode, body length
_MESSAGE_HEAD = struct.Struct("<BQHIQQ")  # opcode, length, channel id, sequence, log, publish time
_MESSAGE_INDEX_HEAD = struct.Struct("<BQHI")  # opcode, length, channel id, records' byte length
_CHUNK_HEAD = struct.Struct("<QQQI")  # start, end, uncompressed size, uncompressed crc
_FOOTER = struct.Struct("<BQQQI")
_INT64_MAX = 2**63 - 1
_HEAD = _MESSAGE_HEAD.size  # 31: a message's payload starts this far after its opcode
_MAX_GAPS = 64  # more non-message stretches in one chunk: walk it record by record
DECOMPRESS_BASE_BYTES = 64 * 2**20
"""Decompressed bytes every file may produce, whatever its size (64 MiB)."""
DECOMPRESS_RATIO = 32
"""Further decompressed bytes per byte of file (real logs compress 2-10 times)."""
_STREAM_STEP = 1 << 20
_EMPTY_BYTES = np.zeros(0, dtype=np.uint8)
_Buffer = bytes | mmap.mmap | memoryview
_EMPTY_INTS = np.zeros(0, dtype=np.int64)


class _CorruptRecordError(Exception):
    """A record whose body does not parse."""


class Payloads(Sequence[bytes]):
    """The raw payloads of one channel: (start, length) views into one byte buffer.

    Indexing gives ``bytes``, as a list of payloads would; bulk decoders use ``buffer``,
    ``starts`` and ``lengths`` directly and never build one object per message.
    """

    __slots__ = ("buffer", "lengths", "starts")

    def __init__(self, buffer: np.ndarray, starts: np.ndarray, lengths: np.ndarray) -> None:
        self.buffer = buffer
        self.starts = starts
        self.lengths = lengths

    @classmethod
    def from_bytes(cls, payloads: Iterable[bytes]) -> Payloads:
        """Payloads held as separate ``bytes`` objects, joined into one buffer."""
        items = list(payloads)
        lengths = np.fromiter(map(len, items), dtype=np.int64, count=len(items))
        starts = np.zeros(len(items), dtype=np.int64)
        np.cumsum(lengths[:-1], out=starts[1:])
        return cls(np.frombuffer(b"".join(items), dtype=np.uint8), starts, lengths)

    def __len__(self) -> int:
        return len(self.starts)

    @overload
    def __getitem__(self, index: int) -> bytes: ...

    @overload
    def __getitem__(self, index: slice) -> Payloads: ...

    def __getitem__(self, index: int | slice) -> bytes | Payloads:
        if isinstance(index, slice):
            return Payloads(self.buffer, self.starts[index], self.lengths[index])
        start = int(self.starts[index])
        return self.buffer[start : start + int(self.lengths[index])].tobytes()

    def __iter__(self) -> Iterator[bytes]:
        view = self.buffer.data
        for start, length in zip(self.starts.tolist(), self.lengths.tolist(), strict=True):
            yield bytes(view[start : start + length])

    def __repr__(self) -> str:
        return f"Payloads({len(self)} messages, {int(self.lengths.sum())} bytes)"


@dataclass
class ChannelMessages:
    """Raw messages of one channel in file order: ``log_time`` (ns, int64) and payloads."""

    log_times: np.ndarray = field(default_factory=lambda: _EMPTY_INTS)
    payloads: Payloads = field(
        default_factory=lambda: Payloads(_EMPTY_BYTES, _EMPTY_INTS, _EMPTY_INTS)
    )


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
    metadata_indexes: list[MetadataIndex] = field(default_factory=list)
    reached_footer: bool = False
    damage: Damage = field(default_factory=Damage)
    after_footer: tuple[int, int] | None = None
    """(offset, bytes) of data after the footer's closing magic; None when the file ends there."""
    appended_mcap: bool = False
    """The data after the footer starts with the MCAP magic: a second file was appended."""
    channel_conflicts: list[ChannelConflict] = field(default_factory=list)
    budget: int = 0
    """Decompressed bytes the scan may still produce."""


class _Scan:
    """Scan state: the result, the buffers messages lie in, and each channel's pieces."""

    def __init__(self, result: ScanResult, only: frozenset[int] | None = None) -> None:
        self.result = result
        self.only = only  # chunk record offsets the arena is planned for (None: all)
        self.buffers: list[np.ndarray] = []
        self.file_buffer: int | None = None
        # channel id -> [(buffer index, payload starts, payload lengths, log times)]
        self.parts: dict[int, list[tuple[int, np.ndarray, np.ndarray, np.ndarray]]] = {}
        self.committed = 0  # messages kept so far
        self.arena: np.ndarray | None = None
        self.arena_id = -1
        self.indexes: dict[int, ChunkIndex] = {}  # chunk record offset -> its index
        self.slots: dict[int, int] = {}  # chunk record offset -> its start in the arena

    def add_buffer(self, buffer: np.ndarray) -> int:
        self.buffers.append(buffer)
        return len(self.buffers) - 1


def scan_mcap(buf: bytes | mmap.mmap) -> ScanResult:
    """Scan an MCAP file held in memory.

    Args:
        buf: the whole file (bytes or memory map); it starts with :data:`MAGIC`.

    Returns:
        The schemas, channels, raw messages per channel, metadata records, summary statistics
        (when readable) and a description of any damage.
    """
    result = ScanResult(size=len(buf), budget=DECOMPRESS_BASE_BYTES + DECOMPRESS_RATIO * len(buf))
    scan = _Scan(result)
    summary_start = _read_summary(buf, result)
    _plan_arena(scan)
    data_end = summary_start or len(buf)  # with a good summary, the data section ends there
    resume_points = sorted(ci.chunk_start_offset for ci in result.chunk_indexes)
    pos = len(MAGIC)
    while True:
        stop = _scan_records(buf, pos, data_end, scan, top=True)
        if stop is None:
            result.reached_footer = result.reached_footer or bool(summary_start)
            break
        resume = next((p for p in resume_points if stop < p < data_end), None)
        if resume is None:
            result.damage.unreadable_tail_bytes = data_end - stop
            result.damage.last_good_offset = stop
            break
        result.damage.skipped.append((stop, resume))
        result.damage.lost_chunks += [
            (ci.message_start_time, ci.message_end_time)
            for ci in result.chunk_indexes
            if stop <= ci.chunk_start_offset < resume
        ]
        pos = resume
    _finish(scan)
    return result


def _read_summary(buf: _Buffer, result: ScanResult) -> int:
    """Read the summary section through the footer; return its start offset (0 if unusable)."""
    n = len(buf)
    at = n - len(MAGIC) - _FOOTER.size
    summary_start = summary_offset(buf)
    if not summary_start:
        return 0
    probe = ScanResult(size=n)
    if _scan_records(buf, summary_start, at, _Scan(probe)) is not None or probe.reached_footer:
        return 0  # a damaged summary is ignored as a whole (a footer inside it: concatenation)
    result.schemas.update(probe.schemas)
    result.channels.update(probe.channels)
    result.channel_conflicts += probe.channel_conflicts
    result.statistics = probe.statistics
    result.chunk_indexes = probe.chunk_indexes
    result.metadata_indexes = probe.metadata_indexes
    return summary_start


def summary_offset(buf: _Buffer) -> int:
    """Where the summary section starts, from the footer at the end of ``buf`` (0: no valid
    footer, or no summary)."""
    n = len(buf)
    at = n - len(MAGIC) - _FOOTER.size
    if at < len(MAGIC) or buf[n - len(MAGIC) :] != MAGIC:
        return 0
    opcode, length, summary_start, _offset_start, _crc = _FOOTER.unpack_from(buf, at)
    if opcode != Opcode.FOOTER or length != 20 or not len(MAGIC) <= summary_start < at:
        return 0
    return int(summary_start)


def read_metadata_record(record: _Buffer, result: ScanResult) -> bool:
    """Parse one whole Metadata record (opcode and length first) into ``result.metadata``;
    False when it is not one."""
    if len(record) < 9 or record[0] != Opcode.METADATA:
        return False
    (length,) = struct.unpack_from("<Q", record, 1)
    if length != len(record) - 9:
        return False
    try:
        _read_other(Opcode.METADATA, bytes(record[9:]), result)
    except _CorruptRecordError:
        return False
    return True


def read_summary(buf: _Buffer) -> tuple[ScanResult, int]:
    """The summary section alone (schemas, channels, statistics, chunk and metadata indexes),
    read through the footer, and its start offset (0 when it is missing or damaged; then the
    result is empty). Only the file's first and last bytes and the summary are looked at, so
    ``buf`` may hold just those (the rest zero)."""
    result = ScanResult(size=len(buf), budget=DECOMPRESS_BASE_BYTES + DECOMPRESS_RATIO * len(buf))
    start = _read_summary(buf, result)
    result.reached_footer = bool(start)
    return result, start


def scan_chunks(buf: _Buffer, summary: ScanResult, chunks: Sequence[ChunkIndex]) -> ScanResult:
    """Open just the chunks ``chunks`` (entries of ``summary.chunk_indexes``) and collect their
    messages, as :func:`scan_mcap` would: each chunk's bytes and the MessageIndex records after
    it must be in ``buf`` at their file offsets (the rest of ``buf`` is not read). Schemas and
    channels start from the summary's; a chunk that fails is recorded in ``damage``."""
    result = ScanResult(size=summary.size, budget=summary.budget)
    result.schemas.update(summary.schemas)
    result.channels.update(summary.channels)
    result.chunk_indexes = list(chunks)
    scan = _Scan(result, frozenset(c.chunk_start_offset for c in chunks))
    _plan_arena(scan)
    for ci in chunks:
        end = ci.chunk_start_offset + ci.chunk_length
        try:
            if end > len(buf) or buf[ci.chunk_start_offset] != Opcode.CHUNK:
                raise _CorruptRecordError  # the index points at something else
            _read_chunk(buf, ci.chunk_start_offset, end, scan)
        except _CorruptRecordError:
            result.damage.lost_chunks.append((ci.message_start_time, ci.message_end_time))
    _finish(scan)
    return result


def _plan_arena(scan: _Scan) -> None:
    """One buffer for all compressed chunks the summary lists, when they fit the budget."""
    at = 0
    for ci in sorted(scan.result.chunk_indexes, key=lambda c: c.chunk_start_offset):
        if ci.chunk_start_offset in scan.indexes:
            continue
        scan.indexes[ci.chunk_start_offset] = ci
        if scan.only is not None and ci.chunk_start_offset not in scan.only:
            continue
        if ci.compression in ("zstd", "lz4"):
            scan.slots[ci.chunk_start_offset] = at
            at += ci.uncompressed_size
    if not scan.slots or at > scan.result.budget:
        scan.slots = {}
        return
    scan.arena = np.empty(at, dtype=np.uint8)  # pages are committed as chunks fill them
    scan.arena_id = scan.add_buffer(scan.arena)


def _scan_records(
    buf: _Buffer,
    pos: int,
    end: int,
    scan: _Scan,
    *,
    top: bool = False,
    source: tuple[int, int] | None = None,
) -> int | None:
    """Read records from ``pos`` up to ``end``; return None when done, else the failing offset.

    ``top``: ``buf`` is the file itself (not a chunk's records or the summary), so bytes after a
    footer are the file's. ``source``: (buffer index, offset of ``buf`` in it) of the messages
    found; None: ``buf`` is the file.
    """
    positions: list[int] = []
    try:
        return _walk(buf, pos, end, scan, positions, top)
    finally:
        if positions:
            if source is None:
                if scan.file_buffer is None:
                    scan.file_buffer = scan.add_buffer(np.frombuffer(buf, dtype=np.uint8))
                source = (scan.file_buffer, 0)
            _commit(scan, source[0], np.asarray(positions, dtype=np.int64) + source[1])


def _walk(
    buf: _Buffer,
    pos: int,
    end: int,
    scan: _Scan,
    positions: list[int],
    top: bool,
) -> int | None:
    """The record-by-record loop; message records only have their offset noted (hot path)."""
    record_head = _RECORD_HEAD.unpack_from
    result = scan.result
    note = positions.append
    while pos < end:
        if buf[pos] == Opcode.MESSAGE and pos + _HEAD <= end:
            _, length = record_head(buf, pos)
            body_end = pos + 9 + length
            if body_end > end or length < _HEAD - 9:
                return pos
            note(pos)
            pos = body_end
            continue
        if pos + 9 > end:
            return pos
        opcode, length = record_head(buf, pos)
        body_end = pos + 9 + length
        if body_end > end:
            if opcode == Opcode.CHUNK:
                result.damage.salvaged_messages += _salvage_chunk(buf, pos + 9, end, scan)
            return pos
        try:
            if opcode == Opcode.CHUNK:
                _read_chunk(buf, pos, body_end, scan)
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


def _values(buffer: np.ndarray, at: np.ndarray, dtype: str) -> np.ndarray:
    """Values of ``dtype`` starting at the byte offsets ``at`` of ``buffer`` (unaligned)."""
    size = np.dtype(dtype).itemsize
    view = np.ndarray((len(buffer) - size + 1,), dtype=dtype, buffer=buffer, strides=(1,))
    return view[at]


def _commit(scan: _Scan, buffer_id: int, positions: np.ndarray) -> None:
    """Keep the messages whose records start at ``positions`` (checked complete) in a buffer."""
    buffer = scan.buffers[buffer_id]
    length = _values(buffer, positions + 1, "<u8").astype(np.int64)
    channel = _values(buffer, positions + 9, "<u2")
    log_time = _values(buffer, positions + 15, "<u8")
    bad = log_time > _INT64_MAX
    if bad.any():
        scan.result.damage.bad_messages += int(bad.sum())
        keep = ~bad
        positions, length, channel, log_time = (
            positions[keep],
            length[keep],
            channel[keep],
            log_time[keep],
        )
    times = log_time.astype(np.int64)
    starts = positions + _HEAD
    lengths = length - (_HEAD - 9)
    scan.committed += len(positions)
    ids = np.unique(channel)
    for cid in ids.tolist():
        if len(ids) == 1:
            piece = (buffer_id, starts, lengths, times)
        else:
            sel = channel == cid
            piece = (buffer_id, starts[sel], lengths[sel], times[sel])
        scan.parts.setdefault(cid, []).append(piece)


def _finish(scan: _Scan) -> None:
    """Each channel's pieces -> one :class:`ChannelMessages` over a single buffer."""
    used = sorted({p[0] for parts in scan.parts.values() for p in parts})
    spread = any(len({p[0] for p in parts}) > 1 for parts in scan.parts.values())
    base = dict.fromkeys(used, 0)
    merged: np.ndarray | None = None
    if spread:  # no summary, damage or unchunked messages: one copy into a single buffer
        sizes = [len(scan.buffers[b]) for b in used]
        offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
        base = dict(zip(used, offsets.tolist(), strict=True))
        merged = np.concatenate([scan.buffers[b] for b in used])
    for cid, parts in scan.parts.items():
        buffer = merged if merged is not None else scan.buffers[parts[0][0]]
        if len(parts) == 1 and not base[parts[0][0]]:
            _, starts, lengths, times = parts[0]
        else:
            starts = np.concatenate([p[1] + base[p[0]] for p in parts])
            lengths = np.concatenate([p[2] for p in parts])
            times = np.concatenate([p[3] for p in parts])
        scan.result.messages[cid] = ChannelMessages(times, Payloads(buffer, starts, lengths))
    scan.parts.clear()
    scan.buffers.clear()


def _read_chunk(buf: _Buffer, record: int, end: int, scan: _Scan) -> None:
    """Open the chunk whose record starts at ``record``; one that fails to open is recorded as
    lost, not raised."""
    result = scan.result
    start = record + 9
    try:
        t0, t1, size, crc = _CHUNK_HEAD.unpack_from(buf, start)
        compression, at = _chunk_compression(buf, start)
        (rlen,) = struct.unpack_from("<Q", buf, at)
        at += 8
        if at + rlen > end:
            raise _CorruptRecordError
    except (struct.error, UnicodeDecodeError) as err:
        raise _CorruptRecordError from err
    index = scan.indexes.pop(record, None)
    if index is not None and (index.compression != compression or index.uncompressed_size != size):
        index = None
    slot = scan.slots.pop(record, None) if index is not None else None
    try:
        if compression == "":
            if scan.file_buffer is None:
                scan.file_buffer = scan.add_buffer(np.frombuffer(buf, dtype=np.uint8))
            records: memoryview | bytes = memoryview(buf)[at : at + rlen]
            source = (scan.file_buffer, at)
        elif slot is not None and scan.arena is not None:
            out = scan.arena.data[slot : slot + size]
            got = _decompress_into(compression, buf[at : at + rlen], out, result)
            records = out[:got]
            source = (scan.arena_id, slot)
        else:
            records = _decompress(compression, bytes(buf[at : at + rlen]), size, result)
            source = (scan.add_buffer(np.frombuffer(records, dtype=np.uint8)), 0)
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
    if index is not None and _read_indexed(buf, records, index, scan, source):
        return
    if _scan_records(records, 0, len(records), scan, source=source) is not None:
        result.damage.lost_chunks.append((t0, t1))


def _read_indexed(
    buf: _Buffer,
    records: memoryview | bytes,
    index: ChunkIndex,
    scan: _Scan,
    source: tuple[int, int],
) -> bool:
    """Keep a chunk's messages as its MessageIndex records locate them; False: walk it instead.

    Every index entry is checked against the record it points at; the records must tile the
    chunk, and the stretches between messages must read as non-message records.
    """
    located = _index_entries(buf, index)
    if located is None:
        return False
    offsets, channels, times = located
    size = len(records)
    buffer = scan.buffers[source[0]]
    if len(offsets):
        if int(offsets.max()) > size - _HEAD:
            return False
        order = np.argsort(offsets, kind="stable")
        at = offsets[order].astype(np.int64)
        channels, times = channels[order], times[order]
        pos = at + source[1]
        length = _values(buffer, pos + 1, "<u8")
        if (
            bool(np.any(buffer[pos] != int(Opcode.MESSAGE)))
            or bool(np.any(length > size))
            or bool(np.any(length < _HEAD - 9))
            or bool(np.any(_values(buffer, pos + 9, "<u2") != channels))
            or bool(np.any(_values(buffer, pos + 15, "<u8") != times))
        ):
            return False
        ends = at + 9 + length.astype(np.int64)
        if int(ends[-1]) > size or bool(np.any(at[1:] < ends[:-1])):
            return False
        gap_starts = np.concatenate([[0], ends])
        gap_ends = np.concatenate([at, [size]])
    else:
        at = _EMPTY_INTS
        gap_starts, gap_ends = np.array([0]), np.array([size])
    gaps = np.flatnonzero(gap_ends > gap_starts)
    if len(gaps) > _MAX_GAPS:
        return False
    probe = ScanResult(size=scan.result.size)
    probe_scan = _Scan(probe)
    in_gap: list[int] = []
    for g in gaps.tolist():
        stop = _walk(records, int(gap_starts[g]), int(gap_ends[g]), probe_scan, in_gap, False)
        if stop is not None or in_gap or probe.reached_footer or probe_scan.committed:
            return False
    _merge(probe, scan.result)
    if len(at):
        _commit(scan, source[0], at + source[1])
    return True


def _index_entries(
    buf: _Buffer, index: ChunkIndex
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(offsets in the chunk, channel ids, log times) from a chunk's MessageIndex records."""
    offsets: list[np.ndarray] = []
    channels: list[np.ndarray] = []
    times: list[np.ndarray] = []
    n = len(buf)
    for cid, where in index.message_index_offsets.items():
        if where + _MESSAGE_INDEX_HEAD.size > n:
            return None
        opcode, length, record_cid, nbytes = _MESSAGE_INDEX_HEAD.unpack_from(buf, where)
        if (
            opcode != Opcode.MESSAGE_INDEX
            or record_cid != cid
            or nbytes % 16
            or nbytes + 6 > length
            or where + 9 + length > n
        ):
            return None
        entries = np.frombuffer(buf, dtype="<u8", count=nbytes // 8, offset=where + 15)
        times.append(entries[0::2])
        offsets.append(entries[1::2])
        channels.append(np.full(nbytes // 16, cid, dtype=np.uint16))
    if not offsets:
        return _EMPTY_INTS.astype(np.uint64), _EMPTY_INTS.astype(np.uint16), _EMPTY_INTS
    return np.concatenate(offsets), np.concatenate(channels), np.concatenate(times)


def _merge(probe: ScanResult, result: ScanResult) -> None:
    """Records read between a chunk's messages, as if read in place."""
    result.schemas.update(probe.schemas)
    for record in probe.channels.values():
        _add_channel(record, result)
    result.channel_conflicts += probe.channel_conflicts
    result.metadata.update(probe.metadata)
    if probe.statistics is not None:
        result.statistics = probe.statistics
    result.chunk_indexes += probe.chunk_indexes


def _salvage_chunk(buf: _Buffer, start: int, end: int, scan: _Scan) -> int:
    """Messages recovered from a chunk cut short (by the end of the file or a bad length)."""
    try:
        compression, at = _chunk_compression(buf, start)
        (size,) = struct.unpack_from("<Q", buf, start + 16)
        data = bytes(buf[at + 8 : end])
        if compression not in ("", "zstd", "lz4"):
            return 0
        records = _decompress(compression, data, size, scan.result, partial=True)
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
    before = scan.committed
    source = (scan.add_buffer(np.frombuffer(records, dtype=np.uint8)), 0)
    _scan_records(records, 0, len(records), scan, source=source)
    return scan.committed - before


def _chunk_compression(buf: _Buffer, start: int) -> tuple[str, int]:
    """The compression of the chunk whose body starts at ``start``, and the offset after it."""
    (clen,) = struct.unpack_from("<I", buf, start + _CHUNK_HEAD.size)
    at = start + _CHUNK_HEAD.size + 4
    return bytes(buf[at : at + clen]).decode("utf-8"), at + clen


def _check_budget(size: int, result: ScanResult) -> None:
    if size > result.budget:
        raise _BudgetError(
            f"it declares {size} bytes uncompressed, beyond the {result.budget} bytes left of "
            f"the decompression budget ({DECOMPRESS_BASE_BYTES} + {DECOMPRESS_RATIO} x the "
            "file size): corrupt or a decompression bomb"
        )


def _decompress_into(
    compression: str, data: bytes | memoryview, out: memoryview, result: ScanResult
) -> int:
    """Decompress a chunk's records into ``out`` (its declared size); return the bytes written."""
    if compression not in ("zstd", "lz4"):
        raise ValueError(f"unknown chunk compression {compression!r}")
    size = len(out)
    _check_budget(size, result)
    if compression == "zstd":
        reader = zstandard.ZstdDecompressor().stream_reader(data, read_across_frames=True)
        got = 0
        while got < size:
            step = reader.readinto(out[got:])
            if not step:
                break
            got += step
        if got == size and reader.read(1):
            raise _BudgetError(f"it decompresses to more than the {size} bytes it declares")
    else:
        piece = lz4.frame.LZ4FrameDecompressor().decompress(data, max_length=size + 1)
        got = len(piece)
        if got > size:
            raise _BudgetError(f"it decompresses to more than the {size} bytes it declares")
        out[:got] = piece
    result.budget -= got
    return got


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
    _check_budget(size, result)
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


def _note_after_footer(buf: _Buffer, footer_end: int, result: ScanResult) -> None:
    """Record bytes after the footer and its closing magic."""
    tail = footer_end + len(MAGIC)
    if tail < len(buf):
        result.after_footer = (tail, len(buf) - tail)
        result.appended_mcap = buf[tail : tail + len(MAGIC)] == MAGIC


def _read_other(opcode: int, body: bytes | memoryview, result: ScanResult) -> None:
    """Parse the non-message records logcal uses; others are skipped."""
    readers: dict[int, Callable[[ReadDataStream], Any]] = {
        Opcode.SCHEMA: Schema.read,
        Opcode.CHANNEL: Channel.read,
        Opcode.METADATA: Metadata.read,
        Opcode.STATISTICS: Statistics.read,
        Opcode.CHUNK_INDEX: ChunkIndex.read,
        Opcode.METADATA_INDEX: MetadataIndex.read,
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
        _add_channel(record, result)
    elif isinstance(record, Metadata):
        result.metadata[record.name] = dict(record.metadata)
    elif isinstance(record, Statistics):
        result.statistics = record
    elif isinstance(record, MetadataIndex):
        result.metadata_indexes.append(record)
    else:
        result.chunk_indexes.append(record)


def _add_channel(record: Channel, result: ScanResult) -> None:
    known = result.channels.get(record.id)
    if known is None:
        result.channels[record.id] = record
    elif (known.topic, known.message_encoding, known.schema_id) != (
        record.topic,
        record.message_encoding,
        record.schema_id,
    ):
        result.channel_conflicts.append(ChannelConflict(record.id, known.topic, record.topic))
