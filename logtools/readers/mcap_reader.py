"""Read an MCAP file into per-topic polars frames, saying what was lost."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import polars as pl
from mcap.records import Channel

from logtools.errors import NotAnMcapError, UnknownEncodingError
from logtools.problems import Problem, ProblemKind
from logtools.readers.base import TIME_COLUMN, LogData, TopicInfo, sorted_by_time
from logtools.readers.decoders import DEFAULT_DECODERS, Decoders, known_encodings
from logtools.readers.mcap_scan import ChannelMessages, ScanResult, scan_mcap

__all__ = ["read_mcap"]


def read_mcap(
    path: str,
    buf: bytes,
    topics: Iterable[str] | None = None,
    decoders: Decoders = DEFAULT_DECODERS,
) -> LogData:
    """Decode the MCAP file ``buf`` (read from ``path``).

    Args:
        path: file name, for messages.
        buf: the file's bytes (starting with the MCAP magic).
        topics: decode only these topics (all are still listed in ``info``); None: all.
        decoders: MCAP message encoding -> decoder.

    Raises:
        NotAnMcapError: nothing could be read (e.g. cut right after the header).
        UnknownEncodingError: no topic with messages has an encoding logcal can decode.
    """
    batched = _read_batched(path, buf, topics, decoders)
    if batched is not None:
        return batched
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
            frame, problem = _decode_channel(path, scan, ch, decoders)
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


def _read_batched(
    path: str, buf: bytes, topics: Iterable[str] | None, decoders: Decoders
) -> LogData | None:
    """A large, intact file decoded ``BATCH_BYTES`` of chunks at a time; None when the file
    does not qualify (then it is read whole).

    Reading whole holds every decompressed chunk until the last channel is decoded: for a
    1 M-message JSON log that is 75 MB of chunks and 40 MB of message index beside 21 MB of
    frames (issue 14). Batch by batch, only one batch's chunks are held, and the frames are
    the same: each channel's parts are decoded as the whole channel would be and concatenated.
    Qualifies: a readable summary listing the chunks and the message counts (every message
    must be found in the listed chunks), more decompressed bytes than one batch,
    no damage found by a first pass over the records outside the chunks, no message outside a
    chunk, and a decoder for every channel's encoding. A batch that finds damage or loses
    messages in decoding sends the whole file back to the whole-file read, which reports it.
    """
    probe = scan_mcap(buf, chunks=())
    ordered = sorted(probe.chunk_indexes, key=lambda c: c.chunk_start_offset)
    total = sum(c.uncompressed_size for c in ordered)
    if (
        not ordered
        or probe.statistics is None
        or total <= BATCH_BYTES
        or probe.damage.any
        or probe.messages
        or not probe.channels
        or any(ch.message_encoding not in decoders for ch in probe.channels.values())
    ):
        return None
    batches: list[list[int]] = [[]]
    size = 0
    for c in ordered:
        if batches[-1] and size + c.uncompressed_size > BATCH_BYTES:
            batches.append([])
            size = 0
        batches[-1].append(c.chunk_start_offset)
        size += c.uncompressed_size
    wanted = None if topics is None else set(topics)
    times: dict[int, list[np.ndarray]] = {}
    parts: dict[int, list[pl.DataFrame]] = {}
    for batch in batches:
        if not _decode_batch(path, buf, batch, probe, wanted, decoders, times, parts):
            return None
    probe.messages = {
        cid: ChannelMessages(np.concatenate(t) if len(t) > 1 else t[0]) for cid, t in times.items()
    }
    counts = {cid: len(m.log_times) for cid, m in probe.messages.items() if len(m.log_times)}
    if counts != {c: n for c, n in probe.statistics.channel_message_counts.items() if n}:
        return None  # a chunk the index does not list, or a summary that disagrees
    by_topic = _channels_by_topic(probe)
    info = {topic: _topic_info(probe, chans) for topic, chans in by_topic.items()}
    origin = min((i.first_ns for i in info.values() if i.first_ns is not None), default=0)
    problems = _damage_problems(path, probe, info, origin)
    frames: dict[str, pl.DataFrame] = {}
    for topic, chans in sorted(by_topic.items()):
        if wanted is not None and topic not in wanted:
            continue
        for ch in chans:  # a channel without messages: its empty frame, as when read whole
            if ch.id not in parts:
                empty, _ = _decode_channel(path, probe, ch, decoders)
                parts[ch.id] = [] if empty is None else [empty]
        # taken out of ``parts`` as they are joined: one topic's pieces exist twice at a time
        pieces = [f for ch in chans for f in parts.pop(ch.id, [])]
        if pieces:
            joined = pl.concat(pieces, how="diagonal_relaxed")
            del pieces
            frames[topic] = sorted_by_time(joined, path, topic, problems, "log_time")
    return LogData(path, frames, info, dict(probe.metadata), problems)


def _decode_batch(
    path: str,
    buf: bytes,
    batch: list[int],
    probe: ScanResult,
    wanted: set[str] | None,
    decoders: Decoders,
    times: dict[int, list[np.ndarray]],
    parts: dict[int, list[pl.DataFrame]],
) -> bool:
    """Scan the chunks starting at ``batch`` and decode their messages into ``times`` and
    ``parts`` (per channel); False on damage or lost messages. Its own function so that
    nothing refers to the batch's decompressed chunks once it returns."""
    scan = scan_mcap(buf, chunks=batch)
    if scan.damage.any or set(scan.messages) - set(scan.channels):
        return False
    for cid, msgs in scan.messages.items():
        times.setdefault(cid, []).append(msgs.log_times)
        ch = scan.channels[cid]
        if wanted is not None and ch.topic not in wanted:
            continue
        frame, problem = _decode_channel(path, scan, ch, decoders)
        if problem is not None or frame is None:
            return False
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
    path: str, scan: ScanResult, ch: Channel, decoders: Decoders
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
    problem = None
    if decoded.kept is not None:
        t_ns = t_ns.gather(decoded.kept)
        lost = len(msgs.payloads) - len(decoded.kept)
        note = f"{where}: {lost} of {len(msgs.payloads)} messages did not decode and were dropped"
        note += f" (first error: {decoded.error})" if decoded.error else ""
        problem = Problem(ProblemKind.DROPPED_MESSAGES, ch.topic, *span, count=lost, message=note)
    frame = decoded.frame
    if TIME_COLUMN in frame.columns:  # a field named like our time column keeps its value
        frame = frame.rename({TIME_COLUMN: f"{TIME_COLUMN}.field"})
    return frame.insert_column(0, t_ns) if frame.width else pl.DataFrame([t_ns]), problem


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
