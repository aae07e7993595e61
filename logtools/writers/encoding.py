"""Encodings of a written drive log, importable without numpy (the CLI builds its options from
them at start-up)."""

from __future__ import annotations

import os
from enum import StrEnum
from typing import Literal

__all__ = ["ENCODINGS", "Encoding", "LogEncoding"]


class LogEncoding(StrEnum):
    """Encodings of a written drive log."""

    JSON = "json"
    """MCAP with JSON messages (``logcal/*`` schemas)."""
    ROS2 = "ros2"
    """MCAP with ROS 2 ``cdr`` messages."""
    CSV = "csv"
    """CSV, one column per logical signal (no metadata)."""

    @classmethod
    def for_path(cls, path: str | os.PathLike[str]) -> LogEncoding:
        """The default encoding of ``path``: CSV for ``*.csv``, else JSON MCAP."""
        return cls.CSV if os.fspath(path).lower().endswith(".csv") else cls.JSON


Encoding = LogEncoding | Literal["json", "ros2", "csv"]
"""An encoding as the enum or its string value."""

ENCODINGS: tuple[str, ...] = tuple(e.value for e in LogEncoding)
