"""Read drive logs (MCAP, ROS bags or CSV) into per-topic polars frames.

``read_log(path)`` picks the reader from the path and the file's first bytes: a rosbag2 folder
(with ``metadata.yaml``; a ``.db3`` file reads its folder) or a ROS 1 ``.bag`` through
``rosbags``; MCAP (magic ``0x89 MCAP0``); or CSV. Every frame has the int64 nanosecond time column
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
from pathlib import Path

from logtools.errors import LogFileNotFoundError, NotAnMcapError
from logtools.problems import Problem, ProblemKind
from logtools.readers.base import TIME_COLUMN, ColumnFilter, LogData, TopicInfo
from logtools.readers.csv_reader import CSV_TOPIC, read_csv
from logtools.readers.decoders import DEFAULT_DECODERS, Decoders, MessageDecoder, known_encodings
from logtools.readers.mcap_reader import read_mcap, read_mcap_batched
from logtools.readers.mcap_scan import MAGIC
from logtools.readers.rosbag_reader import is_rosbag, read_rosbag

_BATCHED_MIN_BYTES = 2**20
"""Smaller files are read whole (no batch could hold less than all of their chunks)."""

__all__ = [
    "CSV_TOPIC",
    "DEFAULT_DECODERS",
    "TIME_COLUMN",
    "ColumnFilter",
    "Decoders",
    "LogData",
    "MessageDecoder",
    "Problem",
    "ProblemKind",
    "TopicInfo",
    "known_encodings",
    "read_log",
    "read_rosbag",
]


def read_log(
    path: str | os.PathLike[str],
    *,
    topics: Iterable[str] | None = None,
    decoders: Decoders = DEFAULT_DECODERS,
    keep: ColumnFilter | None = None,
) -> LogData:
    """Read an MCAP, ROS bag or CSV drive log.

    Args:
        path: the log file, a rosbag2 folder (or one of its ``.db3`` files), or a ROS 1 ``.bag``.
        topics: MCAP and bags: decode just these topics (``info`` still lists all); None: all.
        keep: (topic, column) -> whether to keep a decoded column (``t_ns`` always stays);
            None keeps all. MCAP applies it as each channel is decoded, so dropped columns
            never take memory for the whole log; other formats after reading.
        decoders: MCAP message encoding -> decoder (default: JSON, ROS 2, ROS 1, protobuf);
            e.g. ``{**DEFAULT_DECODERS, "cbor": decode_cbor}`` adds one for this read only.

    Returns:
        The log's frames, topic summaries, metadata records and the problems repaired.

    Raises:
        LogFileNotFoundError: ``path`` does not exist.
        NotAnMcapError: the file is neither a readable MCAP nor a CSV log.
        NotARosbagError: a ROS bag that cannot be read.
        UnknownEncodingError: no topic is in an encoding logcal can decode.
    """
    name = os.fspath(path)
    p = Path(name)
    if not p.exists():
        raise LogFileNotFoundError(name)
    if p.is_dir():
        if is_rosbag(p):
            return _kept(read_rosbag(name, topics), keep)
        raise NotAnMcapError(name, "it is a directory without a rosbag2 metadata.yaml")
    try:
        st = p.stat()
        if not stat.S_ISREG(st.st_mode):
            raise NotAnMcapError(name, f"it is not a regular file ({_file_kind(st.st_mode)})")
        if st.st_size >= _BATCHED_MIN_BYTES:  # a large intact MCAP: a batch at a time
            batched = read_mcap_batched(name, st.st_size, topics, decoders, keep)
            if batched is not None:
                return batched
        # unbuffered: the whole-file read is then one allocation of the file's size (through
        # a buffered reader it grows a second copy, twice the file for a moment)
        with open(p, "rb", buffering=0) as fh:
            head = fh.read(len(MAGIC))
            if head != MAGIC and is_rosbag(p, head + fh.read(16)):
                return _kept(read_rosbag(name, topics), keep)
            fh.seek(0)
            buf = fh.readall()  # one read: ``head + rest`` would hold the file twice
    except OSError as err:
        raise NotAnMcapError(name, f"cannot read it: {err.strerror or err}") from err
    except MemoryError as err:
        raise NotAnMcapError(name, f"{st.st_size} bytes do not fit in memory") from err
    if head == MAGIC:
        return read_mcap(name, buf, topics, decoders, keep)
    if not buf:
        raise NotAnMcapError(name, "the file is empty")
    if MAGIC.startswith(buf):
        raise NotAnMcapError(name, f"only {len(buf)} bytes of an MCAP header: truncated")
    if p.suffix.lower() == ".csv" or _looks_like_csv(buf):
        from logtools.readers.optiodom import is_optiodom_run, read_optiodom

        if is_optiodom_run(p, buf[:4096]):  # headerless run file with a type=diff sibling
            return _kept(read_optiodom(name), keep)
        return _kept(read_csv(name, buf), keep)
    raise NotAnMcapError(name, f"it starts with the bytes {buf[:8]!r}")


def _kept(log: LogData, keep: ColumnFilter | None) -> LogData:
    """``log`` with only the columns ``keep`` keeps (and ``t_ns``)."""
    if keep is None:
        return log
    for topic, frame in log.topics.items():
        cols = [c for c in frame.columns if c == TIME_COLUMN or keep(topic, c)]
        if len(cols) != frame.width:
            log.topics[topic] = frame.select(cols)
    return log


def _file_kind(mode: int) -> str:
    kinds = (
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    )
    return next((text for test, text in kinds if test(mode)), "not a regular file")


def _looks_like_csv(buf: bytes) -> bool:
    head = buf[:4096].split(b"\n", 1)[0]
    try:
        text = head.decode("utf-8").strip()
    except UnicodeDecodeError:
        return False
    return "," in text and "t" in [c.strip().strip('"') for c in text.split(",")]
