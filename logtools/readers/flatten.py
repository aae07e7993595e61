"""Flattening of one decoded message (a ROS 1/2 object, a protobuf message, a dict) into
columns named by field path, shared by the per-message decoders and the compiled JSON walk."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

__all__ = ["MAX_ARRAY_ITEMS", "MAX_COLUMNS", "flatten_object"]

MAX_ARRAY_ITEMS = 256
"""Arrays longer than this keep only their first MAX_ARRAY_ITEMS entries as numbered columns."""
MAX_COLUMNS = 4096
"""Most columns one channel is decoded into (a TFMessage of 256 transforms has ~3,300); the
rest are dropped and counted (``Decoded.dropped_columns``)."""


def flatten_object(obj: Any, prefix: str = "", out: dict[str, Any] | None = None) -> dict[str, Any]:
    """Flatten a decoded message (ROS 1/2 object, protobuf message, dict, list) by field path."""
    out = {} if out is None else out
    if obj is None or isinstance(obj, (bool, int, float, str)):
        out.setdefault(prefix or "value", obj)  # a name made twice ("a.b" and a: {b}): first
    elif isinstance(obj, (bytes, bytearray, memoryview)):
        out.setdefault(prefix or "value", bytes(obj))
    elif isinstance(obj, Mapping):
        for key, value in obj.items():
            flatten_object(value, _join(prefix, str(key)), out)
    elif hasattr(obj, "DESCRIPTOR") and hasattr(obj, "ListFields"):  # protobuf message
        for fd in obj.DESCRIPTOR.fields:
            flatten_object(getattr(obj, fd.name), _join(prefix, fd.name), out)
    elif _is_sequence(obj):
        for i, value in enumerate(obj):
            if i >= MAX_ARRAY_ITEMS:
                break
            flatten_object(value, _join(prefix, str(i)), out)
    else:
        slots = _slots(type(obj))
        if slots:
            for name in slots:
                flatten_object(getattr(obj, name, None), _join(prefix, name), out)
        else:
            out.setdefault(prefix or "value", str(obj))
    return out


def _join(prefix: str, name: str) -> str:
    return f"{prefix}.{name}" if prefix else name


def _is_sequence(obj: Any) -> bool:
    if isinstance(obj, Sequence):
        return True
    return hasattr(obj, "__len__") and hasattr(obj, "__getitem__") and not hasattr(obj, "keys")


_SLOTS_CACHE: dict[type, tuple[str, ...]] = {}


def _slots(cls: type) -> tuple[str, ...]:
    cached = _SLOTS_CACHE.get(cls)
    if cached is None:
        names: list[str] = []
        for klass in reversed(cls.__mro__):
            slots = klass.__dict__.get("__slots__", ())
            names += [slots] if isinstance(slots, str) else list(slots)
        cached = _SLOTS_CACHE[cls] = tuple(n for n in names if not n.startswith("_"))
    return cached
