"""JSON channels whose messages all share one structure, decoded by one compiled pass.

Most JSON channels of a drive log carry the same object in every message with only the numbers
changing (``{"v": 1.02, "omega": -0.17}``). For those, the first message gives a skeleton: its
tokens cut at its numbers (whitespace outside strings removed). One C pass (``_flat_json.c``,
built by ``pip install`` as an extension module and called through ctypes) walks every message
against it in place in the scan's buffer, requiring every other token to match (keys, constant
strings byte for byte, true/false/null, the nesting; whitespace free between tokens) and
parsing each number into its column, correctly rounded (``float(text)``'s value). A channel
where any message differs (a renamed key, a number that turns into a string, a varying string,
invalid JSON, an integer beyond int64) gives ``None`` and is decoded by the general route
(polars' NDJSON reader, :func:`~logtools.readers.decoders.decode_json_ndjson`), so the frames
never depend on which route ran: same column names and order (``flatten_frame``'s), same
dtypes (Int64 where every value of a column, or of a whole numeric array, was written as an
integer; else Float64; constant strings, booleans and nulls as String, Boolean, Null columns;
with a NaN or Infinity anywhere, polars raises and the route decodes message by message,
typing each column on its own, which is reproduced too).

Why hand-written: polars' NDJSON reader needs the payloads laid out as lines (two copies of the
bytes, plus a count of key tokens to infer the schema safely) and parses on threads that share
the box's two cores; ``json.loads`` costs ~1.7 us per message. No library walks ``(buffer,
starts, lengths)`` views without first copying them into one document. Measured on the
1 M-message tractor-trailer JSON log of ``bench/bench_ingest.py`` (5 channels, numbers of 16-20
digits; CPU s, best of 3, imports outside the timing): decoding the channels 0.27 s -> 0.04 s;
``read_log`` 0.47 s -> 0.22 s against 0.40 s for rerun's ``McapReader``; peak RSS 275 -> 222
MB. The walk is bound by memory latency more than by parsing (a channel's messages lie among
the other channels' in the chunks), hence the prefetch in the C loop.

When the extension is not built (a source checkout never installed), :func:`decode_uniform`
returns ``None`` and every channel takes the general route.
"""

from __future__ import annotations

import ctypes
import json
import re
from functools import cache
from typing import Any

import numpy as np
import polars as pl

from calib._compiled import INT64S, UINT8S, load_library
from logtools.readers.flatten import MAX_ARRAY_ITEMS, MAX_COLUMNS, flatten_object
from logtools.readers.mcap_scan import Payloads

__all__ = ["compiled_available", "decode_uniform", "parse_number"]

_U8 = UINT8S
_I64 = INT64S

# number kinds of _flat_json.c
_NUM_BAD, _NUM_INT, _NUM_FLOAT, _NUM_NONFINITE, _NUM_BIGINT = range(5)


@cache
def _library() -> ctypes.CDLL | None:
    """The compiled walk, or None when the extension was not built."""
    lib = load_library("logtools.readers._flat_json")
    if lib is None:
        return None
    i64 = ctypes.c_int64
    lib.logcal_flat_json.restype = i64
    lib.logcal_flat_json.argtypes = [
        _U8, i64, _I64, _I64, i64, i64, ctypes.c_char_p, _I64, ctypes.c_char_p, _I64,
        _I64, ctypes.c_void_p, _U8, _U8,
    ]  # fmt: skip
    lib.logcal_json_number.restype = ctypes.c_int
    lib.logcal_json_number.argtypes = [
        ctypes.c_char_p, i64, ctypes.POINTER(i64), ctypes.POINTER(ctypes.c_double),
    ]  # fmt: skip
    return lib


def compiled_available() -> bool:
    """Whether the compiled walk was built (``pip install`` builds it)."""
    return _library() is not None


def parse_number(text: bytes) -> int | float | None:
    """One JSON number token as the compiled walk reads it (``int`` when written as an integer
    that fits int64, else ``float``; NaN and +-Infinity as ``json.loads`` accepts them);
    ``None`` when it is not a JSON number or the walk would not take it. Raises RuntimeError
    when the extension is not built. For the tests."""
    lib = _library()
    if lib is None:
        raise RuntimeError("logtools.readers._flat_json is not built (pip install)")
    iv, dv = ctypes.c_int64(), ctypes.c_double()
    kind = lib.logcal_json_number(text, len(text), ctypes.byref(iv), ctypes.byref(dv))
    if kind == _NUM_INT:
        return iv.value
    if kind in (_NUM_FLOAT, _NUM_NONFINITE):
        return dv.value
    return None


class _UnsupportedError(Exception):
    """A first message outside what the compiled walk reproduces exactly."""


# One JSON token of a valid document: whitespace, a string, a number (NaN/Infinity as
# json.loads accepts them), or one byte of punctuation or of a literal.
_TOKEN = re.compile(
    rb'(?P<space>[ \t\n\r]+)|(?P<string>"(?:[^"\\]|\\.)*")'
    rb"|(?P<number>-?(?:Infinity|(?:0|[1-9][0-9]*)(?:\.[0-9]+)?(?:[eE][+-]?[0-9]+)?)|NaN)"
    rb"|(?P<other>.)",
    re.DOTALL,
)


class _Skeleton:
    """The first message cut at its numbers: ``tokens`` (whitespace outside strings removed)
    and ``verbatim`` (as written) segments, one more than ``numbers``, as concatenated bytes
    and the end offset of each segment."""

    __slots__ = ("numbers", "tokens", "tokens_end", "verbatim", "verbatim_end")

    def __init__(self, first: bytes) -> None:
        tokens: list[list[bytes]] = [[]]
        verbatim: list[list[bytes]] = [[]]
        for match in _TOKEN.finditer(first):
            kind = match.lastgroup
            if kind == "number":
                tokens.append([])
                verbatim.append([])
                continue
            verbatim[-1].append(match.group())
            if kind != "space":
                tokens[-1].append(match.group())
        self.numbers = len(tokens) - 1
        self.tokens, self.tokens_end = _joined([b"".join(t) for t in tokens])
        self.verbatim, self.verbatim_end = _joined([b"".join(v) for v in verbatim])


def _joined(segments: list[bytes]) -> tuple[bytes, np.ndarray]:
    ends = np.cumsum([len(seg) for seg in segments], dtype=np.int64)
    return b"".join(segments), ends


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    keys = [k for k, _ in pairs]
    if len(set(keys)) != len(keys):  # polars keeps the first, json.loads the last
        raise _UnsupportedError("a key twice in one object")
    return dict(pairs)


class _Leaf:
    """One value of the first message, in document order."""

    __slots__ = ("group", "name", "number", "value")

    def __init__(self, name: str | None, value: Any, number: bool, group: int) -> None:
        self.name = name  # None: an array item beyond MAX_ARRAY_ITEMS (no column)
        self.value = value
        self.number = number
        self.group = group  # numbers of one array share a dtype (one polars list column)


def _leaves(obj: Any, prefix: str, out: list[_Leaf]) -> None:
    if isinstance(obj, dict):
        if not obj:
            raise _UnsupportedError("an empty object")
        for key, value in obj.items():
            _leaves(value, f"{prefix}.{key}" if prefix else key, out)
    elif isinstance(obj, list):
        if not obj or not all(_is_number(v) for v in obj):
            raise _UnsupportedError("an array that is empty or not all numbers")
        group = len(out)
        for i, value in enumerate(obj):
            name = f"{prefix}.{i}" if i < MAX_ARRAY_ITEMS else None
            out.append(_Leaf(name, value, True, group))
    elif _is_number(obj):
        out.append(_Leaf(prefix, obj, True, len(out)))
    elif isinstance(obj, str):
        try:
            obj.encode("utf-8")
        except UnicodeEncodeError as err:  # a lone surrogate (\ud800): no polars string
            raise _UnsupportedError("a string that is not valid Unicode") from err
        out.append(_Leaf(prefix, obj, False, len(out)))
    elif obj is None or isinstance(obj, bool):
        out.append(_Leaf(prefix, obj, False, len(out)))
    else:  # pragma: no cover - json.loads gives no other types
        raise _UnsupportedError(type(obj).__name__)


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


_CONSTANT_DTYPE: dict[type, pl.DataType] = {str: pl.String(), bool: pl.Boolean()}


def _plan(first: bytes) -> tuple[_Skeleton, list[_Leaf]]:
    """Skeleton and leaves of the first message; raises _UnsupportedError."""
    try:
        obj = json.loads(first.decode("utf-8"), object_pairs_hook=_unique_keys)
    except (UnicodeDecodeError, ValueError) as err:
        raise _UnsupportedError(str(err)) from err
    if not isinstance(obj, dict):
        raise _UnsupportedError("not an object")
    leaves: list[_Leaf] = []
    _leaves(obj, "", leaves)
    skeleton = _Skeleton(first)
    if skeleton.numbers != sum(leaf.number for leaf in leaves):
        raise _UnsupportedError("numbers of the text and of the object differ")
    names = [leaf.name for leaf in leaves if leaf.name is not None]
    if len(names) > MAX_COLUMNS:  # the general route drops the columns beyond, and says so
        raise _UnsupportedError(f"more than {MAX_COLUMNS} columns")
    if len(set(names)) != len(names) or names != list(flatten_object(obj)):
        raise _UnsupportedError("flattened names differ from flatten_object's or repeat")
    return skeleton, leaves


def decode_uniform(payloads: Payloads) -> pl.DataFrame | None:
    """The channel's frame when every message has the first one's structure (the same frame
    polars' NDJSON route gives); ``None`` when one differs or the extension is not built."""
    lib = _library()
    n = len(payloads)
    if lib is None or n == 0:
        return None
    try:
        skeleton, leaves = _plan(payloads[0])
    except (_UnsupportedError, RecursionError):
        return None
    numbers = [leaf for leaf in leaves if leaf.number]
    kept = [leaf for leaf in numbers if leaf.name is not None]
    column = np.full(len(numbers), -1, dtype=np.int64)
    column[[i for i, leaf in enumerate(numbers) if leaf.name is not None]] = np.arange(len(kept))
    out = np.empty((len(kept), n), dtype=np.int64)
    isint = np.ones(len(numbers), dtype=np.uint8)
    nonfinite = np.zeros(len(numbers), dtype=np.uint8)
    buffer = np.ascontiguousarray(payloads.buffer, dtype=np.uint8)
    starts = np.ascontiguousarray(payloads.starts, dtype=np.int64)
    lengths = np.ascontiguousarray(payloads.lengths, dtype=np.int64)
    matched = lib.logcal_flat_json(
        buffer, len(buffer), starts, lengths, n, skeleton.numbers,
        skeleton.tokens, skeleton.tokens_end, skeleton.verbatim, skeleton.verbatim_end,
        column, out.ctypes.data, isint, nonfinite,
    )  # fmt: skip
    if matched != n:
        return None
    # polars' NDJSON reader types a numeric array as one list column (Float64 if any item of
    # any message was not an integer); when a value is NaN or +-Infinity it raises and the
    # channel is decoded message by message, each column typed on its own.
    whole_float = {leaf.group for leaf, i in zip(numbers, isint.tolist(), strict=True) if not i}
    per_column = bool(nonfinite.any())
    series: list[pl.Series] = []
    j = 0  # index among the numbers
    for leaf in leaves:
        if not leaf.number:
            dtype = _CONSTANT_DTYPE.get(type(leaf.value), pl.Null())
            series.append(pl.Series(leaf.name, [leaf.value], dtype=dtype).new_from_index(0, n))
            continue
        j += 1
        if leaf.name is None:
            continue
        values = out[int(column[j - 1])]
        if not isint[j - 1]:
            values = values.view(np.float64)
        elif not per_column and leaf.group in whole_float:
            values = values.astype(np.float64)
        series.append(pl.Series(leaf.name, values))
    return pl.DataFrame(series)
