"""Generic CSV writer: sensor-group frames -> one table on the union of their timestamps."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence

import polars as pl

from logtools.errors import LogWriteError

__all__ = ["frames_to_table", "write_frames_csv"]


def frames_to_table(
    frames: Mapping[str, pl.DataFrame], columns: Mapping[str, Sequence[str]]
) -> pl.DataFrame:
    """One frame with ``t`` (s from the first sample) and the ``columns`` of each group.

    Rows are the union of the groups' ``t_ns``; a group's columns are null where it has no
    sample. Groups sharing a timestamp share the row.

    Args:
        frames: sensor group -> frame with ``t_ns`` (int64 ns) and value columns.
        columns: sensor group -> the columns to take from it (logical signal names).

    Raises:
        LogWriteError: a group or column that the frames do not have.
    """
    parts = []
    for group, cols in columns.items():
        if group not in frames:
            raise LogWriteError(f"CSV: no frame {group!r} (frames: {', '.join(frames)})")
        missing = [c for c in ["t_ns", *cols] if c not in frames[group].columns]
        if missing:
            raise LogWriteError(f"CSV: frame {group!r} lacks the columns {', '.join(missing)}")
        parts.append(frames[group].select(pl.col("t_ns").cast(pl.Int64), *cols))
    if not parts:
        raise LogWriteError("CSV: no columns to write")
    table = parts[0]
    for part in parts[1:]:
        table = table.join(part, on="t_ns", how="full", coalesce=True)
    table = table.sort("t_ns")
    t0 = table["t_ns"].min()
    t_s = ((pl.col("t_ns") - t0).cast(pl.Float64) / 1e9).alias("t")
    return table.select(t_s, pl.exclude("t_ns"))


def write_frames_csv(
    path: str | os.PathLike[str],
    frames: Mapping[str, pl.DataFrame],
    columns: Mapping[str, Sequence[str]],
) -> int:
    """Write :func:`frames_to_table` as CSV (header row, empty cells where missing).

    Returns:
        The number of rows written.

    Raises:
        LogWriteError: unwritable path or missing group/column.
    """
    table = frames_to_table(frames, columns)
    try:
        table.write_csv(os.fspath(path), null_value="")
    except OSError as err:
        raise LogWriteError(f"{os.fspath(path)}: cannot write the CSV ({err.strerror})") from err
    return table.height
