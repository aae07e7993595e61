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
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from io import BytesIO
from types import MappingProxyType
from typing import Any, Protocol

import numpy as np
import polars as pl
from mcap.records import Channel, Schema

from logtools.readers.flatten import MAX_ARRAY_ITEMS, flatten_object
from logtools.readers.mcap_scan import Payloads

__all__ = [
    "DEFAULT_DECODERS",
    "MAX_ARRAY_ITEMS",
    "Decoded",
    "Decoders",
    "MessageDecoder",
    "decode_cdr",
    "decode_cdr_each",
    "decode_json",
    "decode_json_ndjson",
    "flatten_frame",
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
    """

    frame: pl.DataFrame
    kept: list[int] | None = None
    error: str | None = None


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


# ---------------------------------------------------------------- flattening


def flatten_frame(frame: pl.DataFrame) -> pl.DataFrame:
    """Flatten struct columns to ``parent.child`` and list columns to ``name.0``, ``name.1``, …"""
    while True:
        nested = [
            name
            for name, dtype in frame.schema.items()
            if isinstance(dtype, (pl.Struct, pl.List, pl.Array))
        ]
        if not nested:
            return frame
        exprs: list[pl.Expr] = []
        for name, dtype in frame.schema.items():
            if isinstance(dtype, pl.Struct):
                fields = pl.col(name).struct
                exprs += [fields.field(f.name).alias(f"{name}.{f.name}") for f in dtype.fields]
            elif isinstance(dtype, (pl.List, pl.Array)):
                col = pl.col(name) if isinstance(dtype, pl.List) else pl.col(name).arr.to_list()
                longest = frame.select(col.list.len().max()).item() or 0
                exprs += [
                    col.list.get(i, null_on_oob=True).alias(f"{name}.{i}")
                    for i in range(min(longest, MAX_ARRAY_ITEMS))
                ]
            else:
                exprs.append(pl.col(name))
        frame = frame.select(exprs)


def frame_from_rows(rows: list[dict[str, Any]]) -> pl.DataFrame:
    """Build a frame from flattened rows; fields missing from a row become null."""
    keys = dict.fromkeys(key for row in rows for key in row)
    return pl.DataFrame([pl.Series(k, [row.get(k) for row in rows], strict=False) for k in keys])


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
    """Decode JSON payloads in one go with polars' NDJSON reader; fall back per message."""
    if not len(payloads):
        return Decoded(pl.DataFrame())
    data = payloads if isinstance(payloads, Payloads) else Payloads.from_bytes(payloads)
    joined = _ndjson_lines(data)
    # Infer the schema from the first messages (fast) when every message has as many keys as
    # they do (a field that first appears later would be dropped silently by that schema);
    # otherwise from all of them. If a later message disagrees in type (an int field that turns
    # float), polars raises and the whole channel is inferred instead.
    first = _JSON_INFER_ROWS if _uniform_keys(joined, len(payloads)) else None
    for infer in dict.fromkeys((first, None)):
        try:
            frame = pl.read_ndjson(BytesIO(joined), infer_schema_length=infer)
        except Exception:  # polars raises ComputeError/SchemaError/...: try the next way
            continue
        if frame.height != len(payloads):
            break
        flat = flatten_frame(frame)
        if infer is not None and _null_after_head(flat):
            continue  # a field missing later (renamed?) where the first lines all had it
        return Decoded(flat)
    return _decode_each(payloads, _json_object)


def _null_after_head(frame: pl.DataFrame) -> bool:
    """Whether a column has nulls after the first ``_JSON_INFER_ROWS`` rows but none in them."""
    head = frame.head(_JSON_INFER_ROWS)
    return any(
        frame[c].null_count() > 0 and head[c].null_count() == 0 for c in frame.columns
    )


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


def _decode_each(payloads: Sequence[bytes], decode: Callable[[bytes], Any]) -> Decoded:
    """Decode message by message, dropping (and counting) those that fail."""
    rows: list[dict[str, Any]] = []
    kept: list[int] = []
    error: str | None = None
    for i, payload in enumerate(payloads):
        try:
            rows.append(flatten_object(decode(payload)))
        except Exception as err:  # any decoder failure drops just this message
            error = error or f"{type(err).__name__}: {err}"
            continue
        kept.append(i)
    return Decoded(frame_from_rows(rows), kept if len(kept) != len(payloads) else None, error)


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
