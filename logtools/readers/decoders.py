"""Message decoders, registered per MCAP message encoding: a channel's payloads -> one frame.

A decoder takes all raw payloads of one channel at once (a sequence of ``bytes``; the MCAP
reader passes a :class:`~logtools.readers.mcap_scan.Payloads`, views into the decompressed
chunks that bulk decoders read with numpy) and returns a polars frame with one row per payload
it could decode (fields flattened by path: ``twist.twist.linear.x``; arrays as numbered columns:
``position.0``) and the indices of those payloads. JSON channels whose messages all share one
structure are decoded by one compiled pass (``flat_json``), other JSON in bulk by polars' NDJSON
reader (the payloads are laid out as NDJSON lines with numpy, not joined one by one); ROS 2
(``cdr``) fixed-layout messages in bulk by ``cdr_bulk``; other ROS 2 messages, ROS 1 and
protobuf go message by message through the ``mcap`` support packages' decoder factories.

The decoders a read uses are passed in (``read_log(path, decoders=...)``, a mapping from MCAP
message encoding to decoder); :data:`DEFAULT_DECODERS` holds the four above. Nothing is
registered at import time, so two reads with different decoders do not affect each other.
"""

from __future__ import annotations

import contextlib
import io
import json
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from io import BytesIO
from types import MappingProxyType
from typing import Any, Protocol

import numpy as np
import polars as pl
from mcap.records import Channel, Schema

from logtools.readers.flatten import MAX_ARRAY_ITEMS, MAX_COLUMNS, flatten_object
from logtools.readers.mcap_scan import Payloads

__all__ = [
    "CELLS_PER_PAYLOAD_BYTE",
    "CELL_BUDGET_BASE",
    "DEFAULT_DECODERS",
    "MAX_ARRAY_ITEMS",
    "MAX_COLUMNS",
    "Decoded",
    "Decoders",
    "MessageDecoder",
    "cell_budget",
    "decode_cdr",
    "decode_cdr_each",
    "decode_json",
    "decode_json_ndjson",
    "flatten_frame",
    "flatten_frame_bounded",
    "flatten_object",
    "frame_from_rows",
    "known_encodings",
]


@dataclass(frozen=True)
class Decoded:
    """Result of decoding one channel.

    Attributes:
        frame: one row per decoded payload, flattened fields as columns.
        kept: indices of the decoded payloads in the input order (None: all of them).
        error: the first decoding error, when some payloads were dropped.
        dropped_columns: see below.
    """

    frame: pl.DataFrame
    kept: list[int] | None = None
    error: str | None = None
    dropped_columns: int = 0
    """Columns left out to keep the channel within :data:`MAX_COLUMNS` and its cell budget
    (:func:`cell_budget`), or because two fields flatten to one name (``"a.b"`` beside
    ``{"a": {"b": …}}``: the first is kept)."""


class MessageDecoder(Protocol):
    """Decodes all payloads of one channel."""

    def __call__(
        self, schema: Schema | None, channel: Channel, payloads: Sequence[bytes]
    ) -> Decoded:
        """Decode ``payloads`` (raw message data of ``channel``)."""
        ...


Decoders = Mapping[str, MessageDecoder]
"""MCAP message encoding -> the decoder for its channels."""


def known_encodings(decoders: Decoders | None = None) -> list[str]:
    """Message encodings ``decoders`` (default: :data:`DEFAULT_DECODERS`) can decode, sorted."""
    return sorted(DEFAULT_DECODERS if decoders is None else decoders)


# ---------------------------------------------------------------- bounds

CELL_BUDGET_BASE = 2**22
"""Cells (rows x columns) every channel may have, whatever its size (4 M)."""
CELLS_PER_PAYLOAD_BYTE = 1
"""Further cells per byte of the channel's payloads. A value costs at least a byte in CDR and
two in JSON, so only missing fields (nulls) go beyond: JSON objects whose keys all differ, one
long array among short ones. Columns beyond the budget are dropped, the first ones kept."""
MAX_LISTED_STRUCT_FIELDS = 256
"""Fields of objects inside JSON arrays that polars' NDJSON reader may unify (every array item
gets every field): beyond, or beyond the cell budget, the channel is decoded message by
message."""


def cell_budget(payload_bytes: int) -> int:
    """Cells a channel of ``payload_bytes`` may be decoded into."""
    return CELL_BUDGET_BASE + CELLS_PER_PAYLOAD_BYTE * max(0, int(payload_bytes))


def _payload_bytes(payloads: Sequence[bytes]) -> int:
    if isinstance(payloads, Payloads):
        return int(payloads.lengths.sum())
    return sum(len(p) for p in payloads)


def _column_limit(rows: int, budget: int) -> int:
    return max(1, min(MAX_COLUMNS, budget // max(1, rows)))


# ---------------------------------------------------------------- flattening


def flatten_frame(frame: pl.DataFrame) -> pl.DataFrame:
    """Flatten struct columns to ``parent.child`` and list columns to ``name.0``, ``name.1``, …
    (within :data:`MAX_COLUMNS`; a name made twice keeps its first column)."""
    return flatten_frame_bounded(frame)[0]


def flatten_frame_bounded(
    frame: pl.DataFrame, budget: int | None = None
) -> tuple[pl.DataFrame, int]:
    """:func:`flatten_frame`, keeping at most :data:`MAX_COLUMNS` columns and ``budget`` cells
    (None: :data:`MAX_COLUMNS` only); returns the frame and how many columns were dropped (at
    least: a struct dropped before it is flattened counts as one)."""
    limit = MAX_COLUMNS if budget is None else _column_limit(frame.height, budget)
    dropped = 0
    while True:
        nested = [
            name
            for name, dtype in frame.schema.items()
            if isinstance(dtype, (pl.Struct, pl.List, pl.Array))
        ]
        if not nested:
            return frame, dropped
        exprs: dict[str, pl.Expr] = {}
        for name, dtype in frame.schema.items():
            if len(exprs) > limit:
                break
            if isinstance(dtype, pl.Struct):
                fields = pl.col(name).struct
                for f in dtype.fields:
                    exprs.setdefault(f"{name}.{f.name}", fields.field(f.name))
            elif isinstance(dtype, (pl.List, pl.Array)):
                col = pl.col(name) if isinstance(dtype, pl.List) else pl.col(name).arr.to_list()
                longest = frame.select(col.list.len().max()).item() or 0
                for i in range(min(longest, MAX_ARRAY_ITEMS, limit + 1)):
                    exprs.setdefault(f"{name}.{i}", col.list.get(i, null_on_oob=True))
            else:
                exprs.setdefault(name, pl.col(name))
        total = _planned_width(frame)
        keep = list(exprs.items())[:limit]
        dropped += max(0, total - len(keep))
        frame = frame.select([e.alias(n) for n, e in keep])


def _planned_width(frame: pl.DataFrame) -> int:
    """Columns one flattening step makes (arrays: up to MAX_ARRAY_ITEMS; each name once)."""
    n = 0
    for name, dtype in frame.schema.items():
        if isinstance(dtype, pl.Struct):
            n += len(dtype.fields)
        elif isinstance(dtype, (pl.List, pl.Array)):
            col = pl.col(name) if isinstance(dtype, pl.List) else pl.col(name).arr.to_list()
            n += min(frame.select(col.list.len().max()).item() or 0, MAX_ARRAY_ITEMS)
        else:
            n += 1
    return n


def frame_from_rows(rows: list[dict[str, Any]]) -> pl.DataFrame:
    """Build a frame from flattened rows; fields missing from a row become null."""
    keys = dict.fromkeys(key for row in rows for key in row)
    return pl.DataFrame([pl.Series(k, [row.get(k) for row in rows], strict=False) for k in keys])


_MAX_COUNTED = 2**16
"""Dropped column names counted (a report saying so; beyond, the names are not held)."""


class _Columns:
    """Flattened rows gathered column by column, at most ``limit`` columns (the first names
    met); values of other names are counted and dropped, never held. Each column holds its
    values and their row numbers (cost: the values present, not rows x columns)."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self.columns: dict[str, tuple[list[int], list[Any]]] = {}
        self.extra: set[str] = set()
        self.rows = 0

    def add(self, row: dict[str, Any]) -> None:
        for key, value in row.items():
            col = self.columns.get(key)
            if col is None:
                if len(self.columns) >= self.limit:
                    if len(self.extra) < _MAX_COUNTED:  # names beyond: not counted
                        self.extra.add(key)
                    continue
                col = self.columns[key] = ([], [])
            col[0].append(self.rows)
            col[1].append(value)
        self.rows += 1

    def frame(self) -> pl.DataFrame:
        series = []
        for key, (at, values) in self.columns.items():
            if len(at) == self.rows:
                full = values
            else:
                full = [None] * self.rows
                for i, v in zip(at, values, strict=True):
                    full[i] = v
            series.append(pl.Series(key, full, strict=False))
        return pl.DataFrame(series)


# ---------------------------------------------------------------- decoders


_JSON_INFER_ROWS = 1000


def decode_json(schema: Schema | None, channel: Channel, payloads: Sequence[bytes]) -> Decoded:
    """Decode JSON payloads in one go: a channel whose messages all share the first one's
    structure by one compiled pass (``flat_json``), any other with polars' NDJSON reader
    (:func:`decode_json_ndjson`; the same frame for the channels both can read)."""
    from logtools.readers.flat_json import decode_uniform

    if not len(payloads):
        return Decoded(pl.DataFrame())
    data = payloads if isinstance(payloads, Payloads) else Payloads.from_bytes(payloads)
    frame = decode_uniform(data)
    return Decoded(frame) if frame is not None else decode_json_ndjson(schema, channel, data)


def decode_json_ndjson(
    schema: Schema | None, channel: Channel, payloads: Sequence[bytes]
) -> Decoded:
    """Decode JSON payloads in one go with polars' NDJSON reader; fall back per message.

    Bounded: the schema polars infers is looked at before any frame is built; a channel whose
    objects would make more than :data:`MAX_COLUMNS` columns or more cells than
    :func:`cell_budget` allows (objects whose keys all differ, unified by polars into one wide
    struct for every array item) is decoded message by message, keeping the first columns
    within the budget."""
    if not len(payloads):
        return Decoded(pl.DataFrame())
    data = payloads if isinstance(payloads, Payloads) else Payloads.from_bytes(payloads)
    budget = cell_budget(_payload_bytes(data))
    joined = _ndjson_lines(data)
    # Infer the schema from the first messages (fast) when every message has as many keys as
    # they do (a field that first appears later would be dropped silently by that schema);
    # otherwise from all of them. If a later message disagrees in type (an int field that turns
    # float), polars raises and the whole channel is inferred instead.
    first = _JSON_INFER_ROWS if _uniform_keys(joined, len(payloads)) else None
    for infer in dict.fromkeys((first, None)):
        try:
            if not _fits(joined, len(payloads), infer, budget):
                break
            frame = pl.read_ndjson(BytesIO(joined), infer_schema_length=infer)
        except Exception:  # polars raises ComputeError/SchemaError/...: try the next way
            continue
        if frame.height != len(payloads):
            break
        flat, dropped = flatten_frame_bounded(frame, budget)
        if infer is not None and _null_after_head(flat):
            continue  # a field missing later (renamed?) where the first lines all had it
        return Decoded(flat, dropped_columns=dropped)
    return _decode_each(payloads, _json_object, budget)


MAX_JSON_DEPTH = 64
"""Deepest nesting of arrays and objects handed to polars' NDJSON reader (drive messages nest
under 10 deep); deeper channels are decoded message by message (``json.loads`` refuses a
message nested beyond Python's recursion limit: it is dropped and counted)."""
_DEPTH_STEP = np.zeros(256, dtype=np.int8)
_DEPTH_STEP[[ord("["), ord("{")]] = 1
_DEPTH_STEP[[ord("]"), ord("}")]] = -1


def _depth(joined: bytes) -> int:
    """Deepest nesting of ``[``/``{`` within any one line (brackets inside strings count too:
    an upper bound; the level restarts at each line, so a string holding "[" on every line does
    not pile up), in blocks of 16 MiB."""
    data = np.frombuffer(joined, dtype=np.uint8)
    carry, deepest = 0, 0
    for at in range(0, len(data), 1 << 24):
        block = data[at : at + (1 << 24)]
        level = np.cumsum(_DEPTH_STEP[block], dtype=np.int64) + carry
        if not len(level):
            continue
        newline = block == 10
        pos = np.where(newline, np.arange(len(block)), -1)
        last = np.maximum.accumulate(pos)
        base = np.where(last >= 0, level[np.maximum(last, 0)], 0)
        inline = level - base
        deepest = max(deepest, int(inline.max()))
        carry = int(inline[-1])
    return deepest


_KEY = re.compile(rb'"((?:[^"\\]|\\.)*)"[ \t\r]*:')


def _few_key_names(joined: bytes) -> bool:
    """Whether the lines use at most MAX_COLUMNS distinct key names (one regex pass; stops at
    the first name beyond)."""
    names: set[bytes] = set()
    for match in _KEY.finditer(joined):
        names.add(match.group(1))
        if len(names) > MAX_COLUMNS:
            return False
    return True


def _fits(joined: bytes, n: int, infer: int | None, budget: int) -> bool:
    """Whether polars may build the frame of these NDJSON lines: the schema it infers (no frame
    is built) has at most MAX_COLUMNS leaves, rows x leaves within ``budget``, and the objects
    inside arrays (each ``{`` beyond one per line, an upper bound) times the widest such object
    within ``budget`` too."""
    if _depth(joined) > MAX_JSON_DEPTH or not _few_key_names(joined):
        return False  # polars' schema inference alone would take minutes
    found = pl.scan_ndjson(BytesIO(joined), infer_schema_length=infer).collect_schema()
    leaves, listed = 0, 0
    stack: list[tuple[Any, bool]] = [(dtype, False) for dtype in found.values()]
    while stack:
        dtype, in_list = stack.pop()
        if isinstance(dtype, pl.Struct):
            if in_list:
                listed = max(listed, len(dtype.fields))
            stack += [(f.dtype, in_list) for f in dtype.fields]
        elif isinstance(dtype, (pl.List, pl.Array)):
            stack.append((dtype.inner, True))
        else:
            leaves += 1
        if leaves > MAX_COLUMNS or listed > MAX_LISTED_STRUCT_FIELDS:
            return False
    if n * leaves > budget:
        return False
    return not listed or (joined.count(b"{") - n) * listed <= budget


def _null_after_head(frame: pl.DataFrame) -> bool:
    """Whether a column has nulls after the first ``_JSON_INFER_ROWS`` rows but none in them."""
    head = frame.head(_JSON_INFER_ROWS)
    return any(frame[c].null_count() > 0 and head[c].null_count() == 0 for c in frame.columns)


def _uniform_keys(joined: bytes, n: int) -> bool:
    """Whether every NDJSON line holds as many key tokens (``":``) as each of the first
    ``_JSON_INFER_ROWS`` lines does, so that no field can first appear later unless another
    goes missing (``_null_after_head`` catches that). Costs one pass of ``bytes.count``."""
    end = -1
    for _ in range(min(n, _JSON_INFER_ROWS)):  # the first lines, without copying the rest
        end = joined.find(b"\n", end + 1)
        if end < 0:
            end = len(joined)
            break
    counts = {line.count(b'":') for line in joined[:end].split(b"\n")}
    if len(counts) != 1:
        return False
    return joined.count(b'":') == n * counts.pop()


_LINE_BLOCK = 4096  # messages laid out at a time, each padded to its block's longest


def _ndjson_lines(data: Payloads) -> bytes:
    """One NDJSON line per payload: CR and LF inside a payload become spaces, and each line is
    padded with spaces to the longest payload of its block of messages (whitespace is
    insignificant in JSON, and a blank line is skipped as an empty one is)."""
    buffer, starts, lengths = data.buffer, data.starts, data.lengths
    firsts = np.arange(0, len(starts), _LINE_BLOCK)
    widths = np.maximum.reduceat(lengths, firsts) + 1
    counts = np.diff(np.append(firsts, len(starts)))
    ends = np.cumsum(widths * counts)
    if int(ends[-1]) > 2 * int(lengths.sum()) + len(starts) + 2**24:
        # one long payload among short ones would pad its whole block: join them instead
        return b"".join(
            bytes(buffer[a : a + n]).replace(b"\n", b" ").replace(b"\r", b" ") + b"\n"
            for a, n in zip(starts.tolist(), lengths.tolist(), strict=True)
        )
    out = np.empty(int(ends[-1]), dtype=np.uint8)
    for first, width, end, count in zip(
        firsts.tolist(), widths.tolist(), ends.tolist(), counts.tolist(), strict=True
    ):
        at = starts[first : first + count]
        size = lengths[first : first + count]
        rows = out[end - width * count : end].reshape(count, width)
        fits = at + width <= len(buffer)
        if len(buffer) >= width:
            view = np.ndarray((len(buffer) - width + 1,), f"V{width}", buffer, strides=(1,))
            rows.view(f"V{width}")[fits, 0] = view[at[fits]]
        for i in np.flatnonzero(~fits).tolist():  # the buffer's last payloads
            rows[i, : size[i]] = buffer[at[i] : at[i] + size[i]]
        np.putmask(rows, np.arange(width) >= size[:, None], 32)
        rows[:, -1] = 10
    joined = out.tobytes()
    if joined.count(b"\n") != len(starts) or joined.count(b"\r"):  # inside payloads: spaces
        out[(out == 13) | (out == 10)] = 32
        row_width = np.repeat(widths, counts)
        row = np.arange(len(starts)) - np.repeat(firsts, counts)
        out[np.repeat(ends - widths * counts, counts) + (row + 1) * row_width - 1] = 10
        joined = out.tobytes()
    return joined


def _json_object(payload: bytes) -> Any:
    value = json.loads(payload)
    if not isinstance(value, dict):
        raise ValueError(f"a JSON {type(value).__name__}, not an object")
    return value


def _decode_each(
    payloads: Sequence[bytes], decode: Callable[[bytes], Any], budget: int | None = None
) -> Decoded:
    """Decode message by message, dropping (and counting) those that fail; at most
    :data:`MAX_COLUMNS` columns and ``budget`` cells (default: :func:`cell_budget` of the
    payloads), the first columns met kept."""
    if budget is None:
        budget = cell_budget(_payload_bytes(payloads))
    columns = _Columns(_column_limit(len(payloads), budget))
    kept: list[int] = []
    error: str | None = None
    for i, payload in enumerate(payloads):
        try:
            row = flatten_object(decode(payload))
        except Exception as err:  # any decoder failure drops just this message
            error = error or f"{type(err).__name__}: {err}"
            continue
        columns.add(row)
        kept.append(i)
    return Decoded(
        columns.frame(), kept if len(kept) != len(payloads) else None, error, len(columns.extra)
    )


class _FactoryDecoder:
    """Per-message decoding through an ``mcap`` support package's DecoderFactory."""

    def __init__(self, make_factory: Callable[[], Any]) -> None:
        self._make_factory = make_factory

    def __call__(
        self, schema: Schema | None, channel: Channel, payloads: Sequence[bytes]
    ) -> Decoded:
        factory = self._make_factory()
        # mcap_ros2's vendored schema parser prints the offending schema line (bytes from the
        # log) to stderr before raising: kept off the terminal; the raised error says it
        with contextlib.redirect_stderr(io.StringIO()):
            try:
                decode = factory.decoder_for(channel.message_encoding, schema)
            except Exception as err:  # a schema the support package cannot parse
                raise ValueError(
                    f"its schema does not parse ({type(err).__name__}: {err})"
                ) from err
            if decode is None:
                enc = schema.encoding if schema is not None else "(no schema)"
                raise ValueError(f"no decoder for schema encoding {enc!r}")
            return _decode_each(payloads, decode)


def _ros2_factory() -> Any:
    from mcap_ros2.decoder import DecoderFactory

    return DecoderFactory()


def _ros1_factory() -> Any:
    from mcap_ros1.decoder import DecoderFactory

    return DecoderFactory()


def _protobuf_factory() -> Any:
    from mcap_protobuf.decoder import DecoderFactory

    return DecoderFactory()


decode_cdr_each: MessageDecoder = _FactoryDecoder(_ros2_factory)
"""ROS 2 message by message (mcap_ros2): the fallback of :func:`decode_cdr`."""


def decode_cdr(schema: Schema | None, channel: Channel, payloads: Sequence[bytes]) -> Decoded:
    """ROS 2: fixed-layout messages in bulk (``cdr_bulk``), anything else message by message."""
    from logtools.readers.cdr_bulk import decode_cdr_bulk

    frame = decode_cdr_bulk(schema, channel.message_encoding, payloads)
    return Decoded(frame) if frame is not None else decode_cdr_each(schema, channel, payloads)


DEFAULT_DECODERS: Decoders = MappingProxyType(
    {
        "json": decode_json,
        "cdr": decode_cdr,
        "ros1": _FactoryDecoder(_ros1_factory),
        "protobuf": _FactoryDecoder(_protobuf_factory),
    }
)
"""The decoders ``read_log`` uses unless given others: JSON, ROS 2 (cdr), ROS 1 and protobuf.
Add one with ``read_log(path, decoders={**DEFAULT_DECODERS, "cbor": my_decoder})``."""
