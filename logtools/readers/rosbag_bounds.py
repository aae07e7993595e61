"""Bounds on what a ROS bag can make the reader do (issue "a log is data, never instructions").

``rosbags`` trusts a bag: it loads ``metadata.yaml`` with every alias expanded where the values
are used, decompresses a rosbag2 bag in file-compression mode into a temporary folder and each
message of a message-compressed bag without a size bound, decompresses ROS 1 bz2/lz4 chunks
whole (the size a chunk declares is not checked against what comes out), and passes whatever a
``.db3`` column holds (an integer where the payload should be, text where the time should be)
on as a message. Here, before ``rosbags`` opens anything:

* ``metadata.yaml`` is read by us: at most :data:`METADATA_MAX_BYTES`, at most
  :data:`METADATA_MAX_NODES` YAML nodes with aliases expanded (counted on the parser's events,
  never built), and every key ``rosbags`` and logcal use checked for its type; the bag is read
  through a clean copy of it (a temporary folder whose storage files are links to the bag's).
* File-compression mode: each storage file is decompressed by us, streaming, into that folder,
  at most the decompression budget in all (:func:`decompress_budget`: the MCAP reader's
  64 MiB + 32 x the bag's size on disk).
* Message-compression mode: ``rosbags`` is told the bag is not compressed and each payload is
  decompressed here (:class:`PayloadGuard`), at most what is left of the budget; a payload that
  is not zstd is dropped and counted.
* ROS 1 chunks and rosbag2 ``.mcap`` storage chunks: each compressed chunk is decompressed once
  by streaming and counted (nothing kept); a chunk that yields more than it declares, or chunks
  that together yield more than the budget, refuse the bag with the offset.
* ``metadata.yaml`` nesting: at most :data:`METADATA_MAX_DEPTH` levels, counted on the raw
  text for flow brackets (``[[[[...``: before the parser, which is slow on them) and on the
  parser's events for block nesting.
* QoS profiles (``offered_qos_profiles``, in ``metadata.yaml`` or a ``.db3``'s ``topics``):
  checked to be what ``rosbags`` reads (a list of mappings whose policies are integers or
  names and whose durations are ``sec``/``nsec`` mappings), else a named error.
* ``.db3`` files: ``messages``, ``topics``, ``schema`` and ``message_definitions`` must be
  tables (a view can compute rows forever), ``schema.schema_version`` an integer, and every
  check runs under a time budget (:data:`DB3_CHECK_S`, an SQLite progress handler);
  the ``topics`` columns must hold text (ids integers); messages whose
  ``topic_id`` is in no ``topics`` row are counted and reported (``unknown_channel``); a payload
  that is not a blob or a record time that is not an integer drops that message, counted.

Every refusal is a :class:`~logtools.errors.NotARosbagError` naming the file, key or offset.
"""

from __future__ import annotations

import bz2
import io
import os
import sqlite3
import struct
import time
from collections import Counter
from contextlib import ExitStack
from pathlib import Path
from tempfile import TemporaryDirectory
from typing import Any, BinaryIO

import lz4.frame
import zstandard

from logtools.errors import NotARosbagError
from logtools.problems import Problem, ProblemKind
from logtools.readers.mcap_scan import DECOMPRESS_BASE_BYTES, DECOMPRESS_RATIO

__all__ = [
    "DB3_CHECK_S",
    "METADATA_MAX_BYTES",
    "METADATA_MAX_DEPTH",
    "METADATA_MAX_NODES",
    "QOS_MAX_BYTES",
    "PayloadGuard",
    "check_db3",
    "checked_metadata",
    "decompress_budget",
    "prepared_folder",
    "verify_mcap_chunks",
    "verify_ros1_chunks",
]

METADATA_MAX_BYTES = 2**20
"""Largest ``metadata.yaml`` read (1 MiB; rosbag2 writes a few KB, ~300 bytes per topic)."""
METADATA_MAX_NODES = 200_000
"""Most YAML nodes ``metadata.yaml`` may hold once its aliases are expanded."""
METADATA_MAX_DEPTH = 64
"""Most levels of nesting in ``metadata.yaml`` (rosbag2 writes 6)."""
QOS_MAX_BYTES = 1 << 16
"""Largest QoS profile string read (64 KiB; rosbag2 writes ~300 bytes per profile)."""
DB3_CHECK_S = 20.0
"""Time budget of the checks of one ``.db3`` file (seconds)."""
_STEP = 1 << 20
_METADATA = "metadata.yaml"


def decompress_budget(compressed_bytes: int) -> int:
    """Bytes a bag of ``compressed_bytes`` on disk may decompress to, in all."""
    return DECOMPRESS_BASE_BYTES + DECOMPRESS_RATIO * max(0, compressed_bytes)


# ----------------------------------------------------------------------------- metadata.yaml


def _flow_depth(text: str) -> int:
    """The deepest nesting of ``[`` and ``{`` in ``text`` (quoted strings and comments left
    out), counted without parsing."""
    import re

    import numpy as np

    bare = re.sub(r"'[^'\n]*'|\"(?:[^\"\\\n]|\\.)*\"|#[^\n]*", "", text)
    codes = np.frombuffer(bare.encode("utf-8", "replace"), dtype=np.uint8)
    step = np.isin(codes, (ord("["), ord("{"))).astype(np.int64)
    step -= np.isin(codes, (ord("]"), ord("}")))
    return int(np.cumsum(step).max(initial=0))


def _yaml_nodes(name: str, text: str) -> None:
    """Count the YAML nodes of ``text`` with aliases expanded, on the parser's events (no
    document is built); refuse more than :data:`METADATA_MAX_NODES`, or nesting deeper than
    :data:`METADATA_MAX_DEPTH` (flow brackets counted on the text, before the parser)."""
    if _flow_depth(text) > METADATA_MAX_DEPTH:
        raise NotARosbagError(
            name,
            f"{_METADATA} nests brackets deeper than {METADATA_MAX_DEPTH} levels; rosbag2 writes 6",
        )
    from ruamel.yaml import YAML
    from ruamel.yaml.events import (
        AliasEvent,
        CollectionEndEvent,
        CollectionStartEvent,
        ScalarEvent,
    )

    sizes: dict[str, int] = {}
    stack: list[list[Any]] = [[None, 0]]  # [anchor, nodes so far] of each open collection

    def done(anchor: str | None, n: int) -> None:
        if anchor:
            sizes[anchor] = n
        stack[-1][1] += n
        if stack[-1][1] > METADATA_MAX_NODES or n > METADATA_MAX_NODES:
            raise NotARosbagError(
                name,
                f"{_METADATA} expands to more than {METADATA_MAX_NODES} YAML nodes "
                "(aliases repeating aliases); rosbag2 writes no aliases",
            )

    for event in YAML(typ="safe", pure=True).parse(io.StringIO(text)):
        if isinstance(event, AliasEvent):
            if event.anchor not in sizes:
                raise NotARosbagError(
                    name, f"{_METADATA}: alias *{event.anchor} names no complete anchor"
                )
            done(None, sizes[event.anchor])
        elif isinstance(event, ScalarEvent):
            done(event.anchor, 1)
        elif isinstance(event, CollectionStartEvent):
            stack.append([event.anchor, 1])
            if len(stack) > METADATA_MAX_DEPTH:
                raise NotARosbagError(
                    name,
                    f"{_METADATA} nests deeper than {METADATA_MAX_DEPTH} levels; rosbag2 writes 6",
                )
        elif isinstance(event, CollectionEndEvent) and len(stack) > 1:
            anchor, n = stack.pop()
            done(anchor, n)


def _is_int(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _want(name: str, key: str, value: object, ok: bool, expected: str) -> None:
    if not ok:
        shown = repr(value)
        shown = shown if len(shown) <= 60 else shown[:57] + "..."
        raise NotARosbagError(name, f"{_METADATA}: {key} is {shown}; expected {expected}")


def checked_metadata(name: str, folder: Path) -> dict[str, Any]:
    """The ``rosbag2_bagfile_information`` mapping of ``folder/metadata.yaml``, read within the
    bounds above and with the type of every key used checked.

    Raises:
        NotARosbagError: too large, too many nodes, not YAML, or a key of the wrong type
            (the message names the key).
    """
    from ruamel.yaml import YAML
    from ruamel.yaml.error import YAMLError

    path = folder / _METADATA
    try:
        with open(path, "rb") as fh:
            raw = fh.read(METADATA_MAX_BYTES + 1)
    except OSError as err:
        raise NotARosbagError(name, f"cannot read {_METADATA}: {err.strerror or err}") from err
    if len(raw) > METADATA_MAX_BYTES:
        raise NotARosbagError(
            name, f"{_METADATA} is larger than {METADATA_MAX_BYTES} bytes; rosbag2 writes a few KB"
        )
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        raise NotARosbagError(
            name, f"{_METADATA} is not UTF-8 text ({err.reason} at byte {err.start})"
        ) from err
    try:
        _yaml_nodes(name, text)
        doc = YAML(typ="safe", pure=True).load(text)
    except (YAMLError, ValueError, TypeError, RecursionError) as err:
        first = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        raise NotARosbagError(name, f"{_METADATA} is not readable YAML ({first[:200]})") from err
    key = "rosbag2_bagfile_information"
    _want(name, "the document", doc, isinstance(doc, dict), f"a mapping with {key}")
    info = doc.get(key)
    _want(name, key, info, isinstance(info, dict), "a mapping")
    _check_info(name, key, info)
    return info


def _check_info(name: str, key: str, info: dict[str, Any]) -> None:
    def need(
        sub: str, test: Any, expected: str, where: dict[str, Any] = info, prefix: str = key
    ) -> Any:
        value = where.get(sub)
        _want(name, f"{prefix}.{sub}", value, sub in where and test(value), expected)
        return value

    def opt(sub: str, test: Any, expected: str) -> None:
        if info.get(sub) is not None:
            need(sub, test, expected)

    need("version", _is_int, "an integer")
    need("storage_identifier", lambda v: isinstance(v, str), "a storage name (sqlite3, mcap)")
    need(
        "relative_file_paths",
        lambda v: isinstance(v, list) and all(isinstance(p, str) and p for p in v),
        "a list of file names",
    )
    for sub, inner in (("duration", "nanoseconds"), ("starting_time", "nanoseconds_since_epoch")):
        table = need(sub, lambda v: isinstance(v, dict), "a mapping")
        need(inner, _is_int, "an integer", table, f"{key}.{sub}")
    need("message_count", _is_int, "an integer")
    topics = need("topics_with_message_count", lambda v: isinstance(v, list), "a list")
    for i, entry in enumerate(topics):
        where = f"{key}.topics_with_message_count[{i}]"
        _want(name, where, entry, isinstance(entry, dict), "a mapping")
        meta = need("topic_metadata", lambda v: isinstance(v, dict), "a mapping", entry, where)
        for sub in ("name", "type", "serialization_format"):
            need(sub, lambda v: isinstance(v, str), "a string", meta, f"{where}.topic_metadata")
        for sub, test, expected in (
            ("offered_qos_profiles", lambda v: isinstance(v, (str, list)), "a string or a list"),
            ("type_description_hash", lambda v: isinstance(v, str), "a string"),
        ):
            if sub in meta:
                need(sub, test, expected, meta, f"{where}.topic_metadata")
        if "offered_qos_profiles" in meta:
            why = qos_problem(meta["offered_qos_profiles"])
            if why is not None:
                raise NotARosbagError(
                    name, f"{_METADATA}: {where}.topic_metadata.offered_qos_profiles {why}"
                )
        need("message_count", _is_int, "an integer", entry, where)
    for sub in ("compression_format", "compression_mode", "ros_distro"):
        opt(sub, lambda v: isinstance(v, str), "a string")
    mode = (info.get("compression_mode") or "").lower()
    _want(
        name,
        f"{key}.compression_mode",
        info.get("compression_mode"),
        mode in ("", "none", "file", "message"),
        "'', 'none', 'file' or 'message'",
    )
    opt(
        "custom_data",
        lambda v: (
            isinstance(v, dict)
            and all(
                isinstance(k, str) and isinstance(x, (str, int, float, bool)) for k, x in v.items()
            )
        ),
        "a mapping of names to plain values",
    )
    opt("files", lambda v: isinstance(v, list), "a list")


_QOS_POLICIES = ("history", "reliability", "durability", "liveliness")
_QOS_DURATIONS = ("deadline", "lifespan", "liveliness_lease_duration")


def qos_problem(value: object) -> str | None:
    """What is wrong with the QoS profiles ``value`` (a YAML string or a list, as rosbag2
    stores them) for ``rosbags``, which reads every profile's policies (an integer or a name),
    ``depth``, three ``sec``/``nsec`` durations and ``avoid_ros_namespace_conventions``; None
    when they can be read ('' or an empty list: none)."""
    from ruamel.yaml import YAML
    from ruamel.yaml.error import YAMLError

    if not value:
        return None
    if isinstance(value, str):
        if len(value) > QOS_MAX_BYTES:
            return f"is longer than {QOS_MAX_BYTES} characters; rosbag2 writes ~300 per profile"
        if _flow_depth(value) > METADATA_MAX_DEPTH:
            return f"nests deeper than {METADATA_MAX_DEPTH} levels"
        try:
            value = YAML(typ="safe", pure=True).load(value)
        except (YAMLError, ValueError, TypeError, RecursionError) as err:
            first = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
            return f"is not readable YAML ({first[:120]})"
        if not value:
            return None
    if not isinstance(value, list):
        return f"is {type(value).__name__}, not a list of profiles"
    for i, profile in enumerate(value):
        if not isinstance(profile, dict):
            return f"[{i}] is {type(profile).__name__}, not a mapping"
        for key in _QOS_POLICIES:
            v = profile.get(key)
            if key in profile and not isinstance(v, (int, str)):
                return f"[{i}].{key} is {type(v).__name__}; expected an integer or a name"
        needed = ("depth", *_QOS_DURATIONS, "avoid_ros_namespace_conventions")
        missing = [k for k in needed if k not in profile]
        if missing:
            return f"[{i}] lacks {', '.join(missing)}"
        for key in _QOS_DURATIONS:
            d = profile[key]
            if not (isinstance(d, dict) and _is_int(d.get("sec")) and _is_int(d.get("nsec"))):
                return f"[{i}].{key} is {str(d)[:40]!r}; expected a mapping of integers sec, nsec"
    return None


def prepared_folder(
    name: str, folder: Path, info: dict[str, Any], stack: ExitStack
) -> tuple[Path, bool, list[Path], int]:
    """The folder ``rosbags`` opens: a temporary one holding a clean ``metadata.yaml`` (from the
    checked ``info``, compression switched off) and the storage files (file-compressed ones
    decompressed within the budget, others linked). Returns (folder, whether each message is
    zstd-compressed and must go through :class:`PayloadGuard`, its storage files, the
    decompression budget)."""
    from ruamel.yaml import YAML

    mode = (info.get("compression_mode") or "").lower()
    mode = "" if mode == "none" else mode
    if mode and (info.get("compression_format") or "") != "zstd":
        raise NotARosbagError(
            name,
            f"{_METADATA}: compression_format is {info.get('compression_format')!r} with "
            f"compression_mode {mode!r}; rosbag2 compresses with 'zstd' only",
        )
    names = [Path(p).name for p in info["relative_file_paths"]]
    sources = [folder / n for n in names]
    missing = [str(p) for p in sources if not p.is_file()]
    if missing:
        raise NotARosbagError(
            name, f"storage files named in {_METADATA} are missing: {', '.join(missing[:5])}"
        )
    tmp = Path(stack.enter_context(TemporaryDirectory(prefix="logcal_bag_")))
    budget = decompress_budget(sum(p.stat().st_size for p in sources))
    used = 0
    clean: list[str] = []
    for src in sources:
        target = tmp / ((src.stem or "storage") if mode == "file" else src.name)
        if target.name in clean:  # one storage file read twice, or two that would clash
            raise NotARosbagError(
                name,
                f"{_METADATA}: relative_file_paths names {src.name!r} where another "
                f"entry already gives the storage file {target.name!r}; each file once",
            )
        if mode == "file":
            used += _decompress_file(name, src, target, budget - used)
        else:
            os.symlink(src.resolve(), target)
        clean.append(target.name)
    copy = {k: v for k, v in info.items() if k not in ("files",)}
    copy["relative_file_paths"] = clean
    if mode:
        copy["compression_mode"] = ""
        copy["compression_format"] = ""
    with open(tmp / _METADATA, "w", encoding="utf-8") as fh:
        YAML(typ="safe", pure=True).dump({"rosbag2_bagfile_information": copy}, fh)
    return tmp, mode == "message", [tmp / c for c in clean], budget


def _decompress_file(name: str, src: Path, target: Path, left: int) -> int:
    """Decompress the zstd file ``src`` into ``target``, at most ``left`` bytes; the count."""
    n = 0
    try:
        with open(src, "rb") as fin, open(target, "wb") as fout:
            reader = zstandard.ZstdDecompressor().stream_reader(fin, read_across_frames=True)
            while piece := reader.read(_STEP):
                n += len(piece)
                if n > left:
                    raise NotARosbagError(
                        name,
                        f"{src.name} (compression_mode file) decompresses to more than "
                        f"the budget of {left} bytes left (64 MiB + 32 x the bag's size)",
                    )
                fout.write(piece)
    except zstandard.ZstdError as err:
        raise NotARosbagError(
            name, f"{src.name} is not zstd-compressed as {_METADATA} says ({err})"
        ) from err
    return n


# ----------------------------------------------------------------------------- payloads


class PayloadGuard:
    """Checks each message ``rosbags`` yields before it is kept: the payload must be bytes and
    the record time an integer (else the message is dropped and counted), and in a
    message-compressed bag the payload is decompressed here within the budget."""

    def __init__(self, name: str, compressed: bool, budget: int) -> None:
        self.name = name
        self.compressed = compressed
        self.left = budget
        self.problems: list[Problem] = []
        self.dropped: Counter[str] = Counter()
        self.why: dict[str, str] = {}

    def payload(self, topic: str, t_ns: object, data: object) -> bytes | None:
        """The message's bytes, or None when it is dropped."""
        if not _is_int(t_ns):
            return self._drop(topic, f"its record time is {type(t_ns).__name__}, not an integer")
        if not isinstance(data, (bytes, bytearray, memoryview)):
            return self._drop(topic, f"its payload is {type(data).__name__}, not bytes")
        if not self.compressed:
            return bytes(data)
        try:
            reader = zstandard.ZstdDecompressor().stream_reader(io.BytesIO(data))
            out = reader.read(self.left + 1)
        except zstandard.ZstdError as err:
            return self._drop(topic, f"its payload is not zstd ({err})")
        if len(out) > self.left:
            raise NotARosbagError(
                self.name,
                "its zstd-compressed messages (compression_mode message) decompress "
                "to more than the budget of 64 MiB + 32 x the bag's size",
            )
        self.left -= len(out)
        return out

    def _drop(self, topic: str, why: str) -> bytes | None:
        self.dropped[topic] += 1
        self.why.setdefault(topic, why)
        return None

    def report(self) -> list[Problem]:
        """The problems found before and while reading: dropped messages per topic."""
        out = list(self.problems)
        for topic, n in sorted(self.dropped.items()):
            out.append(
                Problem(
                    ProblemKind.DROPPED_MESSAGES,
                    topic,
                    count=n,
                    message=f"{self.name}: topic {topic!r}: {n} messages were dropped (first: "
                    f"{self.why[topic]})",
                )
            )
        return out


# ----------------------------------------------------------------------------- .db3 files


_TOPIC_COLUMNS = (
    ("id", "integer"),
    ("name", "text"),
    ("type", "text"),
    ("serialization_format", "text"),
)


_DB3_TABLES = ("messages", "topics", "schema", "message_definitions", "metadata")
"""The objects of a rosbag2 database that rosbags reads: each must be a table if present."""


def _check_db3_schema(name: str, path: Path, con: sqlite3.Connection) -> None:
    """The objects rosbags reads are tables (a view or a virtual table can compute rows
    forever), ``schema.schema_version`` an integer, the ``topics`` QoS profiles readable."""
    kinds: dict[str, str] = {}
    for kind, obj, sql in con.execute("SELECT type, name, sql FROM sqlite_master"):
        if isinstance(obj, str) and obj in _DB3_TABLES:
            virtual = isinstance(sql, str) and "VIRTUAL" in sql.upper()[:40]
            kinds[obj] = "virtual table" if virtual else str(kind)
    for obj, kind in sorted(kinds.items()):
        if kind != "table":
            raise NotARosbagError(
                name,
                f"{path.name}: {obj} is {'an' if kind[0] in 'aeiou' else 'a'} {kind}, "
                "not a table; rosbag2 writes tables only",
            )
    for obj in ("messages", "topics"):
        if obj not in kinds:
            raise NotARosbagError(name, f"{path.name}: holds no {obj} table; not a rosbag2 bag")
    if "schema" in kinds:
        row = con.execute(
            "SELECT count(*), min(typeof(schema_version)) FROM schema "
            "WHERE typeof(schema_version) != 'integer'"
        ).fetchone()
        if row[0]:
            raise NotARosbagError(
                name,
                f"{path.name}: table schema, column schema_version holds {row[1]}, not an integer",
            )
    columns = {r[1] for r in con.execute("PRAGMA table_info(topics)")}
    if "offered_qos_profiles" in columns:
        for topic, qos in con.execute("SELECT name, offered_qos_profiles FROM topics"):
            if qos is not None and not isinstance(qos, str):
                why: str | None = f"is {type(qos).__name__}, not text"
            else:
                why = qos_problem(qos)
            if why is not None:
                raise NotARosbagError(
                    name,
                    f"{path.name}: table topics, topic {str(topic)[:80]!r}: "
                    f"offered_qos_profiles {why}",
                )


def check_db3(name: str, path: Path) -> list[Problem]:
    """Check a rosbag2 sqlite3 storage file (see module doc); the problems to report.

    Raises:
        NotARosbagError: not an SQLite database, or a ``topics`` column of the wrong type.
    """
    try:
        con = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro&immutable=1", uri=True)
    except sqlite3.Error as err:
        raise NotARosbagError(name, f"{path.name}: cannot open it as SQLite ({err})") from err
    deadline = time.monotonic() + DB3_CHECK_S
    con.set_progress_handler(lambda: int(time.monotonic() > deadline), 10_000)
    try:
        _check_db3_schema(name, path, con)
        for col, want in _TOPIC_COLUMNS:
            row = con.execute(
                f"SELECT count(*), min(typeof({col})) FROM topics WHERE typeof({col}) != ?",
                (want,),
            ).fetchone()
            if row[0]:
                raise NotARosbagError(
                    name,
                    f"{path.name}: table topics, column {col}: {row[0]} rows hold "
                    f"{row[1]}, not {want}",
                )
        row = con.execute(
            "SELECT count(*), min(typeof(timestamp)) FROM messages "
            "WHERE typeof(timestamp) != 'integer'"
        ).fetchone()
        if row[0]:  # rosbags computes the bag's time span from these before any message
            raise NotARosbagError(
                name,
                f"{path.name}: table messages, column timestamp: {row[0]} rows hold "
                f"{row[1]}, not integer nanoseconds",
            )
        (orphans,) = con.execute(
            "SELECT count(*) FROM messages WHERE topic_id NOT IN (SELECT id FROM topics)"
        ).fetchone()
    except sqlite3.Error as err:
        if time.monotonic() > deadline:
            raise NotARosbagError(
                name, f"{path.name}: checking it took longer than {DB3_CHECK_S:g} s; not read"
            ) from err
        raise NotARosbagError(name, f"{path.name}: not a rosbag2 database ({err})") from err
    finally:
        con.close()
    if not orphans:
        return []
    return [
        Problem(
            ProblemKind.UNKNOWN_CHANNEL,
            count=orphans,
            message=f"{name}: {path.name}: {orphans} messages name a topic_id that the topics "
            "table does not hold; they were not read",
        )
    ]


# ----------------------------------------------------------------------------- chunks


def _decompressor(kind: str) -> Any:
    if kind == "bz2":
        return bz2.BZ2Decompressor()
    if kind == "lz4":
        return lz4.frame.LZ4FrameDecompressor()
    return None


def _chunk_size(
    name: str, fh: BinaryIO, at: int, length: int, kind: str, limit: int, where: str
) -> int:
    """Decompress ``length`` bytes at ``at`` of ``fh`` (``kind``: bz2, lz4, zstd) by streaming,
    discarding the output; the decompressed size, refused beyond ``limit``."""
    fh.seek(at)
    n = 0
    try:
        if kind == "zstd":
            reader = zstandard.ZstdDecompressor().stream_reader(
                io.BytesIO(fh.read(length)), read_across_frames=True
            )
            while piece := reader.read(_STEP):
                n += len(piece)
                if n > limit:
                    break
        else:
            n = _stream_count(fh, length, kind, limit)
    except (OSError, EOFError, RuntimeError, ValueError, zstandard.ZstdError) as err:
        raise NotARosbagError(
            name,
            f"the {kind} chunk at offset {where} does not decompress ({type(err).__name__}: {err})",
        ) from err
    if n > limit:
        raise NotARosbagError(
            name,
            f"the {kind} chunk at offset {where} decompresses to more "
            f"than {limit} bytes (what it declares, or what is left of "
            "the decompression budget of 64 MiB + 32 x the file size)",
        )
    return n


def _stream_count(fh: BinaryIO, length: int, kind: str, limit: int) -> int:
    """Bytes that ``length`` bytes of ``fh`` decompress to (bz2: every stream, as
    ``bz2.decompress`` reads them; lz4: the first frame, as ``lz4.frame.decompress``), counted
    up to just past ``limit``."""
    dec = _decompressor(kind)
    left, n, pending = length, 0, b""
    while n <= limit:
        if dec.eof:
            rest = dec.unused_data or b""
            if kind != "bz2" or (not rest and left <= 0):
                break
            dec, pending = _decompressor(kind), rest
        elif dec.needs_input and not pending:
            if left <= 0:
                break
            pending = fh.read(min(_STEP, left))
            left -= len(pending)
            if not pending:
                break
        n += len(dec.decompress(pending, max_length=_STEP))
        pending = b""
    return n


def verify_ros1_chunks(name: str, path: Path, chunks: list[tuple[int, int, int, str, int]]) -> None:
    """Decompress every compressed ROS 1 chunk once, counting: ``chunks`` are (record offset,
    data offset, data length, compression, declared size) from the record walk.

    Raises:
        NotARosbagError: a chunk yields more than it declares, or all of them more than the
            budget.
    """
    left = decompress_budget(path.stat().st_size)
    with open(path, "rb") as fh:
        for pos, at, length, kind, declared in chunks:
            if kind == "none":
                continue
            if kind not in ("bz2", "lz4"):
                raise NotARosbagError(
                    name,
                    f"the chunk at offset {pos} has compression "
                    f"{kind!r}; ROS 1 bags use none, bz2 or lz4",
                )
            limit = min(declared, left)
            left -= _chunk_size(name, fh, at, length, kind, limit, str(pos))


_MCAP_MAGIC = b"\x89MCAP0\r\n"
_OP_CHUNK = 0x06


def verify_mcap_chunks(name: str, path: Path) -> None:
    """Walk the top-level records of a rosbag2 ``.mcap`` storage file and decompress every
    compressed chunk once, counting (``rosbags`` decompresses each chunk whole, trusting it).

    Raises:
        NotARosbagError: a chunk yields more than it declares, or all more than the budget.
    """
    size = path.stat().st_size
    left = decompress_budget(size)
    with open(path, "rb") as fh:
        if fh.read(len(_MCAP_MAGIC)) != _MCAP_MAGIC:
            return  # rosbags names what is wrong
        pos = len(_MCAP_MAGIC)
        while pos + 9 <= size:
            fh.seek(pos)
            op, length = struct.unpack("<BQ", fh.read(9))
            if length > size - pos - 9:
                return  # truncated or corrupt: rosbags refuses or reads what it can
            if op == _OP_CHUNK and length >= 32:
                head = fh.read(min(length, 4096))
                declared = struct.unpack_from("<Q", head, 16)[0]
                (clen,) = struct.unpack_from("<I", head, 28)
                kind = head[32 : 32 + clen].decode("latin-1")
                rec_at = 32 + clen
                if kind and len(head) >= rec_at + 8:
                    (rlen,) = struct.unpack_from("<Q", head, rec_at)
                    start = pos + 9 + rec_at + 8
                    if rlen <= size - start and kind in ("zstd", "lz4"):
                        limit = min(declared, left)
                        left -= _chunk_size(name, fh, start, rlen, kind, limit, str(pos))
            pos += 9 + length


def bounded_target(
    name: str, target: Path, is_ros1: bool, stack: ExitStack
) -> tuple[Path, PayloadGuard]:
    """What ``rosbags`` should open for the bag at ``target`` and the guard its messages go
    through, after the checks above (ROS 1 chunks are checked by the record walk)."""
    if is_ros1 or not target.exists():
        return target, PayloadGuard(name, False, 0)
    problems: list[Problem] = []
    if target.is_dir():
        info = checked_metadata(name, target)
        opened, compressed, files, budget = prepared_folder(name, target, info, stack)
        storage = str(info["storage_identifier"])
    else:
        opened, compressed, storage, files, budget = target, False, "", [target], 0
    for f in files:
        if storage == "sqlite3" or f.suffix.lower() == ".db3":
            problems += check_db3(name, f)
        elif storage == "mcap" or f.suffix.lower() == ".mcap":
            verify_mcap_chunks(name, f)
    guard = PayloadGuard(name, compressed, budget)
    guard.problems = problems
    return opened, guard
