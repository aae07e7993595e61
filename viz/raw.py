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
from typing import Any

import numpy as np
import polars as pl
import rerun as rr
import rerun.blueprint as rrb

__all__ = ["MAX_COLUMNS", "log_raw_signals", "raw_groups", "raw_views", "unit_of"]

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


def _fields(topics: Mapping[str, pl.DataFrame]) -> list[tuple[str, str]]:
    """(topic, field) of every series :func:`log_raw_signals` may log, in its order."""
    out = []
    for topic in sorted(topics):
        frame = topics[topic]
        if "t_ns" not in frame.columns or frame.height == 0:
            continue
        out += [
            (topic, name)
            for name, dtype in frame.schema.items()
            if _wanted(name) and isinstance(dtype, _NUMERIC)
        ]
    return out[:MAX_COLUMNS]


_ANGLES = {"yaw", "psi", "theta", "angle", "heading", "roll", "pitch", "yaw2"}


def unit_of(field: str) -> str:
    """The unit a field's name says (ROS message paths and logcal's own names), for grouping
    series onto one axis per unit: ``pose.pose.position.x`` -> "m", ``twist.twist.angular.z``
    -> "rad/s", ``yaw`` -> "rad"; a name that says none gets its own group (``"? <name>"``)."""
    tokens = [t for t in re.split(r"[._]", field.lower()) if t and not t.isdigit()]
    last = tokens[-1] if tokens else field
    if "covariance" in tokens:
        return "covariance"
    rules: tuple[tuple[bool, str], ...] = (
        ("angular" in tokens or last in {"omega", "gyro", "wz"} or "rate" in tokens, "rad/s"),
        ("linear" in tokens or last in {"v", "speed", "vx", "vy"}, "m/s"),
        ("velocity" in tokens, "velocity"),
        (bool({"effort", "torque", "tau"} & set(tokens)), "N·m"),
        ("orientation" in tokens, "quaternion"),
        (last in _ANGLES or (tokens[:1] == ["wheel"]), "rad"),
        ("position" in tokens and "pose" not in tokens, "position"),
        (last in {"x", "y", "z"}, "m"),
        (last in {"curvature", "kappa"}, "1/m"),
    )
    return next((unit for hit, unit in rules if hit), f"? {field}")


def raw_groups(topics: Mapping[str, pl.DataFrame]) -> dict[str, list[str]]:
    """The raw series in groups of one topic and one unit (:func:`unit_of`): title
    (``"/pose (m)"``) -> entity paths; one plot each, so that metres and rad/s never share an
    axis."""
    groups: dict[str, list[str]] = {}
    for topic, name in _fields(topics):
        unit = unit_of(name)
        title = f"{topic} ({unit})" if not unit.startswith("? ") else f"{topic} {unit[2:]}"
        groups.setdefault(title, []).append(_path(topic, name))
    return groups


def raw_views(topics: Mapping[str, pl.DataFrame], **view_args: Any) -> list[rrb.View]:
    """One time-series view per group of :func:`raw_groups` (``view_args``: the robot's time
    axis and range); a log without raw series: none."""
    return [
        rrb.TimeSeriesView(
            name=f"raw {title}", origin="/raw", contents=[f"+ /{p}" for p in paths], **view_args
        )
        for title, paths in raw_groups(topics).items()
    ]


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
