"""Read an MCAP file into per-topic polars frames, saying what was lost."""

from __future__ import annotations

import dataclasses
import mmap
from collections.abc import Iterable
from io import RawIOBase

import numpy as np
import polars as pl
from mcap.records import Channel, ChunkIndex, Statistics

from logtools.errors import NotAnMcapError, UnknownEncodingError
from logtools.problems import Problem, ProblemKind
from logtools.readers.base import (
    DROPPED_COLUMNS,
    TIME_COLUMN,
    ColumnFilter,
    LogData,
    TopicInfo,
    sorted_by_time,
)
from logtools.readers.decoders import (
    CELL_BUDGET_BASE,
    CELLS_PER_PAYLOAD_BYTE,
    DEFAULT_DECODERS,
    MAX_COLUMNS,
    Decoded,
    Decoders,
    known_encodings,
)
from logtools.readers.mcap_scan import (
    MAGIC,
    ChannelMessages,
    ScanResult,
    read_metadata_record,
    read_summary,
    scan_chunks,
    scan_mcap,
    summary_offset,
)

__all__ = ["BATCH_BYTES", "McapExtent", "mcap_extent", "read_mcap", "read_mcap_batched"]


def read_mcap(
    path: str,
    buf: bytes,
    topics: Iterable[str] | None = None,
    decoders: Decoders = DEFAULT_DECODERS,
    keep: ColumnFilter | None = None,
) -> LogData:
    """Decode the MCAP file ``buf`` (read from ``path``).

    Args:
        path: file name, for messages.
        buf: the file's bytes (starting with the MCAP magic).
        topics: decode only these topics (all are still listed in ``info``); None: all.
        decoders: MCAP message encoding -> decoder.
        keep: (topic, column) -> whether a decoded column is kept (``t_ns`` always is);
            None: all. Applied to each channel as it is decoded, so a dropped column never
            exists for the whole log.

    Raises:
        NotAnMcapError: nothing could be read (e.g. cut right after the header).
        UnknownEncodingError: no topic with messages has an encoding logcal can decode.
    """
    scan = scan_mcap(buf)
    if not scan.channels and scan.damage.any:
        why = f"{scan.damage.unreadable_tail_bytes} of them unreadable (truncated or corrupt)"
        if scan.damage.chunk_errors:
            e = scan.damage.chunk_errors[0]
            why = f"a {e.compression or 'plain'} chunk did not open: {e.error}"
        raise NotAnMcapError(
            path, f"MCAP magic found, but no channel could be read: {len(buf)} bytes, {why}"
        )
    by_topic = _channels_by_topic(scan)
    info = {topic: _topic_info(scan, chans) for topic, chans in by_topic.items()}
    origin = min((i.first_ns for i in info.values() if i.first_ns is not None), default=0)
    problems = _damage_problems(path, scan, info, origin)
    wanted = set(by_topic) if topics is None else set(topics)
    frames: dict[str, pl.DataFrame] = {}
    undecodable: list[tuple[str, str]] = []
    for topic, chans in sorted(by_topic.items()):
        if topic not in wanted:
            continue
        parts = []
        for ch in chans:
            frame, problem = _decode_channel(path, scan, ch, decoders, keep)
            if problem is not None:
                problems.append(problem)
            if frame is None and ch.message_encoding not in decoders:
                undecodable.append((topic, ch.message_encoding))
            if frame is not None:
                parts.append(frame)
        if parts:
            frames[topic] = sorted_by_time(
                pl.concat(parts, how="diagonal_relaxed"), path, topic, problems, "log_time"
            )
    if undecodable and not frames and any(info[t].message_count for t, _ in undecodable):
        topic, encoding = undecodable[0]
        raise UnknownEncodingError(path, topic, encoding, known_encodings(decoders))
    return LogData(path, frames, info, dict(scan.metadata), problems)


BATCH_BYTES = 16 * 2**20
"""Decompressed bytes of chunks decoded at a time in a large file (16 MiB)."""


def read_mcap_batched(
    path: str,
    size: int,
    topics: Iterable[str] | None = None,
    decoders: Decoders = DEFAULT_DECODERS,
    keep: ColumnFilter | None = None,
    span_ns: tuple[int, int] | None = None,
) -> LogData | None:
    """Read a large, intact MCAP file ``BATCH_BYTES`` of chunks at a time, never holding the
    whole file; None when the file does not qualify or is not MCAP (the caller then reads it
    whole, which also reports any damage).

    ``span_ns`` (first, last log time, inclusive): read only the chunks whose time range meets
    it (the summary's chunk index gives each chunk's first and last log time) and keep only
    its messages, so a time window of a long log costs that window's chunks, not the file's.
    ``info`` then counts the messages of the span, and the check against the statistics'
    counts (which are the whole file's) is left to the caller: a windowed analysis compares
    the sum over its windows (:mod:`logtools.windows`).

    Reading whole holds the file's bytes and every decompressed chunk until the last channel
    is decoded: for a 1 M-message JSON log, 36 MB of file and 75 MB of chunks beside 21 MB of
    frames (issue 14). Here the summary (through the footer) lists the chunks; each batch's
    bytes are read from the file into an anonymous memory map at their offsets, decoded
    channel by channel, and their pages released before the next batch, so only one batch is
    held. The frames are the same as a whole read's: each channel's parts are decoded as the
    whole channel would be and joined (the tests compare them on every sample log).

    Qualifies: a readable summary with statistics, chunk indexes and an index entry for every
    metadata record; more decompressed bytes than one batch; a decoder for every channel's
    encoding. Falls back (None) when a batch finds damage, a channel id defined twice or a
    message of an unknown channel, a decoder drops messages, or the messages read differ from
    the counts the statistics give (a message outside the listed chunks, a summary that
    disagrees). A second file appended after the footer leaves no readable summary (a footer
    inside it), so it is read whole and reported.
    """
    if size < len(MAGIC) + 64:
        return None
    with open(path, "rb", buffering=0) as fh:
        if fh.read(len(MAGIC)) != MAGIC:
            return None  # not MCAP: the caller reads it as what it is
        amap = mmap.mmap(-1, size)  # anonymous: only the pages written take memory

        def load(start: int, end: int) -> bool:
            return _load(fh, amap, start, end)

        found = _summary(fh, amap, size)
        if found is None:
            return None
        summary, start = found
        summary_start = summary_offset(amap)
        stats = summary.statistics
        ordered = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
        if (
            not start
            or stats is None
            or not ordered
            or sum(c.uncompressed_size for c in ordered) <= BATCH_BYTES
            or stats.metadata_count != len(summary.metadata_indexes)
            or any(ch.message_encoding not in decoders for ch in summary.channels.values())
        ):
            return None
        for mi in summary.metadata_indexes:
            if not (len(MAGIC) <= mi.offset and mi.offset + mi.length <= summary_start):
                return None
            if not load(mi.offset, mi.offset + mi.length):
                return None
            if not read_metadata_record(amap[mi.offset : mi.offset + mi.length], summary):
                return None
        if span_ns is not None:
            ordered = [
                c
                for c in ordered
                if c.message_end_time >= span_ns[0] and c.message_start_time <= span_ns[1]
            ]
        wanted = None if topics is None else set(topics)
        times: dict[int, list[np.ndarray]] = {}
        parts: dict[int, list[pl.DataFrame]] = {}
        for batch in _batches(ordered):
            lo = batch[0].chunk_start_offset
            hi = batch[-1].chunk_start_offset + batch[-1].chunk_length
            hi += batch[-1].message_index_length
            if not (len(MAGIC) <= lo < hi <= summary_start and load(lo, hi)):
                return None
            ok = _decode_batch(
                path, amap, batch, summary, wanted, decoders, keep, times, parts, span_ns
            )
            if hasattr(mmap, "MADV_DONTNEED"):  # give the batch's pages back (Linux, macOS)
                first = lo // mmap.PAGESIZE * mmap.PAGESIZE
                amap.madvise(mmap.MADV_DONTNEED, first, hi - first)
            if not ok:
                return None
    return _assemble(
        path, summary, stats, wanted, decoders, keep, times, parts, whole=span_ns is None
    )


def _summary(fh: RawIOBase, amap: mmap.mmap, size: int) -> tuple[ScanResult, int] | None:
    """The summary of the MCAP file open as ``fh`` (``size`` bytes) and where it starts, its
    footer and summary read into ``amap`` at their offsets; None when they cannot be read."""
    tail = min(size, 4096)
    if not _load(fh, amap, size - tail, size):
        return None
    summary_start = summary_offset(amap)
    if not summary_start or not _load(fh, amap, summary_start, size):
        return None
    return read_summary(amap)


def _load(fh: RawIOBase, amap: mmap.mmap, start: int, end: int) -> bool:
    """Read the file's bytes ``start:end`` into ``amap`` at the same offsets."""
    fh.seek(start)
    view = memoryview(amap)[start:end]
    try:
        return fh.readinto(view) == end - start
    finally:
        view.release()


def _batches(ordered: list[ChunkIndex]) -> list[list[ChunkIndex]]:
    """Consecutive chunks in groups of at most ``BATCH_BYTES`` decompressed (one at least)."""
    batches: list[list[ChunkIndex]] = [[]]
    size = 0
    for c in ordered:
        if batches[-1] and size + c.uncompressed_size > BATCH_BYTES:
            batches.append([])
            size = 0
        batches[-1].append(c)
        size += c.uncompressed_size
    return batches


def _assemble(
    path: str,
    summary: ScanResult,
    stats: Statistics,
    wanted: set[str] | None,
    decoders: Decoders,
    keep: ColumnFilter | None,
    times: dict[int, list[np.ndarray]],
    parts: dict[int, list[pl.DataFrame]],
    *,
    whole: bool = True,
) -> LogData | None:
    """The batches' pieces as one :class:`LogData` (None if the counts disagree; not
    ``whole``: a time span was read, whose counts the statistics do not give)."""
    summary.messages = {
        cid: ChannelMessages(np.concatenate(t) if len(t) > 1 else t[0]) for cid, t in times.items()
    }
    counts = {cid: len(m.log_times) for cid, m in summary.messages.items() if len(m.log_times)}
    if whole and counts != {c: n for c, n in stats.channel_message_counts.items() if n}:
        return None  # a message outside the listed chunks, or a summary that disagrees
    if not whole:
        summary.statistics = None  # the whole file's counts: no "lost messages" for a span
    by_topic = _channels_by_topic(summary)
    info = {topic: _topic_info(summary, chans) for topic, chans in by_topic.items()}
    origin = min((i.first_ns for i in info.values() if i.first_ns is not None), default=0)
    problems = _damage_problems(path, summary, info, origin)
    frames: dict[str, pl.DataFrame] = {}
    for topic, chans in sorted(by_topic.items()):
        if wanted is not None and topic not in wanted:
            continue
        for ch in chans:  # a channel without messages: its empty frame, as when read whole
            if ch.id not in parts:
                empty, _ = _decode_channel(path, summary, ch, decoders, keep)
                parts[ch.id] = [] if empty is None else [empty]
        # taken out of ``parts`` as they are joined: one topic's pieces exist twice at a time
        pieces = [f for ch in chans for f in parts.pop(ch.id, [])]
        if pieces:
            joined = pl.concat(pieces, how="diagonal_relaxed")
            del pieces
            frames[topic] = sorted_by_time(joined, path, topic, problems, "log_time")
    return LogData(path, frames, info, dict(summary.metadata), problems)


def _decode_batch(
    path: str,
    buf: mmap.mmap,
    batch: list[ChunkIndex],
    probe: ScanResult,
    wanted: set[str] | None,
    decoders: Decoders,
    keep: ColumnFilter | None,
    times: dict[int, list[np.ndarray]],
    parts: dict[int, list[pl.DataFrame]],
    span_ns: tuple[int, int] | None = None,
) -> bool:
    """Open the chunks ``batch`` and decode their messages into ``times`` and ``parts`` (per
    channel), only those within ``span_ns`` when given; False on damage or lost messages. Its
    own function so that nothing refers to the batch's decompressed chunks once it returns."""
    scan = scan_chunks(buf, probe, batch)
    if scan.damage.any or scan.channel_conflicts or set(scan.messages) - set(scan.channels):
        return False  # the whole read reports damage, reused channel ids, unknown channels
    for cid, msgs in scan.messages.items():
        t = msgs.log_times
        inside = None if span_ns is None else (t >= span_ns[0]) & (t <= span_ns[1])
        times.setdefault(cid, []).append(t if inside is None else t[inside])
        ch = scan.channels[cid]
        if wanted is not None and ch.topic not in wanted:
            continue
        frame, problem = _decode_channel(path, scan, ch, decoders, keep)
        if problem is not None or frame is None:
            return False
        if span_ns is not None:
            frame = frame.filter(pl.col(TIME_COLUMN).is_between(*span_ns))
        parts.setdefault(cid, []).append(frame)
    probe.channels.update(scan.channels)
    probe.schemas.update(scan.schemas)
    return True


def _channels_by_topic(scan: ScanResult) -> dict[str, list[Channel]]:
    out: dict[str, list[Channel]] = {}
    for cid in sorted(scan.channels):
        ch = scan.channels[cid]
        out.setdefault(ch.topic, []).append(ch)
    return out


def _topic_info(scan: ScanResult, chans: list[Channel]) -> TopicInfo:
    schema = scan.schemas.get(chans[0].schema_id)
    times = [m.log_times for ch in chans if (m := scan.messages.get(ch.id)) and len(m.log_times)]
    return TopicInfo(
        topic=chans[0].topic,
        schema_name=schema.name if schema else "",
        schema_encoding=schema.encoding if schema else "",
        message_encoding=chans[0].message_encoding,
        message_count=sum(len(t) for t in times),
        first_ns=min(int(t.min()) for t in times) if times else None,
        last_ns=max(int(t.max()) for t in times) if times else None,
    )


def _decode_channel(
    path: str, scan: ScanResult, ch: Channel, decoders: Decoders, keep: ColumnFilter | None = None
) -> tuple[pl.DataFrame | None, Problem | None]:
    """Decode one channel; return (frame or None when undecodable, what was lost)."""
    msgs = scan.messages.get(ch.id, ChannelMessages())
    t_ns = pl.Series(TIME_COLUMN, msgs.log_times, dtype=pl.Int64)
    where = f"{path}: topic {ch.topic!r}"
    span = _span(msgs.log_times)
    decode = decoders.get(ch.message_encoding)
    if decode is None:
        n = len(msgs.log_times)
        return None, Problem(
            ProblemKind.UNKNOWN_ENCODING,
            ch.topic,
            *span,
            count=n,
            message=f"{where}: message encoding {ch.message_encoding!r} is unknown (known: "
            f"{', '.join(known_encodings(decoders))}); its {n} messages were not decoded",
        )
    if not len(msgs.payloads):
        return pl.DataFrame([t_ns]), None
    hint = DROPPED_COLUMNS.set(None if keep is None else lambda c: not keep(ch.topic, c))
    try:
        decoded = decode(scan.schemas.get(ch.schema_id), ch, msgs.payloads)
    except ValueError as err:
        n = len(msgs.payloads)
        return None, Problem(
            ProblemKind.UNDECODABLE,
            ch.topic,
            *span,
            count=n,
            message=f"{where}: {n} messages not decoded: {err}",
        )
    finally:
        DROPPED_COLUMNS.reset(hint)
    problem = None
    if decoded.kept is not None:
        t_ns = t_ns.gather(decoded.kept)
        lost = len(msgs.payloads) - len(decoded.kept)
        note = f"{where}: {lost} of {len(msgs.payloads)} messages did not decode and were dropped"
        note += f" (first error: {decoded.error})" if decoded.error else ""
        problem = Problem(ProblemKind.DROPPED_MESSAGES, ch.topic, *span, count=lost, message=note)
    if decoded.dropped_columns:
        problem = _merge(problem, _columns_problem(where, ch.topic, span, decoded))
    frame = decoded.frame
    if keep is not None:
        frame = frame.select([c for c in frame.columns if keep(ch.topic, c)])
    if TIME_COLUMN in frame.columns:  # a field named like our time column keeps its value
        frame = frame.rename({TIME_COLUMN: f"{TIME_COLUMN}.field"})
    return frame.insert_column(0, t_ns) if frame.width else pl.DataFrame([t_ns]), problem


def _columns_problem(
    where: str, topic: str, span: tuple[int | None, int | None], decoded: Decoded
) -> Problem:
    n = decoded.dropped_columns
    return Problem(
        ProblemKind.UNDECODABLE,
        topic,
        *span,
        count=n,
        message=f"{where}: {n} columns were not decoded: beyond {MAX_COLUMNS} columns or the "
        f"channel's cell budget ({CELL_BUDGET_BASE} + {CELLS_PER_PAYLOAD_BYTE} per payload "
        'byte), or a field name made twice ("a.b" beside {"a": {"b": ...}}); the first '
        f"{decoded.frame.width} columns were kept",
    )


def _merge(first: Problem | None, second: Problem) -> Problem:
    """One problem for a channel that lost messages and columns (the messages' kind)."""
    if first is None:
        return second
    return dataclasses.replace(first, message=f"{first.message}; {second.message}")


def _span(log_times: np.ndarray) -> tuple[int | None, int | None]:
    return (int(log_times.min()), int(log_times.max())) if len(log_times) else (None, None)


def _fmt_s(t_ns: int, origin: int) -> str:
    return f"{(t_ns - origin) * 1e-9:.3f} s"


def _damage_problems(
    path: str, scan: ScanResult, info: dict[str, TopicInfo], origin: int
) -> list[Problem]:
    """What the scan lost, with counts and time spans."""
    out: list[Problem] = []
    damage = scan.damage
    stats = scan.statistics
    if stats is not None:
        for cid, expected in sorted(stats.channel_message_counts.items()):
            ch = scan.channels.get(cid)
            got = len(scan.messages.get(cid, ChannelMessages()).log_times)
            if ch is not None and got < expected:
                out.append(
                    Problem(
                        ProblemKind.LOST_MESSAGES,
                        ch.topic,
                        count=expected - got,
                        message=f"{path}: topic {ch.topic!r}: read {got} of the {expected} "
                        f"messages the summary lists; {expected - got} lost",
                    )
                )
    for t0, t1 in damage.lost_chunks:
        out.append(
            Problem(
                ProblemKind.LOST_CHUNK,
                t0_ns=t0,
                t1_ns=t1,
                message=f"{path}: a damaged chunk was skipped: messages logged from "
                f"{_fmt_s(t0, origin)} to {_fmt_s(t1, origin)} (relative to the first message "
                "read) are missing there",
            )
        )
    for first_byte, last_byte in damage.skipped:
        out.append(
            Problem(
                ProblemKind.CORRUPT_BYTES,
                count=last_byte - first_byte,
                message=f"{path}: bytes {first_byte}..{last_byte} are corrupt and were skipped "
                "(reading resumed at the next chunk listed in the summary)",
            )
        )
    if damage.unreadable_tail_bytes:
        last = max((i.last_ns for i in info.values() if i.last_ns is not None), default=None)
        end = f"; the messages read end at {_fmt_s(last, origin)}" if last is not None else ""
        expected_end = ""
        summary_end: int | None = None
        if stats is not None and last is not None and stats.message_end_time > last:
            summary_end = stats.message_end_time
            expected_end = f"; the summary says the log runs to {_fmt_s(summary_end, origin)}"
        salvaged = ""
        if damage.salvaged_messages:
            salvaged = f" ({damage.salvaged_messages} messages were recovered from that chunk)"
        out.append(
            Problem(
                ProblemKind.TRUNCATED,
                t0_ns=last,
                t1_ns=summary_end,
                count=damage.unreadable_tail_bytes,
                message=f"{path}: {damage.unreadable_tail_bytes} bytes after the last good record "
                f"(offset {damage.last_good_offset} of {scan.size}) were unreadable{salvaged}: "
                f"the file is truncated or corrupt{end}{expected_end}",
            )
        )
    elif not scan.reached_footer:
        out.append(
            Problem(
                ProblemKind.NO_FOOTER,
                message=f"{path}: the file ends without an MCAP footer: it was probably cut short",
            )
        )
    if damage.bad_messages:
        n = damage.bad_messages
        out.append(
            Problem(
                ProblemKind.BAD_LOG_TIME,
                count=n,
                message=f"{path}: {n} messages had an impossible log_time; dropped",
            )
        )
    orphans = sum(len(m.log_times) for cid, m in scan.messages.items() if cid not in scan.channels)
    if orphans:
        out.append(
            Problem(
                ProblemKind.UNKNOWN_CHANNEL,
                count=orphans,
                message=f"{path}: {orphans} messages name a channel the file does not define; "
                "dropped",
            )
        )
    out += [
        Problem(
            ProblemKind.DUPLICATE_CHANNEL,
            c.kept,
            count=1,
            message=f"{path}: channel id {c.channel_id} is defined for topic {c.kept!r} and again "
            f"for topic {c.other!r}; its messages are read as {c.kept!r} (a writer reusing channel "
            "ids: the topics may be mixed)",
        )
        for c in scan.channel_conflicts
    ]
    if scan.after_footer is not None:
        at, n = scan.after_footer
        what = "a second MCAP file" if scan.appended_mcap else "data that is not MCAP"
        out.append(
            Problem(
                ProblemKind.CONCATENATED if scan.appended_mcap else ProblemKind.CORRUPT_BYTES,
                count=n,
                message=f"{path}: {n} bytes after the MCAP footer (from offset {at}) hold {what}; "
                "they were not read (split concatenated logs and read each on its own)",
            )
        )
    out += [
        Problem(
            ProblemKind.CHUNK_ERROR,
            t0_ns=e.t0_ns,
            t1_ns=e.t1_ns,
            message=f"{path}: a {e.compression or 'plain'} chunk did not open: {e.error}",
        )
        for e in damage.chunk_errors
    ]
    return out


@dataclasses.dataclass(frozen=True)
class McapExtent:
    """What an MCAP file's summary says of its messages, without reading them: the first and
    last log time (ns) and the number of messages per topic."""

    first_ns: int
    last_ns: int
    messages: dict[str, int]


MESSAGE_RECORD_BYTES = 31
"""The smallest message record (opcode, length, channel id, sequence, two times; no data)."""


def _statistics_plausible(stats: Statistics, chunks: list[ChunkIndex], size: int) -> bool:
    """Whether a summary's statistics fit the file: the time range in order and equal to the
    chunk indexes' (when there are chunks), and no more messages than the file's bytes (the
    chunks' decompressed bytes for a chunked file) can hold. A statistics record claiming
    2^64 - 1 messages or an end time of 2^64 - 1 is not believed (issue 34)."""
    first, last, count = stats.message_start_time, stats.message_end_time, stats.message_count
    if last < first:
        return False
    room = size
    if chunks:
        starts = [
            c.message_start_time for c in chunks if c.message_end_time >= c.message_start_time
        ]
        ends = [c.message_end_time for c in chunks if c.message_end_time >= c.message_start_time]
        if not starts or min(starts) != first or max(ends) != last:
            return False
        room = max(size, sum(max(0, c.uncompressed_size) for c in chunks))
    if count > room // MESSAGE_RECORD_BYTES:
        return False
    return sum(stats.channel_message_counts.values()) <= room // MESSAGE_RECORD_BYTES


def mcap_extent(path: str, size: int) -> McapExtent | None:
    """The extent of the MCAP file ``path`` (``size`` bytes) from its summary's statistics; None
    when it is not MCAP, has no readable summary with statistics (only the footer and the
    summary are read), or its statistics claim what the file cannot hold
    (:func:`_statistics_plausible`)."""
    if size < len(MAGIC) + 64:
        return None
    with open(path, "rb", buffering=0) as fh:
        if fh.read(len(MAGIC)) != MAGIC:
            return None
        amap = mmap.mmap(-1, size)  # anonymous: only the pages written take memory
        found = _summary(fh, amap, size)
        if found is None:
            return None
        summary, start = found
    stats = summary.statistics
    if not start or stats is None or not stats.message_count:
        return None
    if not _statistics_plausible(stats, summary.chunk_indexes, size):
        return None  # claims the file cannot hold: learn the extent by reading it
    counts: dict[str, int] = {}
    for cid, n in stats.channel_message_counts.items():
        ch = summary.channels.get(cid)
        if ch is not None and n:
            counts[ch.topic] = counts.get(ch.topic, 0) + n
    return McapExtent(int(stats.message_start_time), int(stats.message_end_time), counts)
