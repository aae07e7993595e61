"""The MCAP writer: sensor-group frames -> topics, driven by a list of topic bindings.

A :class:`TopicBinding` says which frame (sensor group) feeds a topic and which column fills
each message field (dotted paths for nested messages). Messages of all topics are written in
time order (``log_time`` = ``publish_time`` = the frame's ``t_ns``). Robot-specific writers
(tractor-trailer now, diff-drive and manipulator later) only declare their bindings.

One writer, :func:`write_frames_mcap`, with two message encoders: :class:`JsonEncoder` (JSON
messages, ``jsonschema`` schemas, through ``mcap``'s writer) and :class:`CdrEncoder` (ROS 2
``cdr`` messages, ``ros2msg`` schemas, through ``mcap-ros2-support``'s writer, whose CDR
serialiser is public only that way).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, BinaryIO, Literal, Protocol

import numpy as np
import polars as pl
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter

from logtools.errors import LogWriteError
from logtools.writers.ros2_msgdefs import msgdef

__all__ = [
    "CdrEncoder",
    "Compression",
    "JsonEncoder",
    "MessageEncoder",
    "TopicBinding",
    "json_schema",
    "write_frames_mcap",
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
        fields: message field path (dots for nesting; a numeric part is an array element, e.g.
            ``position.0``) -> frame column (float values).
        constants: field path -> fixed value (e.g. ``header.frame_id``).
        stamp_field: field path of a ``builtin_interfaces/Time`` filled from ``t_ns``; None: none.
    """

    topic: str
    group: str
    schema_name: str
    fields: Mapping[str, str]
    constants: Mapping[str, Any] = field(default_factory=dict)
    stamp_field: str | None = None


POSE_ODOMETRY_ROS2 = TopicBinding(
    "/pose",
    "pose",
    "nav_msgs/msg/Odometry",
    {
        "pose.pose.position.x": "x",
        "pose.pose.position.y": "y",
        "pose.pose.orientation.z": "qz",
        "pose.pose.orientation.w": "qw",
    },
    constants={"header.frame_id": "map", "child_frame_id": "base_link"},
    stamp_field="header.stamp",
)
"""LOG_FORMAT.md's ``/pose`` in ROS 2 (planar: yaw as the quaternion (0, 0, sin yaw/2,
cos yaw/2)), from a ``pose`` frame with columns x, y, qz, qw; shared by every robot's writer."""


def _constant_schema(value: Any) -> dict[str, Any]:
    if isinstance(value, str):
        return {"type": "string"}
    if isinstance(value, list | tuple):
        return {"type": "array", "items": _constant_schema(value[0]) if value else {}}
    return {"type": ["number", "null"]}


def json_schema(binding: TopicBinding) -> dict[str, Any]:
    """A JSON schema (draft 2020-12) for the messages of ``binding``: nested objects of numbers;
    a field path with a numeric part (``position.0``) is an array of numbers; constants get the
    type of their value (``name``: an array of strings)."""
    root: dict[str, Any] = {"type": "object", "properties": {}, "required": []}
    for path in binding.fields:
        node = root
        *parents, leaf = path.split(".")
        if leaf.isdigit():  # an element of an array field
            *parents, array = parents
            target = root
            for name in parents:
                target = target["properties"].setdefault(
                    name, {"type": "object", "properties": {}, "required": []}
                )
            if array not in target["properties"]:
                target["properties"][array] = {
                    "type": "array",
                    "items": {"type": ["number", "null"]},
                }
                target["required"].append(array)
            continue
        for name in parents:
            if name not in node["properties"]:
                node["properties"][name] = {"type": "object", "properties": {}, "required": []}
                node["required"].append(name)
            node = node["properties"][name]
        node["properties"][leaf] = {"type": ["number", "null"]}
        node["required"].append(leaf)
    for dotted, value in binding.constants.items():
        if "." not in dotted and dotted not in root["properties"]:
            root["properties"][dotted] = _constant_schema(value)
            root["required"].append(dotted)
    root["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    root["title"] = binding.schema_name
    return root


def _listify(msg: Any) -> Any:
    """Dicts keyed "0".."n-1" (array elements written by path) become lists."""
    if isinstance(msg, dict):
        if msg and all(k.isdigit() for k in msg):
            return [_listify(msg[str(i)]) for i in range(len(msg))]
        return {k: _listify(v) for k, v in msg.items()}
    return msg


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
    arrays = [any(part.isdigit() for p in ps for part in p) for ps in paths]
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
        yield i, t_ns, (_listify(msg) if arrays[i] else msg)


def _open(path: str | os.PathLike[str]) -> BinaryIO:
    try:
        return open(path, "wb")
    except OSError as err:
        raise LogWriteError(f"{os.fspath(path)}: cannot write the log ({err.strerror})") from err


class MessageEncoder(Protocol):
    """How messages of one encoding reach an MCAP file (one instance per file written)."""

    nan_as_none: bool
    """Whether NaN/inf become None (JSON has no NaN) or are written as floats (CDR)."""

    def start(self, fh: BinaryIO, compression: CompressionType, chunked: bool) -> None:
        """Begin the file."""
        ...

    def add_topic(self, binding: TopicBinding) -> None:
        """Register the schema and channel of ``binding`` (called once per binding, in order)."""
        ...

    def write(self, index: int, t_ns: int, msg: dict[str, Any]) -> None:
        """Write one message of the ``index``-th binding at log time ``t_ns``."""
        ...

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        """Write one metadata record."""
        ...

    def finish(self) -> None:
        """Write the summary and footer."""
        ...


class JsonEncoder:
    """JSON messages (``json``) with a JSON schema per topic (``jsonschema``)."""

    nan_as_none = True

    def __init__(self) -> None:
        self._writer: McapWriter | None = None
        self._channels: list[int] = []
        self._dumps = json.JSONEncoder(allow_nan=False, separators=(",", ":")).encode

    def _w(self) -> McapWriter:
        if self._writer is None:
            raise RuntimeError("JsonEncoder used before start()")
        return self._writer

    def start(self, fh: BinaryIO, compression: CompressionType, chunked: bool) -> None:
        self._writer = McapWriter(fh, compression=compression, use_chunking=chunked)
        self._writer.start(profile="", library="logcal")

    def add_topic(self, binding: TopicBinding) -> None:
        schema = json.dumps(json_schema(binding)).encode()
        sid = self._w().register_schema(binding.schema_name, "jsonschema", schema)
        self._channels.append(self._w().register_channel(binding.topic, "json", sid))

    def write(self, index: int, t_ns: int, msg: dict[str, Any]) -> None:
        self._w().add_message(self._channels[index], t_ns, self._dumps(msg).encode(), t_ns)

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        self._w().add_metadata(name, data)

    def finish(self) -> None:
        self._w().finish()


class CdrEncoder:
    """ROS 2 messages (``cdr``) with the message definitions of
    :data:`logtools.writers.ros2_msgdefs.MSGDEFS` (``ros2msg``); always chunked."""

    nan_as_none = False

    def __init__(self) -> None:
        self._writer: Any = None
        self._schemas: dict[str, Any] = {}
        self._topics: list[tuple[str, Any]] = []

    def start(self, fh: BinaryIO, compression: CompressionType, chunked: bool) -> None:
        from mcap_ros2.writer import Writer as Ros2Writer

        self._writer = Ros2Writer(fh, compression=compression)

    def add_topic(self, binding: TopicBinding) -> None:
        name = binding.schema_name
        if name not in self._schemas:
            self._schemas[name] = self._writer.register_msgdef(name, msgdef(name))
        self._topics.append((binding.topic, self._schemas[name]))

    def write(self, index: int, t_ns: int, msg: dict[str, Any]) -> None:
        topic, schema = self._topics[index]
        self._writer.write_message(topic, schema, msg, t_ns, t_ns)

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        self._writer.add_metadata(name, data)

    def finish(self) -> None:
        self._writer.finish()


def write_frames_mcap(
    path: str | os.PathLike[str],
    frames: Mapping[str, pl.DataFrame],
    bindings: Sequence[TopicBinding],
    encoder: MessageEncoder,
    *,
    metadata: Mapping[str, Mapping[str, str]] | None = None,
    compression: Compression = "zstd",
    chunked: bool = True,
) -> int:
    """Write ``frames`` as an MCAP file whose messages ``encoder`` encodes.

    Args:
        path: output file.
        frames: sensor group -> frame with ``t_ns`` (int64 ns) and value columns.
        bindings: the topics to write (for :class:`CdrEncoder`, ``schema_name`` must be a type
            of :data:`logtools.writers.ros2_msgdefs.MSGDEFS`).
        encoder: a fresh :class:`JsonEncoder` or :class:`CdrEncoder`.
        metadata: metadata records, name -> {key: string value}.
        compression: chunk compression.
        chunked: write chunks (with a message index) or bare messages (JSON only).

    Returns:
        The number of messages written.

    Raises:
        LogWriteError: unwritable path, or a binding naming a missing frame/column.
    """
    count = 0
    with _open(path) as fh:
        encoder.start(fh, _COMPRESSION[compression], chunked)
        for b in bindings:
            encoder.add_topic(b)
        for i, t_ns, msg in _messages(frames, bindings, nan_as_none=encoder.nan_as_none):
            encoder.write(i, t_ns, msg)
            count += 1
        for name, data in (metadata or {}).items():
            encoder.add_metadata(name, dict(data))
        encoder.finish()
    return count
