"""Read ROS bags directly with ``rosbags``: rosbag2 folders (sqlite3 or mcap storage) and ROS 1.

No conversion step: :func:`read_rosbag` opens the bag with ``rosbags``' ``AnyReader`` and turns
every topic into the same frames as the MCAP reader (``t_ns`` = the bag's record time, fields
flattened by path, arrays as numbered columns). Message types come from the definitions stored
in the bag; where a bag stores none (rosbag2 before Humble, e.g. Foxy), from ``rosbags``' type
store of the bag's distribution (``ros_distro`` in metadata.yaml), else of ROS 2 Foxy.

A ROS 1 bag's top-level records are walked first (:func:`check_ros1_records`): ``rosbags`` reads
each record's 32-bit length and allocates that much before reading, so one damaged length field
asks for up to 4 GiB. The walk checks that every record fits in the file, that the index
position is the start of a record, and that no chunk declares more uncompressed bytes than the
decompression budget of the MCAP reader; a bag that fails is refused with the offset.
"""

from __future__ import annotations

import dataclasses
import os
import struct
from collections.abc import Iterable
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

from logtools.errors import NotARosbagError
from logtools.problems import Problem, ProblemKind
from logtools.readers.base import TIME_COLUMN, LogData, TopicInfo, sorted_by_time
from logtools.readers.decoders import MAX_ARRAY_ITEMS, frame_from_rows
from logtools.readers.mcap_scan import DECOMPRESS_BASE_BYTES, DECOMPRESS_RATIO
from logtools.readers.rosbag_bounds import PayloadGuard, bounded_target, verify_ros1_chunks

__all__ = [
    "ROS1_MAGIC",
    "SQLITE_MAGIC",
    "bag_path",
    "check_plain_files",
    "check_ros1_records",
    "is_rosbag",
    "read_rosbag",
]

ROS1_MAGIC = b"#ROSBAG V2.0"
_ROS1_OP_BAG_HEADER = 0x03
_ROS1_OP_CHUNK = 0x05
SQLITE_MAGIC = b"SQLite format 3\x00"
METADATA_FILE = "metadata.yaml"
CUSTOM_DATA_PREFIX = "logcal."
"""rosbag2 ``custom_data`` keys ``logcal.<key>`` become the ``logcal`` metadata record."""


def is_rosbag(path: Path, head: bytes = b"") -> bool:
    """True for a rosbag2 folder, a .db3 file or a ROS 1 bag (by name or first bytes)."""
    if path.is_dir():
        return (path / METADATA_FILE).is_file()
    return (
        path.suffix.lower() in (".db3", ".bag")
        or head.startswith(ROS1_MAGIC)
        or head.startswith(SQLITE_MAGIC)
    )


def bag_path(path: Path) -> Path:
    """What to open: a .db3 file's folder when it holds metadata.yaml, else ``path``."""
    if path.is_file() and path.suffix.lower() == ".db3" and (path.parent / METADATA_FILE).is_file():
        return path.parent
    return path


def _database_errors() -> tuple[type[Exception], ...]:
    """What the rosbag2 ``.db3`` storage raises for a damaged database (rosbags reads it with
    ``apsw``; ``sqlite3`` as well): a damaged bag, not a bug of ours."""
    import sqlite3

    try:
        import apsw
    except ImportError:
        return (sqlite3.Error,)
    return (sqlite3.Error, apsw.Error)


def read_rosbag(path: str | os.PathLike[str], topics: Iterable[str] | None = None) -> LogData:
    """Read a ROS bag into per-topic frames.

    Args:
        path: a rosbag2 folder (with metadata.yaml), a .db3 file (its folder is read when it
            holds metadata.yaml), or a ROS 1 .bag file.
        topics: decode just these topics (``info`` still lists all); None: all.

    Returns:
        Frames, topic summaries, metadata (``rosbag2``: distribution and storage; ``logcal``:
        custom_data keys ``logcal.*``) and problems (undecodable types, time going backwards).

    Raises:
        NotARosbagError: the bag cannot be opened (missing files, bad metadata, not a bag).
    """
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.rosbag1 import ReaderError as Ros1ReaderError
    from rosbags.rosbag2 import ReaderError as Ros2ReaderError

    name = os.fspath(path)
    target = bag_path(Path(name))
    is_ros1 = target.is_file() and _head(target).startswith(ROS1_MAGIC)
    if target.is_file() and target.suffix.lower() != ".bag" and is_ros1:
        raise NotARosbagError(name, "a ROS 1 bag must be named *.bag for rosbags to read it")
    # rosbags checks some invariants of damaged bags with assert and indexes past short
    # buffers: those are damaged bags too, not bugs of the caller
    errors: tuple[type[Exception], ...] = (
        AnyReaderError,
        Ros1ReaderError,
        Ros2ReaderError,
        *_database_errors(),
        OSError,
        ValueError,
        KeyError,
        TypeError,  # a field of the wrong type where rosbags expects another (the last net)
        AttributeError,
        AssertionError,
        IndexError,
        EOFError,
        RuntimeError,
        struct.error,
    )
    if is_ros1:
        check_ros1_records(name, target)
    if target.is_dir():
        check_plain_files(name, target)
    with ExitStack() as stack:  # a temporary clean copy of a rosbag2 folder (rosbag_bounds)
        opened, guard = bounded_target(name, target, is_ros1, stack)
        try:
            store = _default_store(target, is_ros1)
            reader = AnyReader([opened], default_typestore=store)
            reader.open()
        except errors as err:
            raise NotARosbagError(name, _describe(err)) from err
        except MemoryError as err:  # a length field the checks above do not reach
            raise NotARosbagError(
                name, "a length field asks for more memory than there is"
            ) from err
        try:
            return _read_open(name, reader, store, is_ros1, topics, guard)
        except errors as err:
            raise NotARosbagError(name, _describe(err)) from err
        except MemoryError as err:
            raise NotARosbagError(
                name, "a length field asks for more memory than there is"
            ) from err
        finally:
            reader.close()


def check_plain_files(name: str, folder: Path) -> None:
    """Refuse a rosbag2 folder holding a FIFO, socket or device (named like its storage file,
    opening it would block or read without end): regular files and folders only.

    Raises:
        NotARosbagError: names the entry and its kind.
    """
    import stat

    for entry in sorted(os.listdir(folder)):
        try:
            mode = os.stat(folder / entry).st_mode
        except OSError:
            continue  # a dangling link: rosbags names the missing file if it needs it
        if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
            kind = (
                "a FIFO"
                if stat.S_ISFIFO(mode)
                else "a socket"
                if stat.S_ISSOCK(mode)
                else "a device"
                if stat.S_ISCHR(mode) or stat.S_ISBLK(mode)
                else "not a regular file"
            )
            raise NotARosbagError(
                name, f"{entry!r} in the bag folder is {kind}; logcal reads regular files only"
            )


def _describe(err: BaseException) -> str:
    text = str(err) or "a consistency check failed (a record does not match the bag's index)"
    return f"{type(err).__name__}: {text}"


def check_ros1_records(name: str, path: Path) -> None:
    """Walk a ROS 1 bag's top-level records and refuse lengths that do not fit (see module doc).

    Raises:
        NotARosbagError: a record runs past the end of the file, the index position is not a
            record, or a chunk declares more uncompressed bytes than the budget.
    """
    size = path.stat().st_size
    budget = DECOMPRESS_BASE_BYTES + DECOMPRESS_RATIO * size
    starts: set[int] = set()
    index_pos: int | None = None
    chunks: list[tuple[int, int, int, str, int]] = []
    with path.open("rb") as fh:
        first = fh.readline(64)
        pos = len(first)
        while pos < size:
            starts.add(pos)
            fh.seek(pos)
            head = fh.read(4)
            (hlen,) = struct.unpack("<I", head) if len(head) == 4 else (size,)
            if pos + 4 + hlen + 4 > size:
                raise NotARosbagError(
                    name,
                    f"the record at offset {pos} has a {hlen}-byte header: past the end "
                    f"of the {size}-byte file (truncated or corrupt)",
                )
            fields = _ros1_header_fields(fh.read(hlen))
            (dlen,) = struct.unpack("<I", fh.read(4))
            end = pos + 4 + hlen + 4 + dlen
            if end > size:
                raise NotARosbagError(
                    name,
                    f"the record at offset {pos} holds {dlen} data bytes: past the end of "
                    f"the {size}-byte file (truncated or corrupt)",
                )
            op = fields.get("op", b"\xff")[:1]
            if op == bytes([_ROS1_OP_BAG_HEADER]) and len(fields.get("index_pos", b"")) == 8:
                (index_pos,) = struct.unpack("<Q", fields["index_pos"])
            if op == bytes([_ROS1_OP_CHUNK]) and len(fields.get("size", b"")) == 4:
                (unpacked,) = struct.unpack("<I", fields["size"])
                if unpacked > budget:
                    raise NotARosbagError(
                        name,
                        f"the chunk at offset {pos} declares {unpacked} bytes uncompressed, "
                        f"beyond the decompression budget of {budget} bytes",
                    )
                kind = fields.get("compression", b"none").decode("latin-1")
                chunks.append((pos, pos + 4 + hlen + 4, dlen, kind, unpacked))
            pos = end
    if index_pos is not None and index_pos not in starts and index_pos != size:
        raise NotARosbagError(
            name, f"its header puts the index at offset {index_pos}, where no record starts"
        )
    verify_ros1_chunks(name, path, chunks)  # what each chunk really holds (rosbag_bounds)


def _ros1_header_fields(header: bytes) -> dict[str, bytes]:
    """``name=value`` fields of a ROS 1 record header (a malformed tail is ignored)."""
    out: dict[str, bytes] = {}
    at = 0
    while at + 4 <= len(header):
        (n,) = struct.unpack_from("<I", header, at)
        field_bytes = header[at + 4 : at + 4 + n]
        at += 4 + n
        key, sep, value = field_bytes.partition(b"=")
        if sep:
            out[key.decode("latin-1")] = value
    return out


def _head(path: Path) -> bytes:
    try:
        with path.open("rb") as fh:
            return fh.read(len(SQLITE_MAGIC))
    except OSError:
        return b""


def _distro(target: Path) -> str | None:
    meta = target / METADATA_FILE if target.is_dir() else None
    if meta is None or not meta.is_file():
        return None
    for line in meta.read_text(encoding="utf-8", errors="replace").splitlines():
        key, _, value = line.strip().partition(":")
        if key == "ros_distro":
            return value.strip().strip("'\"") or None
    return None


def _default_store(target: Path, is_ros1: bool) -> Any:
    from rosbags.typesys import Stores, get_typestore

    if is_ros1:
        return get_typestore(Stores.ROS1_NOETIC)
    distro = _distro(target)
    store = next((s for s in Stores if s.value == f"ros2_{distro}"), Stores.ROS2_FOXY)
    return get_typestore(store)


def _read_open(
    name: str,
    reader: Any,
    store: Any,
    is_ros1: bool,
    topics: Iterable[str] | None,
    guard: PayloadGuard | None = None,
) -> LogData:
    problems: list[Problem] = []
    _complete_typestore(reader, store)
    known = set(reader.typestore.fielddefs)
    conns_by_topic: dict[str, list[Any]] = {}
    for conn in reader.connections:
        conns_by_topic.setdefault(conn.topic, []).append(conn)
    wanted = set(conns_by_topic) if topics is None else set(topics)
    decodable = [c for c in reader.connections if c.topic in wanted and c.msgtype in known]
    for topic in sorted(wanted & set(conns_by_topic)):
        missing = sorted({c.msgtype for c in conns_by_topic[topic] if c.msgtype not in known})
        if missing:
            count = sum(c.msgcount for c in conns_by_topic[topic] if c.msgtype in missing)
            problems.append(
                Problem(
                    ProblemKind.UNKNOWN_TYPE,
                    topic,
                    count=count,
                    message=f"{name}: topic {topic!r}: message type {', '.join(missing)} is "
                    f"neither defined in the bag nor a standard type; its {count} messages were "
                    "not decoded",
                )
            )
    raw: dict[str, tuple[list[int], list[bytes], list[str]]] = {}
    times: dict[str, list[int]] = {t: [] for t in conns_by_topic}
    guard = guard or PayloadGuard(name, False, 0)
    for conn, t_ns, data in reader.messages(connections=decodable) if decodable else ():
        payload = guard.payload(conn.topic, t_ns, data)  # None: dropped (rosbag_bounds)
        if payload is None:
            continue
        entry = raw.setdefault(conn.topic, ([], [], []))
        entry[0].append(t_ns)
        entry[1].append(payload)
        entry[2].append(conn.msgtype)
    problems += guard.report()
    frames: dict[str, pl.DataFrame] = {}
    for topic, (t_list, payloads, types) in sorted(raw.items()):
        times[topic] = t_list
        frame, lost, error = _decode(reader, t_list, payloads, types)
        if lost:
            problems.append(
                Problem(
                    ProblemKind.DROPPED_MESSAGES,
                    topic,
                    min(t_list),
                    max(t_list),
                    count=lost,
                    message=f"{name}: topic {topic!r}: {lost} of {len(payloads)} messages did "
                    f"not decode and were dropped (first error: {error})",
                )
            )
        frames[topic] = sorted_by_time(frame, name, topic, problems, "record time")
    info = {
        topic: _topic_info(topic, conns, times.get(topic, []), is_ros1)
        for topic, conns in sorted(conns_by_topic.items())
    }
    if not frames and any(info[t].message_count for t in wanted & set(info)):
        types = sorted({c.msgtype for c in reader.connections if c.topic in wanted})
        raise NotARosbagError(
            name, f"none of its messages could be decoded (types: {', '.join(types)})"
        )
    return LogData(name, frames, info, _metadata(reader, is_ros1), problems)


def _complete_typestore(reader: Any, default: Any) -> None:
    """Add the default store's types a bag lacks (bags that define only some of their types)."""
    have = set(reader.typestore.fielddefs)
    needed = {c.msgtype for c in reader.connections} - have
    if needed & set(default.fielddefs):
        reader.typestore.register({k: v for k, v in default.fielddefs.items() if k not in have})


def _decode(
    reader: Any, t_list: list[int], payloads: list[bytes], types: list[str]
) -> tuple[pl.DataFrame, int, str | None]:
    """The decoded frame, how many messages did not decode, and the first error."""
    rows: list[dict[str, Any]] = []
    kept: list[int] = []
    error: str | None = None
    for i, (payload, msgtype) in enumerate(zip(payloads, types, strict=True)):
        try:
            msg = reader.deserialize(payload, msgtype)
        except Exception as err:  # a message that does not match its type: drop just it
            error = error or f"{type(err).__name__}: {err}"
            continue
        row: dict[str, Any] = {}
        _flatten(msg, "", row)
        rows.append(row)
        kept.append(i)
    t_ns = pl.Series(TIME_COLUMN, [t_list[i] for i in kept], dtype=pl.Int64)
    frame = frame_from_rows(rows)
    if TIME_COLUMN in frame.columns:
        frame = frame.rename({TIME_COLUMN: f"{TIME_COLUMN}.field"})
    frame = frame.insert_column(0, t_ns) if frame.width else pl.DataFrame([t_ns])
    return frame, len(payloads) - len(kept), error


_FIELDS: dict[type, tuple[str, ...]] = {}


def _flatten(obj: Any, prefix: str, out: dict[str, Any]) -> None:
    """Flatten a ``rosbags`` message (a dataclass; arrays are numpy arrays or lists) by path."""
    if isinstance(obj, (bool, int, float, str)) or obj is None:
        out[prefix or "value"] = obj
        return
    if isinstance(obj, np.ndarray):
        items = obj[:MAX_ARRAY_ITEMS].tolist()
        for i, value in enumerate(items):
            out[f"{prefix}.{i}"] = value
        return
    if isinstance(obj, np.generic):
        out[prefix or "value"] = obj.item()
        return
    if isinstance(obj, (list, tuple)):
        for i, value in enumerate(obj[:MAX_ARRAY_ITEMS]):
            _flatten(value, f"{prefix}.{i}", out)
        return
    cls = type(obj)
    names = _FIELDS.get(cls)
    if names is None:
        names = _FIELDS[cls] = (
            tuple(f.name for f in dataclasses.fields(obj) if not f.name.startswith("_"))
            if dataclasses.is_dataclass(obj)
            else ()
        )
    if not names:
        out[prefix or "value"] = str(obj)
        return
    for fname in names:
        _flatten(getattr(obj, fname), f"{prefix}.{fname}" if prefix else fname, out)


def _topic_info(topic: str, conns: list[Any], times: list[int], is_ros1: bool) -> TopicInfo:
    from rosbags.interfaces import MessageDefinitionFormat

    fmt = conns[0].msgdef.format
    schema_encoding = ""
    if fmt == MessageDefinitionFormat.MSG:
        schema_encoding = "ros1msg" if is_ros1 else "ros2msg"
    elif fmt == MessageDefinitionFormat.IDL:
        schema_encoding = "ros2idl"
    count = len(times) if times else sum(c.msgcount for c in conns)
    return TopicInfo(
        topic=topic,
        schema_name=conns[0].msgtype,
        schema_encoding=schema_encoding,
        message_encoding="ros1" if is_ros1 else "cdr",
        message_count=count,
        first_ns=min(times) if times else None,
        last_ns=max(times) if times else None,
    )


def _metadata(reader: Any, is_ros1: bool) -> dict[str, dict[str, str]]:
    if is_ros1:
        return {}
    out: dict[str, dict[str, str]] = {}
    rec: dict[str, str] = {}
    for sub in reader.readers:
        meta = getattr(getattr(sub, "storage", sub), "metadata", None)
        distro = getattr(meta, "ros_distro", None)
        if distro:
            rec["ros_distro"] = str(distro)
        custom = getattr(meta, "custom", None) or {}
        for key, value in custom.items():
            if str(key).startswith(CUSTOM_DATA_PREFIX):
                out.setdefault("logcal", {})[str(key)[len(CUSTOM_DATA_PREFIX) :]] = str(value)
            else:
                rec[f"custom_data.{key}"] = str(value)
    if rec:
        out["rosbag2"] = rec
    return out
