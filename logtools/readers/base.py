"""The reader result types: one frame per topic, its summary, metadata and what was repaired."""

from __future__ import annotations

from collections.abc import Callable
from contextvars import ContextVar
from dataclasses import dataclass, field

import numpy as np
import polars as pl

from logtools.problems import Problem, ProblemKind

__all__ = [
    "DROPPED_COLUMNS",
    "TIME_COLUMN",
    "ColumnFilter",
    "LogData",
    "Problem",
    "ProblemKind",
    "TopicInfo",
    "in_span",
    "sorted_by_time",
]

TIME_COLUMN = "t_ns"
"""The one time column of every frame: int64 nanoseconds (MCAP log_time; CSV t * 1e9)."""

ColumnFilter = Callable[[str, str], bool]
"""(topic, flattened column name) -> whether a reader keeps that column."""

DROPPED_COLUMNS: ContextVar[Callable[[str], bool] | None] = ContextVar(
    "logcal_dropped_columns", default=None
)
"""While a channel is decoded: column name -> whether the reader will drop it. A decoder may
skip building those columns (``cdr_bulk`` does, for array items); the reader drops them either
way, so a decoder that ignores this gives the same frames."""


@dataclass(frozen=True)
class TopicInfo:
    """What a log says about one topic (counts and times are of the messages actually read).

    Attributes:
        topic: topic name (CSV: ``"csv"``).
        schema_name: schema (message type) name, e.g. ``nav_msgs/msg/Odometry``; "" if none.
        schema_encoding: ``jsonschema``, ``ros2msg``, ``protobuf``, ``ros1msg``, ``csv``, or "".
        message_encoding: ``json``, ``cdr``, ``protobuf``, ``ros1`` or ``csv``.
        message_count: messages read from the file.
        first_ns: earliest log_time read (ns), None without messages.
        last_ns: latest log_time read (ns), None without messages.
    """

    topic: str
    schema_name: str
    schema_encoding: str
    message_encoding: str
    message_count: int
    first_ns: int | None
    last_ns: int | None

    @property
    def rate_hz(self) -> float | None:
        """Mean message rate (1/s) over the topic's span, None with fewer than two messages."""
        if self.first_ns is None or self.last_ns is None or self.message_count < 2:
            return None
        span = self.last_ns - self.first_ns
        return (self.message_count - 1) / (span * 1e-9) if span > 0 else None


@dataclass(frozen=True)
class LogData:
    """A drive log as frames.

    Attributes:
        path: the file read.
        topics: topic -> frame with ``t_ns`` (int64 ns, sorted) and the flattened message fields.
            Topics whose encoding could not be decoded are absent here but listed in ``info``.
        info: topic -> :class:`TopicInfo`, for every topic of the file.
        metadata: MCAP metadata records by name (CSV: ``{}``).
        problems: what was lost or repaired while reading (``str(p)`` is the sentence).
    """

    path: str
    topics: dict[str, pl.DataFrame]
    info: dict[str, TopicInfo]
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    problems: list[Problem] = field(default_factory=list)

    def topic_names(self) -> list[str]:
        """All topic names of the file, sorted."""
        return sorted(self.info)


def sorted_by_time(
    frame: pl.DataFrame, path: str, topic: str, problems: list[Problem], clock: str
) -> pl.DataFrame:
    """``frame`` sorted by its time column where the recorder wrote messages out of order,
    saying so in ``problems`` (``clock`` names the time the reader uses, e.g. "log_time")."""
    t = frame[TIME_COLUMN].to_numpy()
    backwards = int(np.count_nonzero(np.diff(t) < 0))
    if backwards:
        problems.append(
            Problem(
                ProblemKind.UNSORTED,
                topic,
                count=backwards,
                message=f"{path}: topic {topic!r}: {clock} went backwards {backwards} times; "
                f"messages were sorted by {clock}",
            )
        )
        frame = frame.sort(TIME_COLUMN, maintain_order=True)
    return frame


def in_span(log: LogData, t0_ns: int, t1_ns: int) -> LogData:
    """``log`` with only the messages logged from ``t0_ns`` to ``t1_ns`` (inclusive); each
    decoded topic's ``info`` counts what is kept (a topic not decoded keeps its ``info``)."""
    topics: dict[str, pl.DataFrame] = {}
    info: dict[str, TopicInfo] = {}
    for name, ti in log.info.items():
        frame = log.topics.get(name)
        if frame is None:
            info[name] = ti
            continue
        t = frame[TIME_COLUMN]
        inside = frame.height and t0_ns <= int(t.min()) and int(t.max()) <= t1_ns  # type: ignore[arg-type]
        kept = frame if inside else frame.filter(pl.col(TIME_COLUMN).is_between(t0_ns, t1_ns))
        topics[name] = kept
        times = kept[TIME_COLUMN]
        info[name] = TopicInfo(
            ti.topic,
            ti.schema_name,
            ti.schema_encoding,
            ti.message_encoding,
            kept.height,
            int(times.min()) if kept.height else None,  # type: ignore[arg-type]
            int(times.max()) if kept.height else None,  # type: ignore[arg-type]
        )
    for name, frame in log.topics.items():  # a frame without info (none today): cut as well
        if name not in topics:
            topics[name] = frame.filter(pl.col(TIME_COLUMN).is_between(t0_ns, t1_ns))
    return LogData(log.path, topics, info, log.metadata, log.problems)
