"""Taking one logical signal out of a log's frames: a topic's field (scaled, converted to SI,
transformed), its time (log or header stamp), the element of a ``TFMessage``-like array by its
child frame, and a ``JointState``-like array's element by joint name; default sources named
with a topic pattern (``*/odom``).
"""

from __future__ import annotations

import re
from dataclasses import replace
from typing import Any

import polars as pl

from logtools.channel_map.names import JOINT_TOPIC, signal_spec
from logtools.channel_map.transforms import TRANSFORMS
from logtools.errors import ChannelMapEntryError, LogcalInputError, UnknownEncodingError
from logtools.readers import TIME_COLUMN, LogData, ProblemKind, known_encodings
from logtools.signals import UNIT_FACTORS, SignalSource, Stamp

__all__ = [
    "extract_default",
    "extract_user",
    "signal_frame",
    "to_si",
    "topic_frame",
]


def _transform_columns(fld: str, src: SignalSource) -> list[str]:
    """The columns the source's transform reads under ``fld`` (the field itself without one)."""
    return TRANSFORMS[src.transform].columns(fld) if src.transform is not None else [fld]


def signal_frame(frame: pl.DataFrame, value: pl.Expr, time: pl.Expr | None = None) -> pl.DataFrame:
    """A signal's frame (``t_ns``, ``value``) from ``frame``: the value expression, at the log
    time or at ``time``."""
    t = pl.col(TIME_COLUMN) if time is None else time.alias(TIME_COLUMN)
    return frame.select(t, value.alias("value"))


def to_si(frame: pl.DataFrame, src: SignalSource) -> pl.DataFrame:
    """Apply scale, offset and unit: value = (value * scale + offset) * unit factor."""
    factor = UNIT_FACTORS[src.unit][1] if src.unit else 1.0
    if src.scale == 1.0 and src.offset == 0.0 and factor == 1.0:
        return frame
    value = pl.col("value").cast(pl.Float64)
    return frame.with_columns(((value * src.scale + src.offset) * factor).alias("value"))


def _where(src: SignalSource, name: str) -> tuple[str, str]:
    return src.origin or "", f"signals.{name}"


def extract_user(log: LogData, name: str, src: SignalSource) -> pl.DataFrame:
    """The signal a channel-map entry names.

    Raises:
        ChannelMapEntryError: the log lacks the entry's topic, field, frame or header stamp.
    """
    frame = topic_frame(log, src.topic)
    file, key = _where(src, name)
    if frame is None:
        raise ChannelMapEntryError(
            file,
            f"{key}.topic",
            f"names topic {src.topic!r}, which {log.path} does not have. Topics in the log: "
            f"{', '.join(log.topic_names()) or '(none)'}.",
        )
    got = _value_and_time(frame, name, src, log.path)
    if got is None:
        fields = ", ".join(c for c in frame.columns if c != TIME_COLUMN)
        need = src.field
        if src.transform is not None and len(read := _transform_columns(src.field, src)) > 1:
            need = read[0] + "".join("/." + c.rpartition(".")[2] for c in read[1:])
        if src.frame:
            need += f" of the element whose child_frame_id is {src.frame!r}"
        raise ChannelMapEntryError(
            file,
            f"{key}.frame" if src.frame else f"{key}.field",
            f"takes signal {name!r} from topic {src.topic!r} field {need!r}, which that topic "
            f"of {log.path} does not have. Its fields: {fields or '(none)'}.",
        )
    value, time = got
    return to_si(signal_frame(frame, value, time), src)


def _topic_pattern(log: LogData, src: SignalSource) -> SignalSource | None:
    """A default source whose topic starts with ``*`` (``*/odom``) names the first topic (in
    sorted order) ending with the rest; None when the log has none. Other sources as given."""
    if not src.topic.startswith("*"):
        return src
    suffix = src.topic[1:]
    found = sorted(t for t in log.info if t.endswith(suffix) and log.info[t].message_count)
    return replace(src, topic=found[0]) if found else None


def extract_default(
    log: LogData, name: str, src: SignalSource
) -> tuple[pl.DataFrame, SignalSource] | None:
    """The signal at a default source, with the source as found (a topic pattern resolved, a
    joint picked by name); None when the log does not have it."""
    pattern = _topic_pattern(log, src)
    if pattern is None:
        return None
    src = pattern
    frame = topic_frame(log, src.topic)
    if frame is None:
        return None
    words = _joint_words(frame, name)
    if src.topic == JOINT_TOPIC:  # joint states by joint name only, with every word
        if not words:
            return None
        value = _by_joint_name(frame, words[0], src.field, also=words[1:])
        if value is None:
            return None
        shown_words = ",".join((*words[1:], words[0]))
        shown = SignalSource(src.topic, f"{src.field.rsplit('.', 1)[0]}[name~{shown_words}]")
        return signal_frame(frame, value), shown
    got = _value_and_time(frame, name, src, log.path)
    if got is None:
        return None
    if words:
        src = SignalSource(src.topic, f"{src.field.rsplit('.', 1)[0]}[name~{words[0]}]")
    return to_si(signal_frame(frame, got[0], got[1]), src), src


def topic_frame(log: LogData, topic: str) -> pl.DataFrame | None:
    """The topic's frame; None if the log lacks it; raises if it is there but undecodable."""
    frame = log.topics.get(topic)
    info = log.info.get(topic)
    if frame is not None or info is None or not info.message_count:
        return frame
    mine = [p for p in log.problems if p.topic == topic]
    if any(p.kind is ProblemKind.UNKNOWN_ENCODING for p in mine):
        raise UnknownEncodingError(log.path, topic, info.message_encoding, known_encodings())
    why = " ".join(str(p) for p in mine)
    raise LogcalInputError(
        f"{log.path}: topic {topic!r} ({info.schema_name or 'no schema'}, "
        f"{info.message_encoding}) holds a signal logcal needs but could not be decoded. {why}"
    )


def _value_and_time(
    frame: pl.DataFrame, name: str, src: SignalSource, path: str
) -> tuple[pl.Expr, pl.Expr | None] | None:
    """(value, time or None for the log time) expressions of the signal; None if absent."""
    if src.frame is not None:
        return _by_child_frame(frame, src, path, name)
    value = _value_expr(frame, name, src)
    if value is None:
        return None
    if src.stamp is not Stamp.HEADER:
        return value, None
    stamp = _stamp_expr(frame, "")
    if stamp is None:
        file, key = _where(src, name)
        raise ChannelMapEntryError(
            file,
            f"{key}.stamp",
            f"is 'header', but topic {src.topic!r} of {path} has no header.stamp (sec and "
            "nanosec) field; use stamp = 'log'.",
        )
    _check_stamps(frame, stamp, src, name, path)
    return value, stamp


def _value_expr(frame: pl.DataFrame, name: str, src: SignalSource) -> pl.Expr | None:
    """The expression giving the signal's value from ``frame``, or None if the field is absent."""
    if src.transform is not None:
        if not all(c in frame.columns for c in _transform_columns(src.field, src)):
            return None
        return TRANSFORMS[src.transform].value(frame, src.field)
    words = _joint_words(frame, name)
    if words:
        return _by_joint_name(frame, words[0], src.field)
    if src.field not in frame.columns:
        return None
    return pl.col(src.field)


def _stamp_expr(frame: pl.DataFrame, prefix: str) -> pl.Expr | None:
    """``header.stamp`` as int64 ns (null where 0), under ``prefix`` (e.g. ``transforms.0.``)."""
    base = f"{prefix}header.stamp."
    sec = next((f"{base}{s}" for s in ("sec", "secs") if f"{base}{s}" in frame.columns), None)
    nsec = next(
        (f"{base}{s}" for s in ("nanosec", "nsec", "nsecs") if f"{base}{s}" in frame.columns), None
    )
    if sec is None or nsec is None:
        return None
    t = pl.col(sec).cast(pl.Int64) * 1_000_000_000 + pl.col(nsec).cast(pl.Int64)
    return pl.when(t > 0).then(t).otherwise(None)


def _check_stamps(
    frame: pl.DataFrame, stamp: pl.Expr, src: SignalSource, name: str, path: str
) -> None:
    if frame.height and frame.select(stamp.is_null().all()).item():
        file, key = _where(src, name)
        raise ChannelMapEntryError(
            file,
            f"{key}.stamp",
            f"is 'header', but every header stamp of topic {src.topic!r} in {path} is 0 (never "
            "set by the publisher); use stamp = 'log'.",
        )


def _by_child_frame(
    frame: pl.DataFrame, src: SignalSource, path: str, name: str
) -> tuple[pl.Expr, pl.Expr | None] | None:
    """Arrays of stamped transforms (TFMessage): per message, the element for ``src.frame``
    (also a message with a top-level ``child_frame_id``: Odometry, TransformStamped)."""
    pattern = re.compile(r"^(.*?)\.?(\d+)\.child_frame_id$")
    elements = []
    for col in frame.columns:
        m = pattern.match(col)
        if col == "child_frame_id":  # one stamped transform or odometry per message
            prefix = ""
        elif m is None:
            continue
        else:
            prefix = f"{m.group(1)}.{m.group(2)}." if m.group(1) else f"{m.group(2)}."
        fld = f"{prefix}{src.field}"
        if all(c in frame.columns for c in _transform_columns(fld, src)):
            elements.append((col, prefix, fld))
    if not elements:
        return None
    want = src.frame.lstrip("/") if src.frame else ""
    conds = [pl.col(c).cast(pl.String).str.strip_chars_start("/") == want for c, _, _ in elements]
    if not frame.select(pl.any_horizontal(conds).fill_null(False).any()).item():
        return None
    values = []
    stamps = []
    for _col, prefix, fld in elements:
        if src.transform is not None:
            values.append(TRANSFORMS[src.transform].value(frame, fld))
        else:
            values.append(pl.col(fld))
        if src.stamp is Stamp.HEADER:
            stamp = _stamp_expr(frame, prefix)
            if stamp is None:
                file, key = _where(src, name)
                raise ChannelMapEntryError(
                    file,
                    f"{key}.stamp",
                    f"is 'header', but the transforms of topic {src.topic!r} in {path} have no "
                    "header.stamp; use stamp = 'log'.",
                )
            stamps.append(stamp)
    value = _chain(conds, values)
    time = _chain(conds, stamps) if stamps else None
    if time is not None:
        _check_stamps(
            frame.filter(pl.any_horizontal(conds).fill_null(False)), time, src, name, path
        )
    return value, time


def _chain(conds: list[pl.Expr], values: list[pl.Expr]) -> pl.Expr:
    expr: Any = pl.when(conds[0]).then(values[0])
    for cond, value in zip(conds[1:], values[1:], strict=True):
        expr = expr.when(cond).then(value)
    return expr.otherwise(None)


def _joint_words(frame: pl.DataFrame, name: str) -> tuple[str, ...]:
    """The words a signal picked by joint name from a JointState-like topic (one with a
    ``name`` array) is found by (``SignalSpec.joint_words``); empty: not picked by name."""
    if "name.0" not in frame.columns:
        return ()
    spec = signal_spec(name)
    return spec.joint_words if spec is not None else ()


def _by_joint_name(
    frame: pl.DataFrame, side: str, fld: str, also: tuple[str, ...] = ()
) -> pl.Expr | None:
    """JointState-like topics: take ``<array>.i`` where ``name.i`` contains ``side`` (per
    message) and every word of ``also``."""
    array = fld.rsplit(".", 1)[0]
    pairs = [
        (f"name.{i}", f"{array}.{i}")
        for i in range(len(frame.columns))
        if f"name.{i}" in frame.columns and f"{array}.{i}" in frame.columns
    ]
    conds = []
    for n, _ in pairs:
        low = pl.col(n).cast(pl.String).str.to_lowercase()
        cond = low.str.contains(side, literal=True)
        for word in also:
            cond = cond & low.str.contains(word, literal=True)
        conds.append(cond)
    if not pairs or not frame.select(pl.any_horizontal(conds).fill_null(False).any()).item():
        return None
    return _chain(conds, [pl.col(v) for _, v in pairs])
