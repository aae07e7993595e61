"""Read a CSV drive log (LOG_FORMAT.md): a header row, time ``t`` in seconds, signals as columns."""

from __future__ import annotations

from io import BytesIO

import polars as pl

from logtools.errors import NotAnMcapError
from logtools.problems import Problem, ProblemKind
from logtools.readers.base import TIME_COLUMN, LogData, TopicInfo

__all__ = ["CSV_TOPIC", "read_csv"]

CSV_TOPIC = "csv"
"""The one pseudo-topic of a CSV log."""


def read_csv(path: str, buf: bytes) -> LogData:
    """Parse CSV bytes into a :class:`LogData` with the single topic ``"csv"``.

    The time column ``t`` (s) becomes ``t_ns`` (int64 ns, rounded); rows without a time are
    dropped and counted in ``problems``; empty cells become null.

    Raises:
        NotAnMcapError: the bytes are not a CSV with a numeric column ``t``.
    """
    try:
        frame = pl.read_csv(BytesIO(buf), infer_schema_length=None)
    except Exception as err:  # polars raises ComputeError/NoDataError/... for malformed text
        raise NotAnMcapError(path, f"CSV parse failed: {err}") from err
    if "t" not in frame.columns:
        cols = ", ".join(frame.columns[:12]) or "(none)"
        raise NotAnMcapError(path, f"the CSV has no time column 't'; its columns: {cols}")
    t = frame["t"].cast(pl.Float64, strict=False)
    if frame["t"].null_count() < t.null_count():
        raise NotAnMcapError(path, "the CSV time column 't' holds non-numeric values")
    problems: list[Problem] = []
    keep = t.is_not_null() & t.is_finite()
    dropped = frame.height - int(keep.sum())
    if dropped:
        problems.append(
            Problem(
                ProblemKind.NO_TIME,
                CSV_TOPIC,
                count=dropped,
                message=f"{path}: {dropped} CSV rows have no finite time 't'; dropped",
            )
        )
    t_ns = (t.filter(keep) * 1e9).round().cast(pl.Int64).alias(TIME_COLUMN)
    frame = frame.filter(keep).drop("t").insert_column(0, t_ns)
    if not frame[TIME_COLUMN].is_sorted():
        backwards = int((frame[TIME_COLUMN].diff() < 0).sum())
        problems.append(
            Problem(
                ProblemKind.UNSORTED,
                CSV_TOPIC,
                count=backwards,
                message=f"{path}: CSV time 't' is not increasing; rows were sorted by 't'",
            )
        )
        frame = frame.sort(TIME_COLUMN, maintain_order=True)
    times = frame[TIME_COLUMN]
    info = TopicInfo(
        topic=CSV_TOPIC,
        schema_name="",
        schema_encoding="csv",
        message_encoding="csv",
        message_count=frame.height,
        first_ns=int(times.min()) if frame.height else None,  # type: ignore[arg-type]
        last_ns=int(times.max()) if frame.height else None,  # type: ignore[arg-type]
    )
    return LogData(path, {CSV_TOPIC: frame}, {CSV_TOPIC: info}, {}, problems)
