"""Read a CSV drive log (LOG_FORMAT.md): a header row, time ``t`` in seconds, signals as columns.

The time column may also be named as other tools write it: ``__time`` (PlotJuggler's CSV
export, s), ``%time`` (``rostopic echo -p``, ns since the epoch) or ``timestamp`` (unit told by
its magnitude, as for ``t``); the first of ``t``, ``__time``, ``%time``, ``timestamp`` present
is the time.

A time column in epoch milliseconds, microseconds or nanoseconds (loggers that write their clock
as is) is recognised by its magnitude (seconds since 1970 are ~1.7e9; nothing in seconds is above
1e11) and rescaled, with a problem saying so. A time that does not fit the int64 nanosecond
clock (e.g. one ``t = 1e300``) is refused with its row. A last row cut short (fewer fields than
the header and no final newline: the writer was stopped mid-row) is dropped with a warning.
"""

from __future__ import annotations

import re
from io import BytesIO

import polars as pl

from logtools.errors import NotAnMcapError, TimestampError
from logtools.problems import Problem, ProblemKind
from logtools.readers.base import TIME_COLUMN, LogData, TopicInfo

__all__ = [
    "CSV_TOPIC",
    "MAX_CSV_COLUMNS",
    "TIME_COLUMNS",
    "by_topic_paths",
    "check_csv_width",
    "read_csv",
    "read_csv_file",
    "topic_field",
]

CSV_TOPIC = "csv"
"""The one pseudo-topic of a CSV log."""

_UNITS = ((1e11, 1.0, "s"), (1e14, 1e-3, "ms"), (1e17, 1e-6, "us"), (1e20, 1e-9, "ns"))
"""(largest median |t|, factor to seconds, unit name): the time unit told by the magnitude."""
TIME_COLUMNS: tuple[tuple[str, str | None], ...] = (
    ("t", None),
    ("__time", "s"),
    ("%time", "ns"),
    ("timestamp", None),
)
"""(column, unit) of the time columns a CSV may have, in order of preference; unit None: told by
the magnitude (s, or epoch ms/us/ns)."""
_INT64_NS_LIMIT_S = 9.2e9
"""|t| (s) beyond which t * 1e9 does not fit an int64 nanosecond count."""


MAX_CSV_COLUMNS = 4096
"""Most columns a CSV log may have (its header is counted before anything is parsed)."""
MAX_HEADER_BYTES = 2**20
"""Longest header line read (1 MiB: 4096 names of 256 characters)."""
STREAM_MIN_BYTES = 32 * 2**20
"""Files from this size on are parsed from the file by polars' streaming engine (memory of
the frames, not of the file); smaller ones are read whole (the same frames)."""
_TAIL_BYTES = 1 << 16


def check_csv_width(path: str, head: bytes, size: int) -> int:
    """Count the header's fields (``head``: the file's first bytes); refuse a CSV wider than
    :data:`MAX_CSV_COLUMNS` or a header line longer than :data:`MAX_HEADER_BYTES`."""
    import csv

    line, newline, _ = head[:MAX_HEADER_BYTES].partition(b"\n")
    if not newline and size > MAX_HEADER_BYTES:
        if line.count(b",") >= MAX_CSV_COLUMNS:
            raise NotAnMcapError(
                path,
                f"the CSV has more than {line.count(b',')} columns; logcal reads at most "
                f"{MAX_CSV_COLUMNS} (CSV width budget); keep the time and the signals the "
                "analysis needs",
            )
        raise NotAnMcapError(
            path,
            f"the CSV's header line is longer than {MAX_HEADER_BYTES} bytes (CSV width "
            f"budget: at most {MAX_CSV_COLUMNS} columns)",
        )
    try:
        fields = next(csv.reader([line.decode("utf-8", "replace")]), [])
    except csv.Error:
        fields = line.split(b",")  # type: ignore[assignment]
    if len(fields) > MAX_CSV_COLUMNS:
        raise NotAnMcapError(
            path,
            f"the CSV has {len(fields)} columns; logcal reads at most {MAX_CSV_COLUMNS} "
            "(CSV width budget); keep the time and the signals the analysis needs",
        )
    return len(fields)


def read_csv_file(path: str, size: int) -> LogData:
    """Read the CSV file ``path`` (``size`` bytes) as :func:`read_csv` reads its bytes, within
    bounds: the header is counted first (:func:`check_csv_width`), and a file of
    :data:`STREAM_MIN_BYTES` or more is parsed by polars' streaming engine from the file, so
    that memory follows the frame, not the file (a 1 GiB CSV is never held as bytes).

    Raises:
        NotAnMcapError: not a CSV with a numeric time column, or too wide.
    """
    try:
        with open(path, "rb", buffering=0) as fh:
            check_csv_width(path, fh.read(MAX_HEADER_BYTES + 1), size)
            if size < STREAM_MIN_BYTES:
                fh.seek(0)
                buf = fh.readall()
                if not buf:
                    raise NotAnMcapError(path, "the file is empty")
                return read_csv(path, buf)
            fh.seek(max(0, size - _TAIL_BYTES))
            tail = fh.read(_TAIL_BYTES)
    except OSError as err:
        raise NotAnMcapError(path, f"cannot read it: {err.strerror or err}") from err
    frame = None
    for infer in (10_000, None):  # a type that changes after the first rows: infer from all
        try:
            frame = pl.scan_csv(path, infer_schema_length=infer).collect(engine="streaming")
            break
        except Exception as err:  # polars raises ComputeError/NoDataError/... for bad text
            if infer is None:
                raise NotAnMcapError(path, f"CSV parse failed: {err}") from err
    assert frame is not None
    return _csv_log(path, frame, tail)


def read_csv(path: str, buf: bytes) -> LogData:
    """Parse CSV bytes into a :class:`LogData` with the single topic ``"csv"``.

    The time column ``t`` (s) becomes ``t_ns`` (int64 ns, rounded); rows without a time are
    dropped and counted in ``problems``; empty cells become null.

    Raises:
        NotAnMcapError: the bytes are not a CSV with a numeric column ``t``.
    """
    check_csv_width(path, buf[: MAX_HEADER_BYTES + 1], len(buf))
    try:
        frame = pl.read_csv(BytesIO(buf), infer_schema_length=None)
    except Exception as err:  # polars raises ComputeError/NoDataError/... for malformed text
        raise NotAnMcapError(path, f"CSV parse failed: {err}") from err
    return _csv_log(path, frame, buf[-_TAIL_BYTES:])


def _csv_log(path: str, frame: pl.DataFrame, tail: bytes) -> LogData:
    """The log of a parsed CSV (``tail``: the file's last bytes, to tell a cut last row)."""
    found = next(((c, u) for c, u in TIME_COLUMNS if c in frame.columns), None)
    if found is None:
        cols = ", ".join(frame.columns[:12]) or "(none)"
        raise NotAnMcapError(
            path,
            f"the CSV has no time column 't'; its columns: {cols} (a time column is 't' or "
            "'timestamp' (s), '__time' (PlotJuggler, s) or '%time' (rostopic echo -p, ns))",
        )
    tcol, declared = found
    exact_ns = declared == "ns" and frame[tcol].dtype.is_integer()
    t = frame[tcol].cast(pl.Float64, strict=False)
    if frame[tcol].null_count() < t.null_count():
        raise NotAnMcapError(path, f"the CSV time column {tcol!r} holds non-numeric values")
    problems: list[Problem] = []
    cut = _cut_last_row(tail, len(frame.columns))
    if cut and frame.height:
        frame, t = frame.head(frame.height - 1), t.head(frame.height - 1)
        problems.append(
            Problem(
                ProblemKind.TRUNCATED,
                CSV_TOPIC,
                count=1,
                message=f"{path}: the last CSV row has {cut} of {len(frame.columns)} fields and "
                "no final newline: the file was cut short; that row was dropped",
            )
        )
    keep = t.is_not_null() & t.is_finite()
    dropped = frame.height - int(keep.sum())
    if dropped:
        problems.append(
            Problem(
                ProblemKind.NO_TIME,
                CSV_TOPIC,
                count=dropped,
                message=f"{path}: {dropped} CSV rows have no finite time {tcol!r}; dropped",
            )
        )
    if exact_ns:  # integer nanoseconds: no round trip through float64 (256 ns steps at 2e18)
        t_ns = frame[tcol].filter(keep).cast(pl.Int64).alias(TIME_COLUMN)
    else:
        scale = 1e-9 if declared == "ns" else 1.0
        t_s = _to_seconds(path, t.filter(keep) * scale, problems, tcol, declared is None)
        t_ns = (t_s * 1e9).round().cast(pl.Int64).alias(TIME_COLUMN)
    frame = frame.filter(keep).drop(tcol).insert_column(0, t_ns)
    if not frame[TIME_COLUMN].is_sorted():
        backwards = int((frame[TIME_COLUMN].diff() < 0).sum())
        problems.append(
            Problem(
                ProblemKind.UNSORTED,
                CSV_TOPIC,
                count=backwards,
                message=f"{path}: CSV time {tcol!r} is not increasing; rows were sorted by it",
            )
        )
        frame = frame.sort(TIME_COLUMN, maintain_order=True)
    topics = by_topic_paths(frame)
    info = {topic: _topic_info(topic, f) for topic, f in topics.items()}
    return LogData(path, topics, info, {}, problems)


def _topic_info(topic: str, frame: pl.DataFrame) -> TopicInfo:
    times = frame[TIME_COLUMN]
    return TopicInfo(
        topic=topic,
        schema_name="",
        schema_encoding="csv",
        message_encoding="csv",
        message_count=frame.height,
        first_ns=int(times.min()) if frame.height else None,  # type: ignore[arg-type]
        last_ns=int(times.max()) if frame.height else None,  # type: ignore[arg-type]
    )


FIELD_ROOTS = frozenset(
    {
        "data",
        "header",
        "linear",
        "angular",
        "twist",
        "pose",
        "position",
        "orientation",
        "velocity",
        "effort",
        "transform",
        "translation",
        "rotation",
        "transforms",
        "angular_velocity",
        "linear_acceleration",
        "point",
        "vector",
        "wrench",
        "force",
        "torque",
        "drive",
        "steering_angle",
        "speed",
        "range",
    }
)
"""First components of the fields of common ROS messages (std_msgs, geometry_msgs, nav_msgs,
sensor_msgs, ackermann_msgs): in a column ``/odom/twist/twist/linear/x`` the topic ends before
the first of them (``/odom``, field ``twist.twist.linear.x``)."""

_INDEX = re.compile(r"\[(\d+)\]")


def topic_field(column: str) -> tuple[str, str] | None:
    """The (topic, field) a column named by its ROS path means, as PlotJuggler, Foxglove and
    ``ros2 bag`` CSV exports name them: ``/hitch/angle/data`` -> ("/hitch/angle", "data"),
    ``/wheels/position[1]`` -> ("/wheels", "position.1"); the field dotted as the MCAP reader
    flattens messages. None for a column that is no such path."""
    if not column.startswith("/") or column.endswith("/"):
        return None
    parts = [p for p in _INDEX.sub(r"/\1", column[1:]).split("/") if p]
    if len(parts) < 2:
        return None
    cut = next((i for i in range(1, len(parts)) if parts[i] in FIELD_ROOTS), len(parts) - 1)
    return "/" + "/".join(parts[:cut]), ".".join(parts[cut:])


def by_topic_paths(frame: pl.DataFrame) -> dict[str, pl.DataFrame]:
    """``frame`` (``t_ns`` and the CSV's columns) as frames by topic: columns named by ROS paths
    (:func:`topic_field`) on their own topic, each with the rows where any of its fields has a
    value (an export fills the other topics' rows with empty cells); every other column on
    the pseudo-topic ``csv``."""
    paths = {c: topic_field(c) for c in frame.columns if c != TIME_COLUMN}
    fields: dict[str, dict[str, str]] = {}
    for column, tf in paths.items():
        if tf is not None:
            fields.setdefault(tf[0], {})[column] = tf[1]
    plain = [c for c, tf in paths.items() if tf is None]
    if not fields:
        return {CSV_TOPIC: frame}
    out: dict[str, pl.DataFrame] = {}
    if plain:
        out[CSV_TOPIC] = frame.select(TIME_COLUMN, *plain)
    for topic, named in fields.items():
        if topic == CSV_TOPIC or len(set(named.values())) < len(named):
            return {CSV_TOPIC: frame}  # two columns on one field: not an export's paths
        part = frame.select(TIME_COLUMN, *named).rename(named)
        out[topic] = part.filter(pl.any_horizontal(pl.col(f).is_not_null() for f in named.values()))
    return out


MAX_PERIOD_S = 2.0
"""A typical spacing of the time column at or above this (s) is no drive log's sample period
(a 1 Hz export in seconds stays as it is):
the column counts relative milliseconds (or us, ns), told by the spacing."""
_RELATIVE = ((1e-3, "ms"), (1e-6, "us"), (1e-9, "ns"))


def _relative_unit(
    path: str, t: pl.Series, problems: list[Problem], column: str
) -> tuple[pl.Series, float, str]:
    """``t`` rescaled when its spacing says relative ms/us/ns (median step >= MAX_PERIOD_S),
    with a ``time_unit`` problem naming it; else as is."""
    steps = t.sort().diff().drop_nulls()
    steps = steps.filter(steps > 0)
    if steps.len() < 2:
        return t, 1.0, "s"
    step = float(steps.median())  # type: ignore[arg-type]
    if step < MAX_PERIOD_S:
        return t, 1.0, "s"
    factor, name = next(((f, u) for f, u in _RELATIVE if step * f < MAX_PERIOD_S), _RELATIVE[-1])
    problems.append(
        Problem(
            ProblemKind.TIME_UNIT,
            CSV_TOPIC,
            count=t.len(),
            message=f"{path}: CSV column {column!r} advances by a median of {step:.4g} per row: "
            f"relative {name}, not seconds (no drive log samples every {step:.4g} s); it was "
            f"divided by {1 / factor:.0e}",
        )
    )
    return t * factor, factor, name


def _cut_last_row(buf: bytes, n_fields: int) -> int:
    """Fields of the last row when it is cut short (fewer than ``n_fields``, no final newline);
    0 when the last row is whole."""
    if not buf or buf.endswith((b"\n", b"\r")):
        return 0
    last = buf.rsplit(b"\n", 1)[-1]
    k = last.count(b",") + 1
    return k if k < n_fields else 0


def _to_seconds(
    path: str, t: pl.Series, problems: list[Problem], column: str = "t", guess: bool = True
) -> pl.Series:
    """``t`` in seconds: (``guess``) epoch ms/us/ns told by the magnitude and rescaled (with a
    problem); a value that cannot be a time on the int64 ns clock is refused."""
    if t.len() == 0:
        return t
    median = float(t.abs().median())  # type: ignore[arg-type]
    unit = next((u for u in _UNITS if median < u[0]), None) if guess else _UNITS[0]
    if unit is None:
        raise TimestampError(
            f"{path}: CSV column {column!r} has a median of {median:.3g}, too large for a time "
            "in s, ms, us or ns; expected seconds (see LOG_FORMAT.md)"
        )
    _, factor, name = unit
    if factor != 1.0:
        t = t * factor
        problems.append(
            Problem(
                ProblemKind.TIME_UNIT,
                CSV_TOPIC,
                count=t.len(),
                message=f"{path}: CSV column {column!r} holds epoch {name} (median "
                f"{median:.4g}), not seconds; it was divided by {1 / factor:.0e}",
            )
        )
    elif guess:
        t, factor, name = _relative_unit(path, t, problems, column)
    bad = (t.abs() > _INT64_NS_LIMIT_S).arg_true()
    if bad.len():
        first = float(t[int(bad[0])]) / factor
        raise TimestampError(
            f"{path}: CSV column {column!r} holds {first:.6g}, which is no "
            f"time in {name} (beyond +-{_INT64_NS_LIMIT_S / factor:.3g}); "
            f"{bad.len()} such rows. Expected seconds (see LOG_FORMAT.md)"
        )
    return t
