"""Map a log's topics and fields onto the logical signals of LOG_FORMAT.md.

Without a channel map, the defaults of :mod:`logtools.signals` are tried (JSON names, then
ROS 2 standard types), ``/joint_states`` arrays become ``q1, q2, …``, ``qd1, …``, ``tau1, …``, and
the columns of a CSV log are taken by their logical names. A channel map is a TOML file::

    [signals.psi]
    topic = "/trailer/joint"
    field = "position.0"
    transform = "deg_to_rad"      # optional: deg_to_rad | yaw_from_quaternion

Entries of a channel map take precedence; signals it does not name still use the defaults.
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import polars as pl

from logtools.errors import ChannelMapError, LogcalInputError, UnknownEncodingError
from logtools.readers import CSV_TOPIC, TIME_COLUMN, LogData, known_encodings
from logtools.signals import DEFAULT_JSON_MAP, DEFAULT_ROS2_MAP, SIGNAL_UNITS, SignalSource
from logtools.validate import check_yaw_units, clean_signal

__all__ = [
    "JOINT_ARRAYS",
    "JOINT_TOPIC",
    "LOGICAL_SIGNALS",
    "TRANSFORMS",
    "ResolvedSignals",
    "is_logical_signal",
    "load_channel_map",
    "resolve_signals",
]

LOGICAL_SIGNALS: tuple[str, ...] = (*(s for s in SIGNAL_UNITS if s != "kappa"), "q", "qd", "tau")
"""Logged signals (``kappa`` is derived, never logged); q/qd/tau stand for q1, q2, … per joint."""

JOINT_TOPIC = "/joint_states"
JOINT_ARRAYS = {"position": "q", "velocity": "qd", "effort": "tau"}
_JOINT_SIGNAL = re.compile(r"^(q|qd|tau)([1-9]\d*)$")


def is_logical_signal(name: str) -> bool:
    """True for a logical signal name, including per-joint names like ``q1`` or ``tau2``."""
    return name in LOGICAL_SIGNALS or _JOINT_SIGNAL.match(name) is not None


def _yaw_from_quaternion(frame: pl.DataFrame, fld: str) -> pl.Expr:
    x, y, z, w = (pl.col(f"{fld}.{c}").cast(pl.Float64) for c in "xyzw")
    return pl.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def _deg_to_rad(frame: pl.DataFrame, fld: str) -> pl.Expr:
    return pl.col(fld).cast(pl.Float64) * (math.pi / 180)


TRANSFORMS: dict[str, Callable[[pl.DataFrame, str], pl.Expr]] = {
    "yaw_from_quaternion": _yaw_from_quaternion,
    "deg_to_rad": _deg_to_rad,
}
"""Transforms a channel map may name; each turns (frame, field) into the signal's value."""


@dataclass(frozen=True)
class ResolvedSignals:
    """Logical signals found in a log.

    Attributes:
        signals: logical name -> frame (``t_ns`` int64 increasing, ``value`` float64 finite).
        sources: logical name -> where it came from.
        missing: logical signals (of :data:`LOGICAL_SIGNALS`) not found.
        problems: what was repaired (NaN dropped, duplicate timestamps, wheel order assumed).
    """

    signals: dict[str, pl.DataFrame]
    sources: dict[str, SignalSource]
    missing: list[str]
    problems: list[str] = field(default_factory=list)


# ---------------------------------------------------------------- channel-map files


def load_channel_map(path: str | Path) -> dict[str, SignalSource]:
    """Read a channel-map TOML (``[signals.NAME] topic=… field=… transform=…``).

    Raises:
        ChannelMapError: the file is missing, not TOML, or names an unknown signal/transform.
    """
    p = Path(path)
    try:
        doc = tomllib.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError as err:
        raise ChannelMapError(f"{p}: no such channel-map file.") from err
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as err:
        raise ChannelMapError(f"{p}: not a readable TOML channel map ({err}).") from err
    table = doc.get("signals")
    if not isinstance(table, dict) or not table:
        raise ChannelMapError(
            f"{p}: expected a [signals.NAME] table with topic and field, e.g. "
            '[signals.psi] topic = "/hitch/angle" field = "data".'
        )
    return {name: _entry(p, name, entry) for name, entry in table.items()}


def _entry(p: Path, name: str, entry: object) -> SignalSource:
    if not is_logical_signal(name):
        raise ChannelMapError(
            f"{p}: [signals.{name}] is not a logical signal; expected one of "
            f"{', '.join(LOGICAL_SIGNALS[:-3])}, or q1, qd1, tau1, … per joint."
        )
    if not isinstance(entry, dict):
        raise ChannelMapError(f"{p}: [signals.{name}] must be a table with topic and field.")
    extra = set(entry) - {"topic", "field", "transform"}
    topic, fld, transform = entry.get("topic"), entry.get("field"), entry.get("transform")
    if extra or not isinstance(topic, str) or not isinstance(fld, str):
        raise ChannelMapError(
            f"{p}: [signals.{name}] needs string keys topic and field (and optional "
            f"transform); got keys {', '.join(sorted(entry))}."
        )
    if transform is not None and transform not in TRANSFORMS:
        raise ChannelMapError(
            f"{p}: [signals.{name}] transform {transform!r} is unknown; expected one of "
            f"{', '.join(TRANSFORMS)}."
        )
    return SignalSource(topic, fld, transform)


# ---------------------------------------------------------------- resolution


def resolve_signals(
    log: LogData, channel_map: Mapping[str, SignalSource] | None = None
) -> ResolvedSignals:
    """Find the logical signals of ``log``.

    Args:
        log: the frames from :func:`logtools.readers.read_log`.
        channel_map: signal -> source overriding the defaults (see :func:`load_channel_map`).

    Returns:
        The cleaned signals, their sources, the missing names and the repairs made.

    Raises:
        ChannelMapError: a channel-map entry names a topic or field the log does not have.
        UnknownEncodingError: a signal's topic is in an encoding logcal cannot decode.
        SignalValueError, TimestampError: a signal cannot be repaired (see
            :func:`logtools.validate.clean_signal`).
    """
    user = dict(channel_map or {})
    raw: dict[str, tuple[pl.DataFrame, SignalSource]] = {}
    notes: list[str] = []
    for name, src in user.items():
        raw[name] = (_extract_user(log, name, src), src)
    for name, found in _defaults(log).items():
        if name not in raw and not _joint_family_mapped(name, user):
            raw[name] = found
    signals: dict[str, pl.DataFrame] = {}
    sources: dict[str, SignalSource] = {}
    for name, (frame, src) in raw.items():
        cleaned, repaired = clean_signal(frame, path=log.path, name=name, source=src)
        notes += repaired
        if cleaned.height:
            signals[name], sources[name] = cleaned, src
    if "yaw" in signals:
        notes += check_yaw_units(
            signals["yaw"], signals.get("omega"), path=log.path, source=sources["yaw"]
        )
    missing = [s for s in LOGICAL_SIGNALS if s not in signals and not _any_joint(s, signals)]
    return ResolvedSignals(signals, sources, missing, notes)


def _joint_family_mapped(name: str, user: Mapping[str, SignalSource]) -> bool:
    """A user map naming any of q1, q2, … replaces the default q signals altogether."""
    m = _JOINT_SIGNAL.match(name)
    return m is not None and any(
        (u := _JOINT_SIGNAL.match(k)) and u.group(1) == m.group(1) for k in user
    )


def _any_joint(family: str, signals: Mapping[str, pl.DataFrame]) -> bool:
    return family in ("q", "qd", "tau") and any(
        (m := _JOINT_SIGNAL.match(k)) and m.group(1) == family for k in signals
    )


def _signal_frame(frame: pl.DataFrame, value: pl.Expr) -> pl.DataFrame:
    return frame.select(pl.col(TIME_COLUMN), value.alias("value"))


def _extract_user(log: LogData, name: str, src: SignalSource) -> pl.DataFrame:
    frame = _topic_frame(log, src.topic)
    if frame is None:
        raise ChannelMapError(
            f"{log.path}: the channel map names topic {src.topic!r}, which the log does not "
            f"have. Topics in the log: {', '.join(log.topic_names()) or '(none)'}."
        )
    value = _value_expr(frame, name, src)
    if value is None:
        fields = ", ".join(c for c in frame.columns if c != TIME_COLUMN)
        need = f"{src.field}.x/.y/.z/.w" if src.transform == "yaw_from_quaternion" else src.field
        raise ChannelMapError(
            f"{log.path}: the channel map takes signal {name!r} from topic {src.topic!r} field "
            f"{need!r}, which that topic does not have. Its fields: {fields or '(none)'}."
        )
    return _signal_frame(frame, value)


def _topic_frame(log: LogData, topic: str) -> pl.DataFrame | None:
    """The topic's frame; None if the log lacks it; raises if it is there but undecodable."""
    frame = log.topics.get(topic)
    info = log.info.get(topic)
    if frame is not None or info is None or not info.message_count:
        return frame
    if info.message_encoding not in known_encodings():
        raise UnknownEncodingError(log.path, topic, info.message_encoding, known_encodings())
    why = " ".join(p for p in log.problems if f"topic {topic!r}" in p)
    raise LogcalInputError(
        f"{log.path}: topic {topic!r} ({info.schema_name or 'no schema'}, "
        f"{info.message_encoding}) holds a signal logcal needs but could not be decoded. {why}"
    )


def _value_expr(frame: pl.DataFrame, name: str, src: SignalSource) -> pl.Expr | None:
    """The expression giving the signal's value from ``frame``, or None if the field is absent."""
    if src.transform is not None:
        needed = [f"{src.field}.{c}" for c in "xyzw"]
        if src.transform == "deg_to_rad":
            needed = [src.field]
        if not all(c in frame.columns for c in needed):
            return None
        return TRANSFORMS[src.transform](frame, src.field)
    if _selects_by_name(frame, name):
        return _by_joint_name(frame, name.removeprefix("wheel_"), src.field)
    if src.field not in frame.columns:
        return None
    return pl.col(src.field)


def _selects_by_name(frame: pl.DataFrame, name: str) -> bool:
    """Wheel angles from a JointState-like topic are picked by the ``name`` array."""
    return name in ("wheel_left", "wheel_right") and "name.0" in frame.columns


def _by_joint_name(frame: pl.DataFrame, side: str, fld: str) -> pl.Expr | None:
    """JointState-like topics: take ``<array>.i`` where ``name.i`` names ``side`` (per message)."""
    array = fld.rsplit(".", 1)[0]
    pairs = [
        (f"name.{i}", f"{array}.{i}")
        for i in range(len(frame.columns))
        if f"name.{i}" in frame.columns and f"{array}.{i}" in frame.columns
    ]
    conds = [
        pl.col(n).cast(pl.String).str.to_lowercase().str.contains(side, literal=True)
        for n, _ in pairs
    ]
    if not pairs or not frame.select(pl.any_horizontal(conds).fill_null(False).any()).item():
        return None
    expr = pl.when(conds[0]).then(pl.col(pairs[0][1]))
    for cond, (_, value_col) in zip(conds[1:], pairs[1:], strict=True):
        expr = expr.when(cond).then(pl.col(value_col))
    return expr.otherwise(None)


def _defaults(log: LogData) -> dict[str, tuple[pl.DataFrame, SignalSource]]:
    """Signals found through the default names of LOG_FORMAT.md."""
    if set(log.topics) == {CSV_TOPIC}:
        frame = log.topics[CSV_TOPIC]
        return {
            c: (_signal_frame(frame, pl.col(c)), SignalSource(CSV_TOPIC, c))
            for c in frame.columns
            if c != TIME_COLUMN and is_logical_signal(c)
        }
    out: dict[str, tuple[pl.DataFrame, SignalSource]] = {}
    for table in (DEFAULT_JSON_MAP, DEFAULT_ROS2_MAP):
        for name, src in table.items():
            if name in out:
                continue
            frame = _topic_frame(log, src.topic)
            value = None if frame is None else _value_expr(frame, name, src)
            if frame is not None and value is not None:
                if _selects_by_name(frame, name):
                    side = name.removeprefix("wheel_")
                    src = SignalSource(src.topic, f"{src.field.rsplit('.', 1)[0]}[name~{side}]")
                out[name] = (_signal_frame(frame, value), src)
    joints = _topic_frame(log, JOINT_TOPIC)
    if joints is not None:
        for col in joints.columns:
            array, _, index = col.rpartition(".")
            if array in JOINT_ARRAYS and index.isdigit():
                src = SignalSource(JOINT_TOPIC, col)
                out[f"{JOINT_ARRAYS[array]}{int(index) + 1}"] = (
                    _signal_frame(joints, pl.col(col)),
                    src,
                )
    return out
