"""Generic MCAP writer: sensor-group frames -> topics, driven by a list of topic bindings.

A :class:`TopicBinding` says which frame (sensor group) feeds a topic and which column fills
each message field (dotted paths for nested messages). Messages of all topics are written in
time order (``log_time`` = ``publish_time`` = the frame's ``t_ns``). Robot-specific writers
(tractor-trailer now, diff-drive and manipulator later) only declare their bindings.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import polars as pl
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter

from logtools.errors import LogWriteError
from logtools.writers.ros2_msgdefs import msgdef

__all__ = [
    "Compression",
    "TopicBinding",
    "json_schema",
    "write_frames_mcap_json",
    "write_frames_mcap_ros2",
]

Compression = Literal["zstd", "lz4", "none"]

_COMPRESSION: dict[str, CompressionType] = {
    "zstd": CompressionType.ZSTD,
    "lz4": CompressionType.LZ4,
    "none": CompressionType.NONE,
}


@dataclass(frozen=True)
class TopicBinding:
    """How one topic is filled from one sensor-group frame.

    Args:
        topic: MCAP topic name.
        group: key of the frame that feeds it.
        schema_name: message type name (``nav_msgs/msg/Odometry``; for JSON a descriptive name).
        fields: message field path (dots for nesting) -> frame column (float values).
        constants: field path -> fixed value (e.g. ``header.frame_id``).
        stamp_field: field path of a ``builtin_interfaces/Time`` filled from ``t_ns``; None: none.
    """

    topic: str
    group: str
    schema_name: str
    fields: Mapping[str, str]
    constants: Mapping[str, Any] = field(default_factory=dict)
    stamp_field: str | None = None


def json_schema(binding: TopicBinding) -> dict[str, Any]:
    """A JSON schema (draft 2020-12) for the messages of ``binding``: nested objects of numbers."""
    root: dict[str, Any] = {"type": "object", "properties": {}, "required": []}
    for path in binding.fields:
        node = root
        *parents, leaf = path.split(".")
        for name in parents:
            if name not in node["properties"]:
                node["properties"][name] = {"type": "object", "properties": {}, "required": []}
                node["required"].append(name)
            node = node["properties"][name]
        node["properties"][leaf] = {"type": ["number", "null"]}
        node["required"].append(leaf)
    root["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    root["title"] = binding.schema_name
    return root


def _set(msg: dict[str, Any], path: tuple[str, ...], value: Any) -> None:
    node = msg
    for name in path[:-1]:
        node = node.setdefault(name, {})
    node[path[-1]] = value


def _column(frame: pl.DataFrame, binding: TopicBinding, col: str, nan_as_none: bool) -> list[Any]:
    """Column values as Python floats; NaN/inf as None if ``nan_as_none`` (JSON has no NaN)."""
    if col not in frame.columns:
        raise LogWriteError(
            f"topic {binding.topic!r}: frame {binding.group!r} has no column {col!r} "
            f"(columns: {', '.join(frame.columns)})"
        )
    arr = frame[col].cast(pl.Float64).to_numpy()
    values = arr.tolist()
    if nan_as_none and not np.all(np.isfinite(arr)):
        values = [v if math.isfinite(v) else None for v in values]
    return values


def _messages(
    frames: Mapping[str, pl.DataFrame], bindings: Sequence[TopicBinding], nan_as_none: bool
) -> Iterator[tuple[int, int, dict[str, Any]]]:
    """(binding index, log_time ns, message dict) of every topic, in time order."""
    cols: list[list[list[Any]]] = []
    times: list[np.ndarray] = []
    for b in bindings:
        if b.group not in frames:
            raise LogWriteError(
                f"topic {b.topic!r}: no frame {b.group!r} (frames: {', '.join(frames)})"
            )
        frame = frames[b.group]
        if "t_ns" not in frame.columns:
            raise LogWriteError(f"topic {b.topic!r}: frame {b.group!r} has no column 't_ns'")
        times.append(frame["t_ns"].cast(pl.Int64).to_numpy())
        cols.append([_column(frame, b, c, nan_as_none) for c in b.fields.values()])
    t_all = np.concatenate(times) if times else np.zeros(0, np.int64)
    which = np.concatenate([np.full(t.size, i) for i, t in enumerate(times)]) if times else t_all
    row = np.concatenate([np.arange(t.size) for t in times]) if times else t_all
    order = np.lexsort((which, t_all))
    paths = [[tuple(p.split(".")) for p in b.fields] for b in bindings]
    for k in order.tolist():
        i, r, t_ns = int(which[k]), int(row[k]), int(t_all[k])
        b = bindings[i]
        msg: dict[str, Any] = {}
        for dotted, value in b.constants.items():
            _set(msg, tuple(dotted.split(".")), value)
        if b.stamp_field is not None:
            sec, nsec = divmod(t_ns, 1_000_000_000)
            _set(msg, tuple(b.stamp_field.split(".")), {"sec": sec, "nanosec": nsec})
        for path, values in zip(paths[i], cols[i], strict=True):
            _set(msg, path, values[r])
        yield i, t_ns, msg


def _open(path: str | os.PathLike[str]) -> Any:
    try:
        return open(path, "wb")
    except OSError as err:
        raise LogWriteError(f"{os.fspath(path)}: cannot write the log ({err.strerror})") from err


def write_frames_mcap_json(
    path: str | os.PathLike[str],
    frames: Mapping[str, pl.DataFrame],
    bindings: Sequence[TopicBinding],
    *,
    metadata: Mapping[str, Mapping[str, str]] | None = None,
    compression: Compression = "zstd",
    chunked: bool = True,
) -> int:
    """Write ``frames`` as an MCAP with JSON messages (schema encoding ``jsonschema``).

    Args:
        path: output file.
        frames: sensor group -> frame with ``t_ns`` (int64 ns) and value columns.
        bindings: the topics to write.
        metadata: metadata records, name -> {key: string value}.
        compression: chunk compression.
        chunked: write chunks (with a message index) or bare messages.

    Returns:
        The number of messages written.

    Raises:
        LogWriteError: unwritable path, or a binding naming a missing frame/column.
    """
    count = 0
    with _open(path) as fh:
        writer = McapWriter(fh, compression=_COMPRESSION[compression], use_chunking=chunked)
        writer.start(profile="", library="logcal")
        channels = []
        for b in bindings:
            schema = json.dumps(json_schema(b)).encode()
            sid = writer.register_schema(b.schema_name, "jsonschema", schema)
            channels.append(writer.register_channel(b.topic, "json", sid))
        dumps = json.JSONEncoder(allow_nan=False, separators=(",", ":")).encode
        for i, t_ns, msg in _messages(frames, bindings, nan_as_none=True):
            writer.add_message(channels[i], t_ns, dumps(msg).encode(), t_ns)
            count += 1
        for name, data in (metadata or {}).items():
            writer.add_metadata(name, dict(data))
        writer.finish()
    return count


def write_frames_mcap_ros2(
    path: str | os.PathLike[str],
    frames: Mapping[str, pl.DataFrame],
    bindings: Sequence[TopicBinding],
    *,
    metadata: Mapping[str, Mapping[str, str]] | None = None,
    compression: Compression = "zstd",
) -> int:
    """Write ``frames`` as a ROS 2 MCAP (``cdr`` messages, ``ros2msg`` schemas, chunked).

    ``schema_name`` of each binding must be a type of
    :data:`logtools.writers.ros2_msgdefs.MSGDEFS`. Arguments, return and errors as
    :func:`write_frames_mcap_json`.
    """
    from mcap_ros2.writer import Writer as Ros2Writer

    count = 0
    with _open(path) as fh:
        writer = Ros2Writer(fh, compression=_COMPRESSION[compression])
        schemas = {}
        for b in bindings:
            name = b.schema_name
            if name not in schemas:
                schemas[name] = writer.register_msgdef(name, msgdef(name))
        for i, t_ns, msg in _messages(frames, bindings, nan_as_none=False):
            b = bindings[i]
            writer.write_message(b.topic, schemas[b.schema_name], msg, t_ns, t_ns)
            count += 1
        for name, data in (metadata or {}).items():
            writer.add_metadata(name, dict(data))
        writer.finish()
    return count
