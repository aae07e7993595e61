"""Read drive logs (MCAP, ROS bags, CSV and the other registered formats) into per-topic polars
frames.

``read_log(path)`` asks the format registry (:mod:`logtools.readers.formats`) which format reads
the path, from its name and first bytes: a rosbag2 folder (with ``metadata.yaml``; a ``.db3``
file reads its folder) or a ROS 1 ``.bag`` through ``rosbags``; MCAP (magic ``0x89 MCAP0``);
an OptiOdom run; a TUM trajectory; or CSV. Every frame has the int64 nanosecond time column
``t_ns`` (MCAP ``log_time``, the bag's record time) and the message fields flattened by path
(``twist.twist.linear.x``; arrays as ``position.0``). Damage is repaired where possible and
described in ``LogData.problems`` (:class:`logtools.problems.Problem` records); input that
cannot be read at all raises a :class:`logtools.errors.LogcalInputError`.

A file is read into memory once (``st_size`` bytes, taken before opening), not memory-mapped:
a log truncated by another process while it is read then gives a short read, which the readers
handle as truncation, instead of a SIGBUS that kills the process. Only regular files are read:
``/dev/zero``, a FIFO or a socket are refused before they are opened (opening a FIFO blocks).
"""

from __future__ import annotations

import os
import stat
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from logtools.errors import LogFileNotFoundError, NotAnMcapError
from logtools.problems import Problem, ProblemKind
from logtools.readers.base import TIME_COLUMN, ColumnFilter, LogData, TopicInfo, in_span
from logtools.readers.csv_reader import CSV_TOPIC
from logtools.readers.decoders import DEFAULT_DECODERS, Decoders, MessageDecoder, known_encodings
from logtools.readers.formats import HEAD_BYTES, FormatReader, ReadRequest, format_for
from logtools.readers.formats import formats as registered_formats
from logtools.readers.mcap_scan import MAGIC
from logtools.readers.rosbag_reader import read_rosbag

__all__ = [
    "CSV_TOPIC",
    "DEFAULT_DECODERS",
    "TIME_COLUMN",
    "ColumnFilter",
    "Decoders",
    "FormatReader",
    "LogData",
    "LogExtent",
    "MessageDecoder",
    "Problem",
    "ProblemKind",
    "TopicInfo",
    "in_span",
    "known_encodings",
    "log_extent",
    "read_log",
    "read_rosbag",
]


def read_log(
    path: str | os.PathLike[str],
    *,
    topics: Iterable[str] | None = None,
    decoders: Decoders = DEFAULT_DECODERS,
    keep: ColumnFilter | None = None,
    span_ns: tuple[int, int] | None = None,
) -> LogData:
    """Read a drive log in any registered format (:mod:`logtools.readers.formats`: MCAP, ROS
    bags, OptiOdom runs, TUM trajectories, CSV, and any format a plugin registers).

    Args:
        path: the log file, a rosbag2 folder (or one of its ``.db3`` files), or a ROS 1 ``.bag``.
        topics: MCAP and bags: decode just these topics (``info`` still lists all); None: all.
        keep: (topic, column) -> whether to keep a decoded column (``t_ns`` always stays);
            None keeps all. MCAP applies it as each channel is decoded, so dropped columns
            never take memory for the whole log; other formats after reading.
        decoders: MCAP message encoding -> decoder (default: JSON, ROS 2, ROS 1, protobuf);
            e.g. ``{**DEFAULT_DECODERS, "cbor": decode_cbor}`` adds one for this read only.
        span_ns: keep only the messages logged from ``span_ns[0]`` to ``span_ns[1]`` (ns,
            inclusive; ``info`` then describes those). A large intact MCAP file reads just the
            chunks its chunk index places there; other formats are read whole and cut.

    Returns:
        The log's frames, topic summaries, metadata records and the problems repaired.

    Raises:
        LogFileNotFoundError: ``path`` does not exist.
        NotAnMcapError: no format reads the file (it names what the file starts with).
        NotARosbagError: a ROS bag that cannot be read.
        UnknownEncodingError: no topic is in an encoding logcal can decode.
    """
    name = os.fspath(path)
    p = Path(name)
    if not p.exists():
        raise LogFileNotFoundError(name)
    head = b""
    size = 0
    if not p.is_dir():
        try:
            st = p.stat()
            if not stat.S_ISREG(st.st_mode):
                raise NotAnMcapError(name, f"it is not a regular file ({_file_kind(st.st_mode)})")
            size = st.st_size
            with open(p, "rb", buffering=0) as fh:
                head = fh.read(HEAD_BYTES)
        except OSError as err:
            raise NotAnMcapError(name, f"cannot read it: {err.strerror or err}") from err
    reader = format_for(p, head)
    if reader is None:
        every = [f.title for f in registered_formats()]
        if p.is_dir():
            raise NotAnMcapError(name, "it is a directory without a rosbag2 metadata.yaml", every)
        if not head:
            raise NotAnMcapError(name, "the file is empty", every)
        if MAGIC.startswith(head):
            raise NotAnMcapError(name, f"only {len(head)} bytes of an MCAP header: truncated")
        raise NotAnMcapError(name, f"it starts with the bytes {head[:8]!r}", every)
    log = reader.read(name, ReadRequest(topics, keep, decoders, size, span_ns))
    if span_ns is not None:
        log = in_span(log, *span_ns)
    log.problems.extend(checked_numbers(name, log.metadata))
    return log


@dataclass(frozen=True)
class LogExtent:
    """A log's time span (first and last log time, ns) and message count per topic, as its
    index gives them."""

    first_ns: int
    last_ns: int
    messages: dict[str, int]

    @property
    def duration_s(self) -> float:
        return (self.last_ns - self.first_ns) * 1e-9

    @property
    def rate_hz(self) -> float:
        """The fastest topic's mean rate (1/s; 0 for a log of one instant)."""
        span = self.last_ns - self.first_ns
        return max(self.messages.values(), default=0) / (span * 1e-9) if span > 0 else 0.0


def log_extent(path: str | os.PathLike[str]) -> LogExtent | None:
    """The extent of ``path`` read from its index alone (an MCAP file's summary statistics),
    without reading its messages; None for a format or file that keeps no such index (read
    the log to learn it)."""
    from logtools.readers.mcap_reader import mcap_extent

    p = Path(os.fspath(path))
    try:
        st = p.stat()
    except OSError:
        return None
    if not stat.S_ISREG(st.st_mode):
        return None
    try:
        ext = mcap_extent(os.fspath(p), st.st_size)
    except (OSError, ValueError):
        return None
    return None if ext is None else LogExtent(ext.first_ns, ext.last_ns, dict(ext.messages))


NUMERIC_METADATA: dict[str, tuple[str, ...]] = {
    "logcal.nominal": (),
    "logcal": ("nominal.", "l1", "l2", "g"),
}
"""Metadata records whose values (all: ``()``; else the keys named or starting so) the
analyses take as numbers."""


def checked_numbers(name: str, metadata: dict[str, dict[str, str]]) -> list[Problem]:
    """Drop (and report) metadata values the analyses read as numbers that are not finite
    numbers (``logcal.nominal`` ``track_width = "wide"``), so that none fails later."""
    import math

    out: list[Problem] = []
    for record, keys in NUMERIC_METADATA.items():
        rec = metadata.get(record)
        if not isinstance(rec, dict):
            continue
        for key in list(rec):
            if keys and not any(key == k or (k.endswith(".") and key.startswith(k)) for k in keys):
                continue
            try:
                ok = math.isfinite(float(rec[key]))
            except (TypeError, ValueError, OverflowError):
                ok = False
            if not ok:
                value = str(rec.pop(key))[:60]
                out.append(
                    Problem(
                        ProblemKind.UNDECODABLE,
                        count=1,
                        message=f"{name}: metadata record {record!r} key {key!r} is {value!r}, not "
                        "a finite number; ignored",
                    )
                )
    return out


def _file_kind(mode: int) -> str:
    kinds = (
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    )
    return next((text for test, text in kinds if test(mode)), "not a regular file")
