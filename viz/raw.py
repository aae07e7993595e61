"""The signals as read, before alignment: every numeric field of every topic at its own stamps,
under ``/raw/<topic>/<field>``, so the recording can be browsed as PlotJuggler or Foxglove
would show the log, beside the fit. Shared by every robot's views.

Arrays beyond ``MAX_ITEMS`` entries of one field (``position.0`` .. ``position.N``) and
covariance matrices are left out (they would bury the signals); at most ``MAX_COLUMNS`` series
in all, the rest named in the returned list.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np
import polars as pl
import rerun as rr

__all__ = ["MAX_COLUMNS", "log_raw_signals"]

MAX_COLUMNS = 400
MAX_ITEMS = 16
_ITEM = re.compile(r"\.(\d+)$")
_NUMERIC = (
    pl.Float32,
    pl.Float64,
    pl.Int8,
    pl.Int16,
    pl.Int32,
    pl.Int64,
    pl.UInt8,
    pl.UInt16,
    pl.UInt32,
    pl.UInt64,
    pl.Boolean,
)


def _wanted(name: str) -> bool:
    if name == "t_ns" or "covariance" in name:
        return False
    m = _ITEM.search(name)
    return m is None or int(m.group(1)) < MAX_ITEMS


def _path(topic: str, field: str) -> str:
    parts = [p for p in topic.split("/") if p] or ["topic"]
    return "/".join(
        ["raw", *map(rr.escape_entity_path_part, parts), rr.escape_entity_path_part(field)]
    )


def log_raw_signals(
    rec: rr.RecordingStream,
    topics: Mapping[str, pl.DataFrame],
    *,
    timeline: str,
    origin_ns: int | None = None,
) -> list[str]:
    """Log every numeric field of ``topics`` (topic -> frame with ``t_ns``) as scalars at its
    own stamps on ``timeline``: absolute timestamps, or seconds from ``origin_ns`` when given
    (the timeline of views drawn in seconds). Returns the fields left out by the budget."""
    left: list[str] = []
    count = 0
    for topic in sorted(topics):
        frame = topics[topic]
        if "t_ns" not in frame.columns or frame.height == 0:
            continue
        t = frame["t_ns"].to_numpy().astype(np.int64)
        if origin_ns is None:
            index = [rr.TimeColumn(timeline, timestamp=t.astype("datetime64[ns]"))]
        else:
            index = [rr.TimeColumn(timeline, duration=(t - origin_ns) / 1e9)]
        for name, dtype in frame.schema.items():
            if not _wanted(name) or not isinstance(dtype, _NUMERIC):
                continue
            if count >= MAX_COLUMNS:
                left.append(f"{topic}:{name}")
                continue
            values = frame[name].cast(pl.Float64).to_numpy()
            if not np.isfinite(values).any():
                continue
            rec.send_columns(
                _path(topic, name), indexes=index, columns=rr.Scalars.columns(scalars=values)
            )
            count += 1
    return left
