"""Bulk decoding of fixed-layout ROS 2 (CDR) messages: all payloads of one channel -> one frame.

Why hand-written: ``mcap_ros2`` decodes message by message in Python (about 20 k msg/s and a
Python object per message: 45 s and 3.5 GB for a 1 M-message drive log), and rerun's fast Rust
MCAP reader may not be used here (only ``viz`` imports rerun) and has no salvage of damaged files.
Drive logs are dominated by a few message types whose layout barely changes from one message to
the next (``std_msgs/Float64``, ``geometry_msgs/Twist[Stamped]``, ``PoseStamped``,
``nav_msgs/Odometry``, ``sensor_msgs/JointState``). So the channel's ``ros2msg`` schema is compiled
into a flat field list, one pass over that list computes every message's field offsets at once
(numpy arrays over messages, a plain int while all messages agree; CDR alignment is relative to
the byte after the 4-byte encapsulation header; strings such as ``frame_id`` and sequences move
the offsets of what follows), and numpy gathers each field from the payloads.

The frame is the one the per-message path builds (``mcap_ros2`` + ``flatten_object`` +
``frame_from_rows``): same columns in the same order (array items as ``name.0``; a column that
first appears in a later message comes after the earlier ones), dtypes, values and nulls.
Whenever a schema or a payload falls outside what is handled here (big-endian or XCDR
encapsulation, byte arrays, arrays of messages, bounded types, a length that runs past a payload,
invalid UTF-8, ...), :func:`decode_cdr_bulk` returns None and the caller decodes the channel
message by message, which drops and reports the bad messages.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import polars as pl
from mcap.records import Schema

from logtools.readers.base import DROPPED_COLUMNS
from logtools.readers.mcap_scan import Payloads

__all__ = ["decode_cdr_bulk", "max_array_items"]

_MAX_ARRAY_ITEMS = 256  # decoders.MAX_ARRAY_ITEMS (not imported: decoders imports this module)
_MAX_STRING_ITEMS = 4096  # longer string sequences go message by message
_MAX_STRING_LENGTHS = 64  # more distinct string lengths in one field: per-message str decode
_BLOCK_BYTES = 1 << 22  # messages copied at a time to read fixed-offset fields (4 MiB)

_NAME = re.compile(r"^(?!.*__)(?!.*_$)[a-z][a-z0-9_]*$")  # rosidl's package/field name pattern
_MSG_NAME = re.compile(r"^[A-Z][A-Za-z0-9]*$")
_CONSTANT = re.compile(r"^[A-Z]([A-Z0-9_]?[A-Z0-9]+)*$")
_SEPARATOR = re.compile(r"^={3,}$", re.MULTILINE)
_MSG_LINE = re.compile(r"^MSG:\s+(\S+)$", re.MULTILINE)

# primitive -> (numpy dtype little-endian, size); bool is read as uint8 != 0, char as int8
_PRIMITIVES: dict[str, tuple[str, int]] = {
    "bool": ("u1", 1),
    "byte": ("u1", 1),
    "char": ("i1", 1),
    "int8": ("i1", 1),
    "uint8": ("u1", 1),
    "int16": ("<i2", 2),
    "uint16": ("<u2", 2),
    "int32": ("<i4", 4),
    "uint32": ("<u4", 4),
    "int64": ("<i8", 8),
    "uint64": ("<u8", 8),
    "float32": ("<f4", 4),
    "float64": ("<f8", 8),
}
# builtin_interfaces Time/Duration as mcap_ros2 predefines them (schema text may override them)
_PREDEFINED = {
    "builtin_interfaces/Time": [("uint32", "sec")],
    "builtin_interfaces/Duration": [("uint32", "sec")],
}
for _fields in _PREDEFINED.values():
    _fields.append(("uint32", "nanosec"))


def max_array_items() -> int:
    """Array items kept as columns (the same cap as ``decoders.MAX_ARRAY_ITEMS``)."""
    return _MAX_ARRAY_ITEMS


class _UnsupportedError(Exception):
    """This schema or these payloads are not for the bulk path."""


@dataclass(frozen=True)
class _Field:
    """One leaf field: its flattened path, element type and array shape."""

    path: str
    kind: str  # a primitive name or "string"
    array: int | None = None  # None: scalar; 0: unbounded sequence; N: fixed array of N


# ---------------------------------------------------------------- schema -> field list


def _parse_section(text: str) -> list[tuple[str, str]] | None:
    """(type string, field name) of one message definition, None when outside the subset."""
    fields: list[tuple[str, str]] = []
    for raw in text.replace("\t", " ").splitlines():
        line = raw.rstrip()
        cut = line.find("#")
        if cut >= 0:
            line = line[:cut]
        if not line.strip():
            continue
        type_string, _, rest = line.partition(" ")
        rest = rest.lstrip()
        if not type_string or not rest or '"' in rest or "'" in rest:
            return None
        if "=" in rest:  # a constant
            name, _, value = rest.partition("=")
            if not _CONSTANT.match(name.rstrip()) or not _plain_value(type_string, value.strip()):
                return None
            continue
        name, _, default = rest.partition(" ")
        if not _NAME.match(name) or any(name == f[1] for f in fields):
            return None
        if default.strip() and not _plain_value(type_string, default.strip()):
            return None
        fields.append((type_string, name))
    return fields


def _plain_value(type_string: str, text: str) -> bool:
    """A numeric default or constant value the rosidl parser surely accepts; others: not bulk."""
    kind = _PRIMITIVES.get(type_string)
    if kind is None or type_string == "bool":
        return False
    try:
        int(text) if kind[0][-2] in "iu" else float(text)
    except ValueError:
        return False
    return True


def _sections(schema_name: str, text: str) -> dict[str, list[tuple[str, str]]] | None:
    """Message definitions of a ``ros2msg`` schema by ``pkg/Name``, as mcap_ros2 splits them."""
    defs: dict[str, list[tuple[str, str]]] = {k: list(v) for k, v in _PREDEFINED.items()}
    text = "\n".join(s for s in text.splitlines() if s.strip())
    name = schema_name
    first: str | None = None
    for part in _SEPARATOR.split(text):
        part = part.strip()
        match = _MSG_LINE.match(part)
        if match:
            name = match.group(1)
            part = _MSG_LINE.sub("", part)
        pkg, msg = name.split("/")[0], name.split("/")[-1]
        if not _NAME.match(pkg) or not _MSG_NAME.match(msg):
            return None
        fields = _parse_section(part)
        if fields is None:
            return None
        short = f"{pkg}/{msg}"
        defs[short] = [(_qualify(t, pkg), n) for t, n in fields]
        first = first or short
    if first is None or first != _short(schema_name):
        return None
    defs[""] = defs[first]
    return defs


def _short(name: str) -> str:
    return f"{name.split('/')[0]}/{name.split('/')[-1]}"


def _qualify(type_string: str, pkg: str) -> str:
    """A nested message type's ``pkg/Name`` (an unqualified name is in the enclosing package)."""
    base, bracket, dims = type_string.partition("[")
    if base in _PRIMITIVES or base == "string" or "/" in base:
        return type_string
    return f"{pkg}/{base}{bracket}{dims}"


def _flatten(
    defs: dict[str, list[tuple[str, str]]], key: str, prefix: str, depth: int
) -> list[_Field]:
    fields = defs.get(key)
    if not fields or depth > 16:  # an empty message reads one byte and flattens to its repr
        raise _UnsupportedError
    out: list[_Field] = []
    for type_string, name in fields:
        path = f"{prefix}.{name}" if prefix else name
        base, array = _array_shape(type_string)
        if base in _PRIMITIVES or base == "string":
            if array is not None and base in ("uint8", "byte"):
                raise _UnsupportedError  # read as bytes, one binary column
            out.append(_Field(path, base, array))
        elif array is None and "/" in base and "<" not in base:
            parts = base.split("/")
            if len(parts) != 2 or not _NAME.match(parts[0]) or not _MSG_NAME.match(parts[1]):
                raise _UnsupportedError
            out += _flatten(defs, base, path, depth + 1)
        else:
            raise _UnsupportedError  # arrays of messages, bounded strings, wstring, ...
    return out


def _array_shape(type_string: str) -> tuple[str, int | None]:
    if not type_string.endswith("]"):
        return type_string, None
    base, _, dims = type_string[:-1].partition("[")
    if dims == "":
        return base, 0
    if not dims.isdigit() or int(dims) <= 0:
        raise _UnsupportedError  # bounded (<=N) arrays
    return base, int(dims)


def _compile(schema: Schema) -> list[_Field]:
    try:
        text = schema.data.decode()
    except UnicodeDecodeError as err:
        raise _UnsupportedError from err
    defs = _sections(schema.name, text)
    if defs is None:
        raise _UnsupportedError
    return _flatten(defs, "", "", 0)


# ---------------------------------------------------------------- payloads -> columns

Offset = int | np.ndarray


@dataclass
class _Column:
    name: str
    values: np.ndarray | pl.Series
    first_row: int = 0
    present: np.ndarray | None = None  # rows holding a value; None: all


class _Payloads:
    """The channel's payloads: starts into the buffer the scan left them in, and lengths.

    Fields at the same offset in every message are read block by block (:meth:`column`, then
    :meth:`fill`): the block's messages up to the last such field are copied into one small
    reused (messages x width) array and each column is a strided copy out of it. Fields whose
    offset differs between messages, and lengths and counts, are gathered at once (:meth:`read`).
    """

    def __init__(self, payloads: Sequence[bytes]) -> None:
        data = payloads if isinstance(payloads, Payloads) else Payloads.from_bytes(payloads)
        self.n = len(data)
        self.lens = data.lengths
        self.min_len = int(self.lens.min())
        self.flat = data.buffer
        self.starts = data.starts
        self.pending: list[tuple[int, str, np.ndarray]] = []

    def check(self, end: Offset, sel: np.ndarray | None = None) -> None:
        """Raise unless every selected message holds at least ``end`` bytes."""
        lens = self.lens if sel is None else self.lens[sel]
        if isinstance(end, np.ndarray):
            if end.size and bool(np.any(end > lens)):
                raise _UnsupportedError
        elif lens.size and end > (self.min_len if sel is None else int(lens.min())):
            raise _UnsupportedError

    def read(self, at: Offset, dtype: str, size: int, sel: np.ndarray | None = None) -> np.ndarray:
        """Values of ``dtype`` at offset ``at`` (int or per selected message) of each message."""
        self.check(at + size, sel)
        starts = self.starts if sel is None else self.starts[sel]
        view = np.ndarray((len(self.flat) - size + 1,), dtype, self.flat, strides=(1,))
        return view[starts + at]

    def column(self, at: int, kind: str) -> np.ndarray:
        """The ``kind`` field at ``at`` in every message: an array :meth:`fill` fills in."""
        dtype, size = _PRIMITIVES[kind]
        self.check(at + size)
        out: np.ndarray = np.empty(self.n, dtype=_column_dtype(kind))
        self.pending.append((at, dtype, out))
        return out

    def fill(self) -> None:
        """Fill the arrays :meth:`column` handed out."""
        if not self.pending:
            return
        width = max(at + np.dtype(dtype).itemsize for at, dtype, _ in self.pending)
        rows_view = np.ndarray((len(self.flat) - width + 1,), f"V{width}", self.flat, strides=(1,))
        block = max(1, _BLOCK_BYTES // width)
        for first in range(0, self.n, block):
            rows = rows_view[self.starts[first : first + block]]  # (k,) records of width bytes
            k = len(rows)
            for at, dtype, out in self.pending:
                src = np.ndarray((k,), dtype, rows, offset=at, strides=(width,))
                if out.dtype == np.bool_:
                    np.not_equal(src, 0, out=out[first : first + k])
                else:
                    out[first : first + k] = src
        self.pending.clear()

    def strings(self, at: Offset, length: np.ndarray, sel: np.ndarray | None) -> pl.Series:
        """The strings of ``length - 1`` bytes at ``at`` (empty when ``length`` <= 1)."""
        starts = self.starts if sel is None else self.starts[sel]
        pos = starts + at
        count = len(length)
        nbytes = np.maximum(length - 1, 0)
        distinct = np.unique(nbytes)
        if len(distinct) > _MAX_STRING_LENGTHS:
            out = [
                _utf8(self.flat[p : p + k].tobytes())
                for p, k in zip(pos.tolist(), nbytes.tolist(), strict=True)
            ]
            return pl.Series(out, dtype=pl.String)
        values = np.empty(count, dtype=object)
        constant: str | None = None
        for k in distinct.tolist():
            idx = np.flatnonzero(nbytes == k)
            if k == 0:
                values[idx] = constant = ""
                continue
            block = self.flat[pos[idx][:, None] + np.arange(k)]
            if bool(np.all(block == block[0])):
                values[idx] = constant = _utf8(block[0].tobytes())
                continue
            constant = None
            keys = np.ascontiguousarray(block).view(f"V{k}").reshape(-1)
            uniq, inverse = np.unique(keys, return_inverse=True)
            decoded = np.array([_utf8(u.tobytes()) for u in uniq], dtype=object)
            values[idx] = decoded[inverse.reshape(-1)]
        if len(distinct) == 1 and constant is not None:
            return pl.repeat(constant, count, eager=True, dtype=pl.String)
        return pl.Series(values.tolist(), dtype=pl.String)


def _column_dtype(kind: str) -> type:
    """The dtype a field's column is built with (the per-message path's: int64, float64, bool;
    uint64 stays unsigned until :func:`_series` sees whether it fits int64)."""
    if kind == "bool":
        return np.bool_
    if kind.startswith("float"):
        return np.float64
    return np.uint64 if kind == "uint64" else np.int64


def _utf8(raw: bytes) -> str:
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as err:
        raise _UnsupportedError from err


def _align(at: Offset, size: int) -> Offset:
    if size <= 1:
        return at
    return at + (-(at - 4)) % size


def _narrow(at: Offset) -> Offset:
    """An offset array on which all messages agree becomes an int again."""
    if isinstance(at, np.ndarray) and at.size and bool(np.all(at == at[0])):
        return int(at[0])
    return at


def _scalar(
    data: _Payloads, at: Offset, kind: str, sel: np.ndarray | None
) -> tuple[np.ndarray, Offset]:
    dtype, size = _PRIMITIVES[kind]
    at = _align(at, size)
    if sel is None and not isinstance(at, np.ndarray):
        return data.column(at, kind), at + size
    values = data.read(at, dtype, size, sel)
    if kind == "bool":
        values = values != 0
    return values, at + size


def _string(data: _Payloads, at: Offset, sel: np.ndarray | None) -> tuple[pl.Series, Offset]:
    at = _align(at, 4)
    length = data.read(at, "<u4", 4, sel).astype(np.int64)
    end = at + 4 + length
    data.check(end, sel)
    return data.strings(at + 4, length, sel), _narrow(end)


def _decode_fields(data: _Payloads, fields: list[_Field]) -> list[_Column]:
    columns: list[_Column] = []
    at: Offset = 4
    for f in fields:
        if f.array is None:
            values: np.ndarray | pl.Series
            if f.kind == "string":
                values, at = _string(data, at, None)
            else:
                values, at = _scalar(data, at, f.kind, None)
            columns.append(_Column(f.path, values))
        elif f.kind == "string":
            at = _string_array(data, at, f, columns)
        else:
            at = _numeric_array(data, at, f, columns)
    return columns


def _count(data: _Payloads, at: Offset, f: _Field) -> tuple[np.ndarray, Offset]:
    if f.array:
        return np.full(data.n, f.array, dtype=np.int64), at
    at = _align(at, 4)
    return data.read(at, "<u4", 4).astype(np.int64), at + 4


def _numeric_array(data: _Payloads, at: Offset, f: _Field, columns: list[_Column]) -> Offset:
    size = _PRIMITIVES[f.kind][1]
    count, at = _count(data, at, f)
    first = _align(at, size)
    if not bool(np.all(count > 0)) and (isinstance(first, np.ndarray) or first != at):
        first = np.where(count > 0, first, at)  # an empty sequence is not aligned
    end = first + count * size
    data.check(end)
    dropped = DROPPED_COLUMNS.get()  # items the reader drops are not built at all
    for i in range(min(int(count.max(initial=0)), _MAX_ARRAY_ITEMS)):
        if dropped is not None and dropped(f"{f.path}.{i}"):
            continue
        present = count > i
        sel = None if bool(present.all()) else np.flatnonzero(present)
        base = first[sel] if sel is not None and isinstance(first, np.ndarray) else first
        values, _ = _scalar(data, _narrow(base + i * size), f.kind, sel)
        columns.append(_column(f"{f.path}.{i}", values, present, sel))
    return _narrow(end)


def _string_array(data: _Payloads, at: Offset, f: _Field, columns: list[_Column]) -> Offset:
    count, at = _count(data, at, f)
    data.check(at + 4 * count)  # every string takes at least its 4-byte length
    longest = int(count.max(initial=0))
    if longest > _MAX_STRING_ITEMS:
        raise _UnsupportedError
    pos = np.broadcast_to(np.asarray(at, dtype=np.int64), (data.n,)).copy()
    for i in range(longest):
        present = count > i
        sel = None if bool(present.all()) else np.flatnonzero(present)
        here = _narrow(pos) if sel is None else pos[sel]
        values, end = _string(data, here, sel)
        if sel is None:
            pos[:] = end
        else:
            pos[sel] = end
        if i < _MAX_ARRAY_ITEMS:
            columns.append(_column(f"{f.path}.{i}", values, present, sel))
    return _narrow(pos)


def _column(
    name: str, values: np.ndarray | pl.Series, present: np.ndarray, sel: np.ndarray | None
) -> _Column:
    if sel is None:
        return _Column(name, values)
    return _Column(name, values, int(sel[0]), present)


def _series(col: _Column, n: int) -> pl.Series:
    values = col.values
    if isinstance(values, pl.Series):
        series = values.alias(col.name)
    else:
        if values.dtype.kind == "u" and values.dtype.itemsize == 8:
            big = bool(np.any(values >= 2**63))
            series = (
                pl.Series(col.name, values)
                if big
                else pl.Series(col.name, values.astype(np.int64, copy=False))
            )
        elif values.dtype.kind in "iu":
            series = pl.Series(col.name, values.astype(np.int64, copy=False))
        elif values.dtype.kind == "f":
            series = pl.Series(col.name, values.astype(np.float64, copy=False))
        else:
            series = pl.Series(col.name, values)
    if col.present is None:
        return series
    idx = np.zeros(n, dtype=np.int64)
    idx[col.present] = np.arange(len(series))
    full = series.gather(idx)
    return pl.select(pl.when(pl.Series(col.present)).then(full)).to_series().alias(col.name)


def decode_cdr_bulk(
    schema: Schema | None, message_encoding: str, payloads: Sequence[bytes]
) -> pl.DataFrame | None:
    """Decode one channel's CDR payloads in bulk, or return None to have them decoded one by one.

    Args:
        schema: the channel's schema (``ros2msg`` text).
        message_encoding: the channel's message encoding (``cdr``).
        payloads: the channel's raw messages.

    Returns:
        The frame the per-message path would build, or None when the schema or any payload is
        outside the bulk subset (see the module docstring).
    """
    if (
        message_encoding != "cdr"
        or schema is None
        or schema.encoding != "ros2msg"
        or not len(payloads)
    ):
        return None
    try:
        fields = _compile(schema)
        data = _Payloads(payloads)
        if data.min_len < 4 or bool(np.any(data.flat[data.starts + 1] != 1)):
            return None  # big-endian or parameter-list (XCDR) encapsulation
        columns = _decode_fields(data, fields)
        data.fill()
    except _UnsupportedError:
        return None
    if not columns:
        return pl.DataFrame()
    order = sorted(range(len(columns)), key=lambda k: (columns[k].first_row, k))
    return pl.DataFrame([_series(columns[k], data.n) for k in order])
