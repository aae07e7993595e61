"""The shape of one log format (:class:`FormatReader`) and of a read request, shared by the
format registry (:mod:`logtools.readers.formats`) and the formats themselves."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

from logtools.readers.base import ColumnFilter, LogData
from logtools.readers.decoders import Decoders

__all__ = ["HEAD_BYTES", "FormatReader", "ReadRequest"]

HEAD_BYTES = 4096
"""Bytes of a file's start handed to ``sniff``."""


@dataclass(frozen=True)
class ReadRequest:
    """What a caller asks of a read: ``topics`` to decode (None: all), a column filter
    ``keep``, the MCAP ``decoders`` (None: the default ones), the file's ``size`` in bytes
    (0 for a folder), and ``span_ns``, a time range (first, last log time in ns, inclusive)
    the caller keeps: a format with a time index (MCAP's chunk index) reads only the parts that
    cover it; any format may return more (``read_log`` cuts the rest)."""

    topics: Iterable[str] | None = None
    keep: ColumnFilter | None = None
    decoders: Decoders | None = None
    size: int = 0
    span_ns: tuple[int, int] | None = None


@dataclass(frozen=True)
class FormatReader:
    """One log format.

    Attributes:
        name: short name ("mcap", "rosbag2", "csv", ...), shown in ``logcal info``.
        title: what a person calls it, for messages ("ROS 2 bag folder").
        suffixes: file suffixes (lower case, with the dot) an archive walk collects as logs of
            this format; a folder format has none.
        sniff: (path, first ``HEAD_BYTES`` bytes; empty for a folder) -> whether this format
            reads the path. Must not raise.
        read: (path, request) -> the log's frames; raises ``LogcalInputError`` subclasses
            naming the file and what was wrong.
        folder: the format is a folder (a rosbag2 bag), not a file.
        runs: for a folder holding several runs of its own (an OptiOdom session), the run
            files; None: the format has no such folders.
        skip: (path) -> a file with one of ``suffixes`` that is not a log of this format (a
            session's metadata), left out of folder walks.
    """

    name: str
    title: str
    suffixes: tuple[str, ...]
    sniff: Callable[[Path, bytes], bool]
    read: Callable[[str, ReadRequest], LogData]
    folder: bool = False
    runs: Callable[[Path], list[Path]] | None = None
    skip: Callable[[Path], bool] | None = None
