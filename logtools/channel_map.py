"""Map a log's topics and fields onto the logical signals of LOG_FORMAT.md.

Without a channel map, the defaults of :mod:`logtools.signals` are tried in order (our JSON
names, ROS 2 types on our topics, then the standard ROS names ``/cmd_vel``, ``/odom``,
``/joint_states``, ``/tf``), ``/joint_states`` arrays become ``q1, q2, …``, ``qd1, …``,
``tau1, …``, and the columns of a CSV log are taken by their logical names. A channel map is a
TOML file::

    [robot]                       # optional
    type = "tractor_trailer"      # tractor_trailer | diff_drive | manipulator_2link
    wheelbase = 0.42              # m: kappa_cmd = tan(steer_cmd) / wheelbase
    L2 = 0.6                      # other numbers: nominal parameters

    [tf]                          # optional: the /tf child frame whose pose is x, y, yaw
    child_frame = "truck_link"

    [signals.psi]
    topic = "/trailer/joint"
    field = "position.0"
    unit = "deg"                  # optional: deg -> rad (see logtools.signals.UNIT_FACTORS)
    scale = 1.0                   # optional: value = (field * scale + offset) in `unit`
    offset = 0.0
    stamp = "header"              # optional: "log" (default) | "header" (header.stamp)
    transform = "yaw_from_quaternion"   # optional: yaw_from_quaternion | deg_to_rad
    frame = "truck_link"          # optional: element of a TFMessage-like array by child frame

    [signals.kappa_cmd]
    formula = "tan(steer_cmd) / wheelbase"   # derived from other signals (safe, no eval)

    [signals.omega]
    off = true                    # switch a default off

Entries of a channel map take precedence; signals it does not name still use the defaults.

Measured signals that carry nothing (a speed, rate or angle that is zero in every sample, like
the twist of an ``Odometry`` filled only with a pose) are detected, reported with topic and
field, and not used: the next default source is tried, and ``kappa`` then comes from the pose
path instead of 0/0. Commands may be constant; so may a nonzero speed or yaw rate, and a
position (a robot may spin in place).

When ``kappa_cmd`` is not logged it is derived, and :attr:`ResolvedSignals.kappa_cmd_origin`
says how: tan(steer_cmd) / wheelbase when a steering command and a wheelbase (channel map
``[robot] wheelbase``, else the ``logcal`` metadata record's ``wheelbase``) are known, else
omega_cmd / v_cmd where |v_cmd| > 0.05 m/s.
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

from logtools.align import resample_at
from logtools.errors import (
    ChannelMapEntryError,
    ChannelMapError,
    LogcalInputError,
    SignalValueError,
    UnknownEncodingError,
)
from logtools.outliers import drop_outliers
from logtools.problems import Problem
from logtools.readers import CSV_TOPIC, TIME_COLUMN, LogData, ProblemKind, known_encodings
from logtools.robots.tractor_trailer.curvature import (
    STEER_SATURATION_RAD,
    KappaCmdKind,
    KappaCmdOrigin,
    kappa_from_steering,
)
from logtools.signals import (
    COMMAND_SIGNALS,
    DERIVED_TOPIC,
    SIGNAL_UNITS,
    UNIT_FACTORS,
    Formula,
    FormulaError,
    RobotConfig,
    SignalSource,
    Stamp,
    default_candidates,
)
from logtools.validate import check_yaw_units, clean_signal

__all__ = [
    "JOINT_ARRAYS",
    "JOINT_TOPIC",
    "LOGICAL_SIGNALS",
    "PLAUSIBLE_LIMITS",
    "TRANSFORMS",
    "ChannelMap",
    "FlatSignal",
    "ResolvedSignals",
    "is_logical_signal",
    "load_channel_map",
    "parse_signal_option",
    "resolve_signals",
    "with_signal_options",
]

LOGICAL_SIGNALS: tuple[str, ...] = (*(s for s in SIGNAL_UNITS if s != "kappa"), "q", "qd", "tau")
"""Logged signals (``kappa`` is derived, never logged); q/qd/tau stand for q1, q2, … per joint."""

JOINT_TOPIC = "/joint_states"
JOINT_ARRAYS = {"position": "q", "velocity": "qd", "effort": "tau"}
_JOINT_SIGNAL = re.compile(r"^(q|qd|tau)([1-9]\d*)$")
_JOINT_UNITS = {"q": "rad", "qd": "rad/s", "tau": "N·m"}

V_CMD_MIN = 0.05
"""|v_cmd| (m/s) above which kappa_cmd = omega_cmd / v_cmd is derived."""

FLAT_MIN_SAMPLES = 5
"""A signal needs at least this many samples to be called constant."""
_ZERO_MEANS_EMPTY = ("v", "omega", "psi", "steer", "wheel_left", "wheel_right", "yaw", "yaw2")

_ENTRY_KEYS = ("topic", "field", "transform", "scale", "offset", "unit", "stamp", "frame")

MAX_CHANNEL_MAP_BYTES = 2**20
"""Largest channel-map TOML read (1 MiB)."""
MAX_FORMULA_CHARS = 1000
"""Longest formula (its parse and evaluation recurse once per nested term: a bound keeps them
far from Python's recursion limit)."""


def _parse_formula(file: str, key: str, text: str) -> Formula:
    """``Formula.parse`` within :data:`MAX_FORMULA_CHARS`; errors name the file and key."""
    if len(text) > MAX_FORMULA_CHARS:
        raise ChannelMapEntryError(
            file, key, f"is {len(text)} characters long; a formula has at most "
            f"{MAX_FORMULA_CHARS}."
        )
    try:
        return Formula.parse(text)
    except FormulaError as err:
        raise ChannelMapEntryError(file, key, str(err)) from err
    except (RecursionError, MemoryError) as err:
        raise ChannelMapEntryError(
            file, key, "is nested too deeply to parse; write it with fewer parentheses and "
            "unary signs."
        ) from err


def plugin_sources() -> dict[str, list[SignalSource]]:
    """Default sources the robot plugins declare (``SignalSpec.sources``), after ours."""
    from logtools.robots import plugins

    out: dict[str, list[SignalSource]] = {}
    for p in plugins():
        for spec in p.signals:
            out.setdefault(spec.name, []).extend(spec.sources)
    return out


def _plugin_units() -> dict[str, str]:
    """Units of the signals the robot plugins declare beyond LOG_FORMAT.md's."""
    from logtools.robots import plugins

    return {s.name: s.unit for p in plugins() for s in p.signals}


def is_logical_signal(name: str) -> bool:
    """True for a logical signal name, including per-joint names like ``q1`` or ``tau2`` and
    the signals a robot plugin declares."""
    return (
        name in LOGICAL_SIGNALS
        or _JOINT_SIGNAL.match(name) is not None
        or name in _plugin_units()
    )


def _si_unit(name: str) -> str | None:
    m = _JOINT_SIGNAL.match(name)
    if m:
        return _JOINT_UNITS[m.group(1)]
    return SIGNAL_UNITS.get(name) or _plugin_units().get(name)


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


def _transform_columns(fld: str, transform: str | None) -> list[str]:
    return [f"{fld}.{c}" for c in "xyzw"] if transform == "yaw_from_quaternion" else [fld]


# ---------------------------------------------------------------- records


@dataclass(frozen=True)
class FlatSignal:
    """A signal that carries nothing: every sample has the same value (e.g. an empty twist).

    Attributes:
        name: logical signal name.
        topic: its topic.
        field: its field path.
        value: the one value it holds (in the signal's unit).
        samples: how many samples hold it.
    """

    name: str
    topic: str
    field: str
    value: float
    samples: int

    def message(self, path: str) -> str:
        """One sentence for ``problems``."""
        return (
            f"{path}: signal {self.name!r} (topic {self.topic!r}, field {self.field!r}) is "
            f"{self.value:g} in all {self.samples} samples: it carries nothing and is not used"
        )


@dataclass(frozen=True)
class ResolvedSignals:
    """Logical signals found in a log.

    Attributes:
        signals: logical name -> frame (``t_ns`` int64 increasing, ``value`` float64 finite);
            derived signals (formulas, kappa_cmd from steering) included.
        sources: logical name -> where it came from (derived: topic ``(derived)``, field the
            expression).
        missing: logical signals (of :data:`LOGICAL_SIGNALS`) not found.
        problems: what was repaired or left out (NaN dropped, duplicate timestamps, signals
            that carry nothing, saturated steering, kappa_cmd not derivable).
        flat: signals found but not used because every sample holds the same value.
        kappa_cmd_origin: how ``kappa_cmd`` was obtained; None without one.
        robot: the channel map's ``[robot]`` table, its wheelbase completed from the ``logcal``
            metadata record when the map has none.
    """

    signals: dict[str, pl.DataFrame]
    sources: dict[str, SignalSource]
    missing: list[str]
    problems: list[str] = field(default_factory=list)
    flat: list[FlatSignal] = field(default_factory=list)
    kappa_cmd_origin: KappaCmdOrigin | None = None
    robot: RobotConfig = field(default_factory=RobotConfig)
    outliers: list[Problem] = field(default_factory=list)
    """Single-sample outliers excluded from the signals (:mod:`logtools.outliers`), with times."""


PLAUSIBLE_LIMITS: dict[str, float] = {
    "m/s": 1e3,
    "rad/s": 1e4,
    "1/m": 1e3,
    "m": 1e8,
    "rad": 1e9,
    "N·m": 1e7,
}
"""Largest |value| a logical signal can physically hold, per SI unit (a speed of 1 km/s, a
position 1e8 m from the origin, 1e9 rad of accumulated yaw or wheel angle): beyond it (after
outliers are excluded) the values are not in the unit the channel map says, and every
integration step count downstream would grow with them)."""


@dataclass(frozen=True, eq=False)
class ChannelMap(Mapping[str, SignalSource]):
    """A channel map: signal -> source (it is a Mapping of those), plus its other tables.

    Attributes:
        signals: logical name -> source (formulas included).
        off: default signals switched off (``off = true``).
        robot: the ``[robot]`` table.
        tf_frame: the ``[tf] child_frame`` whose pose gives x, y, yaw; None: defaults.
        path: the TOML file ("" when built in code).
    """

    signals: dict[str, SignalSource] = field(default_factory=dict)
    off: frozenset[str] = frozenset()
    robot: RobotConfig = field(default_factory=RobotConfig)
    tf_frame: str | None = None
    path: str = ""

    def __getitem__(self, key: str) -> SignalSource:
        return self.signals[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self.signals)

    def __len__(self) -> int:
        return len(self.signals)

    def __eq__(self, other: object) -> bool:
        if isinstance(other, ChannelMap):
            return (self.signals, self.off, self.robot, self.tf_frame) == (
                other.signals,
                other.off,
                other.robot,
                other.tf_frame,
            )
        return isinstance(other, Mapping) and dict(self.signals) == dict(other)

    __hash__ = None  # type: ignore[assignment]


# ---------------------------------------------------------------- channel-map files


def load_channel_map(path: str | Path) -> ChannelMap:
    """Read a channel-map TOML (see the module docstring for its tables and keys).

    Raises:
        ChannelMapError: the file is missing or not TOML.
        ChannelMapEntryError: a table or key is wrong (the message names the file and the key).
    """
    p = Path(path)
    try:
        with open(p, "rb") as fh:
            raw = fh.read(MAX_CHANNEL_MAP_BYTES + 1)
        if len(raw) > MAX_CHANNEL_MAP_BYTES:
            raise ChannelMapError(
                f"{p}: larger than {MAX_CHANNEL_MAP_BYTES} bytes; not a channel map."
            )
        doc = tomllib.loads(raw.decode("utf-8"))
    except FileNotFoundError as err:
        raise ChannelMapError(f"{p}: no such channel-map file.") from err
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as err:
        raise ChannelMapError(f"{p}: not a readable TOML channel map ({err}).") from err
    except RecursionError as err:
        raise ChannelMapError(
            f"{p}: not a readable TOML channel map (arrays or tables nested too deeply)."
        ) from err
    file = str(p)
    table = doc.get("signals")
    if not (doc.get("robot") or doc.get("tf")) and (not isinstance(table, dict) or not table):
        raise ChannelMapError(
            f"{p}: expected a [signals.NAME] table with topic and field, e.g. "
            '[signals.psi] topic = "/hitch/angle" field = "data" (and optionally [robot], [tf]).'
        )
    for key in doc:
        if key not in ("signals", "robot", "tf"):
            raise ChannelMapEntryError(
                file,
                key,
                "is not a channel-map table; expected a [signals.NAME] table, [robot] or [tf].",
            )
    robot = _robot_table(file, doc.get("robot", {}))
    tf_frame = _tf_table(file, doc.get("tf", {}))
    if table is not None and not isinstance(table, dict):
        raise ChannelMapEntryError(file, "signals", "must be a table of [signals.NAME] tables.")
    signals: dict[str, SignalSource] = {}
    off: set[str] = set()
    for name, entry in (table or {}).items():
        src = _entry(file, name, entry, robot)
        if src is None:
            if entry.get("off") is True:
                off.add(name)
            continue
        signals[name] = src
    _check_formula_cycles(file, signals)
    return ChannelMap(signals, frozenset(off), robot, tf_frame, file)


SIGNAL_OPTION = "--signal"
"""Where ``--signal`` entries say they were written (the ``file`` of their errors)."""


def parse_signal_option(text: str, robot: RobotConfig | None = None) -> tuple[str, SignalSource]:
    """One ``--signal NAME=TOPIC:FIELD[:UNIT]`` into ``(NAME, source)``, the same entry as
    ``[signals.NAME] topic = TOPIC, field = FIELD, unit = UNIT`` of a channel-map TOML.

    The third part may also name a transform (``yaw_from_quaternion``, ``deg_to_rad``). A
    CSV log's topic is ``csv`` (``--signal v=csv:speed_kmh:km/h``).

    Raises:
        ChannelMapEntryError: the text is not ``NAME=TOPIC:FIELD[:UNIT]``, or the entry is
            wrong as a channel-map entry would be (the message names ``--signal`` and the key).
    """
    name, eq, rest = text.partition("=")
    name = name.strip()
    parts = [p.strip() for p in rest.split(":")] if eq else []
    if not name or len(parts) not in (2, 3) or not all(parts):
        raise ChannelMapEntryError(
            SIGNAL_OPTION, f"signals.{name or '?'}",
            f"{text!r} is not NAME=TOPIC:FIELD[:UNIT]; e.g. --signal psi=/hitch:data:deg or "
            "--signal yaw=/mocap/pose:pose.orientation:yaw_from_quaternion",
        )
    entry: dict[str, Any] = {"topic": parts[0], "field": parts[1]}
    if len(parts) == 3:
        entry["transform" if parts[2] in TRANSFORMS else "unit"] = parts[2]
    src = _entry(SIGNAL_OPTION, name, entry, robot or RobotConfig())
    assert src is not None  # an entry with topic and field is never "off"
    return name, src


def with_signal_options(
    cmap: ChannelMap | None, options: list[str] | tuple[str, ...]
) -> ChannelMap | None:
    """``cmap`` (a channel map or None) with ``--signal`` entries added; an entry of the same
    name replaces the map's (the command line wins), and switches an ``off`` back on.

    Raises:
        ChannelMapEntryError: an entry is malformed (see :func:`parse_signal_option`).
    """
    if not options:
        return cmap
    base = cmap if cmap is not None else ChannelMap()
    signals = dict(base.signals)
    for text in options:
        name, src = parse_signal_option(text, base.robot)
        signals[name] = src
    path = f"{base.path} + {SIGNAL_OPTION}" if base.path else SIGNAL_OPTION
    return ChannelMap(signals, base.off - set(signals), base.robot, base.tf_frame, path)


def _robot_table(file: str, table: object) -> RobotConfig:
    if not isinstance(table, dict):
        raise ChannelMapEntryError(
            file, "robot", "must be a table: [robot] type = …, wheelbase = …"
        )
    from logtools.robots import UnknownRobotError, plugin_for

    rtype: str | None = None
    urdf: str | None = None
    wheelbase: float | None = None
    params: dict[str, float] = {}
    for key, value in table.items():
        if key == "type":
            try:
                rtype = plugin_for(str(value)).name
            except UnknownRobotError as err:
                raise ChannelMapEntryError(
                    file, "robot.type", f"is {value!r}; expected one of {', '.join(err.known)}."
                ) from None
        elif key == "urdf":
            if not isinstance(value, str) or not value:
                raise ChannelMapEntryError(
                    file, "robot.urdf", f"is {value!r}; expected a URDF path or a model name."
                )
            urdf = value
        elif not _is_number(value) or not math.isfinite(value):
            raise ChannelMapEntryError(
                file, f"robot.{key}",
                f"is {value!r}; expected a number (m or rad), or type = … / urdf = …",
            )
        elif key == "wheelbase":
            if value <= 0:
                raise ChannelMapEntryError(
                    file, "robot.wheelbase", f"is {value!r}; expected a positive length in m."
                )
            wheelbase = float(value)
        else:
            params[key] = float(value)
    return RobotConfig(rtype, wheelbase, params, urdf)


def _tf_table(file: str, table: object) -> str | None:
    if not isinstance(table, dict):
        raise ChannelMapEntryError(file, "tf", 'must be a table: [tf] child_frame = "base_link"')
    for key, value in table.items():
        if key != "child_frame":
            raise ChannelMapEntryError(file, f"tf.{key}", "is unknown; [tf] takes child_frame.")
        if not isinstance(value, str) or not value:
            raise ChannelMapEntryError(
                file, "tf.child_frame", f"is {value!r}; expected a frame name."
            )
    frame = table.get("child_frame")
    return frame if isinstance(frame, str) else None


def _is_number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _entry(file: str, name: str, entry: object, robot: RobotConfig) -> SignalSource | None:
    key = f"signals.{name}"
    if not is_logical_signal(name):
        raise ChannelMapEntryError(
            file,
            key,
            f"{name!r} is not a logical signal; expected one of {', '.join(LOGICAL_SIGNALS[:-3])}, "
            "or q1, qd1, tau1, … per joint.",
        )
    if not isinstance(entry, dict):
        raise ChannelMapEntryError(file, key, "must be a table with topic and field.")
    if "off" in entry:
        if not isinstance(entry["off"], bool):
            raise ChannelMapEntryError(file, f"{key}.off", "must be true or false.")
        if entry["off"] and len(entry) > 1:
            others = ", ".join(sorted(k for k in entry if k != "off"))
            raise ChannelMapEntryError(
                file, f"{key}.off", f"switches the signal off; drop the other keys ({others})."
            )
        if entry["off"] or len(entry) == 1:
            return None
        entry = {k: v for k, v in entry.items() if k != "off"}
    allowed = {*_ENTRY_KEYS, "formula"}
    extra = sorted(set(entry) - allowed)
    if extra:
        raise ChannelMapEntryError(
            file,
            f"{key}.{extra[0]}",
            f"is not a key of a signal entry; expected {', '.join(sorted(allowed | {'off'}))}.",
        )
    scale, offset, unit = _numbers_and_unit(file, key, name, entry)
    if "formula" in entry:
        return _formula_entry(file, key, name, entry, robot, scale, offset, unit)
    topic, fld, transform = entry.get("topic"), entry.get("field"), entry.get("transform")
    if not isinstance(topic, str) or not isinstance(fld, str) or not topic or not fld:
        raise ChannelMapEntryError(
            file,
            key,
            "needs string keys topic and field (or a formula); got keys "
            f"{', '.join(sorted(entry))}.",
        )
    if transform is not None and (not isinstance(transform, str) or transform not in TRANSFORMS):
        raise ChannelMapEntryError(
            file,
            f"{key}.transform",
            f"transform {transform!r} is unknown; expected one of {', '.join(TRANSFORMS)}.",
        )
    if transform == "deg_to_rad" and unit is not None:
        raise ChannelMapEntryError(
            file, f"{key}.unit", 'and transform = "deg_to_rad" both convert; keep one of them.'
        )
    stamp = entry.get("stamp", "log")
    if stamp not in ("log", "header"):
        raise ChannelMapEntryError(
            file, f"{key}.stamp", f"is {stamp!r}; expected 'log' (record time) or 'header'."
        )
    frame = entry.get("frame")
    if frame is not None and (not isinstance(frame, str) or not frame):
        raise ChannelMapEntryError(file, f"{key}.frame", f"is {frame!r}; expected a frame name.")
    return SignalSource(
        topic, fld, transform, scale, offset, unit, Stamp(stamp), frame, None, origin=file
    )


def _numbers_and_unit(
    file: str, key: str, name: str, entry: dict[str, Any]
) -> tuple[float, float, str | None]:
    nums = []
    for k, default in (("scale", 1.0), ("offset", 0.0)):
        value = entry.get(k, default)
        if not _is_number(value) or not math.isfinite(value):
            raise ChannelMapEntryError(file, f"{key}.{k}", f"is {value!r}; expected a number.")
        nums.append(float(value))
    if nums[0] == 0.0:
        raise ChannelMapEntryError(file, f"{key}.scale", "is 0; the signal would carry nothing.")
    unit = entry.get("unit")
    if unit is not None and not isinstance(unit, str):
        raise ChannelMapEntryError(
            file, f"{key}.unit", f"is {unit!r}; expected a unit name (a string, e.g. \"deg\")."
        )
    if unit is not None:
        si = _si_unit(name)
        fits = [u for u, (base, _) in UNIT_FACTORS.items() if base == si]
        if unit not in UNIT_FACTORS or UNIT_FACTORS[unit][0] != si:
            expected = ", ".join(fits) if fits else "none (leave unit out)"
            raise ChannelMapEntryError(
                file,
                f"{key}.unit",
                f"is {unit!r}, which does not fit signal {name!r} ({si}); expected {expected}.",
            )
    return nums[0], nums[1], unit


def _formula_entry(
    file: str,
    key: str,
    name: str,
    entry: dict[str, Any],
    robot: RobotConfig,
    scale: float,
    offset: float,
    unit: str | None,
) -> SignalSource:
    text = entry["formula"]
    clash = sorted(k for k in ("topic", "field", "transform", "stamp", "frame") if k in entry)
    if clash:
        raise ChannelMapEntryError(
            file, f"{key}.formula", f"derives the signal; drop {', '.join(clash)}."
        )
    if not isinstance(text, str) or not text.strip():
        raise ChannelMapEntryError(file, f"{key}.formula", "must be a non-empty string.")
    formula = _parse_formula(file, f"{key}.formula", text)
    constants = robot.constants()
    for used in formula.names:
        if used == name:
            raise ChannelMapEntryError(file, f"{key}.formula", f"uses {name!r} itself.")
        if not is_logical_signal(used) and used not in constants:
            known = ", ".join(["pi", *constants]) or "pi"
            raise ChannelMapEntryError(
                file,
                f"{key}.formula",
                f"uses {used!r}, which is neither a logical signal nor a [robot] number "
                f"(constants: {known}).",
            )
    return SignalSource(
        DERIVED_TOPIC, text, None, scale, offset, unit, Stamp.LOG, None, text, origin=file
    )


def _check_formula_cycles(file: str, signals: Mapping[str, SignalSource]) -> None:
    deps = {
        n: set(Formula.parse(s.formula).names) & set(signals)
        for n, s in signals.items()
        if s.formula is not None
    }
    state: dict[str, int] = {}

    def visit(n: str, chain: list[str]) -> None:
        if state.get(n) == 2 or n not in deps:
            return
        if state.get(n) == 1:
            cycle = " -> ".join([*chain[chain.index(n) :], n])
            raise ChannelMapEntryError(file, f"signals.{n}.formula", f"is circular: {cycle}.")
        state[n] = 1
        for d in sorted(deps[n]):
            visit(d, [*chain, n])
        state[n] = 2

    for n in sorted(deps):
        visit(n, [])


# ---------------------------------------------------------------- resolution


def resolve_signals(
    log: LogData, channel_map: Mapping[str, SignalSource] | None = None
) -> ResolvedSignals:
    """Find the logical signals of ``log``.

    Args:
        log: the frames from :func:`logtools.readers.read_log`.
        channel_map: a :class:`ChannelMap` (see :func:`load_channel_map`) or any mapping of
            signal -> source overriding the defaults.

    Returns:
        The cleaned signals, their sources, the missing names, the repairs made, the signals
        that carry nothing, and how kappa_cmd was obtained.

    Raises:
        ChannelMapError: a channel-map entry names a topic or field the log does not have, or a
            formula uses a signal the log does not have.
        UnknownEncodingError: a signal's topic is in an encoding logcal cannot decode.
        SignalValueError, TimestampError: a signal cannot be repaired (see
            :func:`logtools.validate.clean_signal`).
    """
    cmap = (
        channel_map if isinstance(channel_map, ChannelMap) else ChannelMap(dict(channel_map or {}))
    )
    state = _Resolution(log, cmap)
    direct = {n: s for n, s in cmap.items() if not s.is_derived}
    derived = {n: s for n, s in cmap.items() if s.is_derived}
    for name, src in direct.items():
        state.take(name, _extract_user(log, name, src), src)
    skip = set(direct) | set(derived) | set(cmap.off)
    state.take_defaults(skip, user=direct)
    state.evaluate_formulas(derived)
    if "kappa_cmd" in state.signals and "kappa_cmd" not in derived:
        src = state.sources["kappa_cmd"]
        state.kappa_cmd_origin = KappaCmdOrigin(
            KappaCmdKind.LOGGED, f"{src.topic}:{src.field}", f"logged on {src.describe()}"
        )
    elif "kappa_cmd" not in state.signals and "kappa_cmd" not in cmap.off:
        state.derive_kappa_cmd()
    state.note_saturated_steer()
    signals, sources, notes = state.signals, state.sources, state.notes
    for yaw, rate in (("yaw", "omega"), ("yaw2", None)):
        if yaw in signals:
            notes += check_yaw_units(
                signals[yaw],
                signals.get(rate) if rate else None,
                path=log.path,
                source=sources[yaw],
            )
    missing = [s for s in LOGICAL_SIGNALS if s not in signals and not _any_joint(s, signals)]
    return ResolvedSignals(
        signals,
        sources,
        missing,
        notes,
        state.flat,
        state.kappa_cmd_origin,
        state.robot,
        state.outliers,
    )


class _Resolution:
    """The signals found so far and what was noted on the way."""

    def __init__(self, log: LogData, cmap: ChannelMap) -> None:
        self.log, self.cmap = log, cmap
        self.signals: dict[str, pl.DataFrame] = {}
        self.sources: dict[str, SignalSource] = {}
        self.notes: list[str] = []
        self.flat: list[FlatSignal] = []
        self.kappa_cmd_origin: KappaCmdOrigin | None = None
        self.robot, self.wheelbase_from = _robot_config(log, cmap, self.notes)
        self.outliers: list[Problem] = []
        firsts = [i.first_ns for i in log.info.values() if i.first_ns is not None]
        self.origin = min(firsts, default=0)

    def take(self, name: str, frame: pl.DataFrame, src: SignalSource) -> bool:
        """Clean and keep the signal; False (and a record) when it is empty or carries nothing.

        Outliers are excluded (and recorded); values beyond :data:`PLAUSIBLE_LIMITS` refused."""
        cleaned, repaired = clean_signal(frame, path=self.log.path, name=name, source=src)
        self.notes += repaired
        if not cleaned.height:
            return False
        kept, found = drop_outliers(self.log.path, {name: cleaned}, self.origin)
        cleaned = kept[name]
        self.outliers += found
        _check_plausible(self.log.path, name, cleaned, src)
        flat = _flatness(name, cleaned, src)
        if flat is not None:
            self.flat.append(flat)
            self.notes.append(flat.message(self.log.path))
            return False
        self.signals[name], self.sources[name] = cleaned, src
        return True

    def take_defaults(self, skip: set[str], user: Mapping[str, SignalSource]) -> None:
        log = self.log
        if set(log.topics) == {CSV_TOPIC}:
            frame = log.topics[CSV_TOPIC]
            for c in frame.columns:
                if c != TIME_COLUMN and is_logical_signal(c) and c not in skip:
                    self.take(c, _signal_frame(frame, pl.col(c)), SignalSource(CSV_TOPIC, c))
            return
        # a topic the map reads the trailer's pose from does not also give the tractor's pose
        # by the default names (a trailer tracked on /odom is not the tractor)
        trailer_topics = {s.topic for n, s in user.items() if n in ("x2", "y2", "yaw2")}
        candidates_by_name = default_candidates(self.cmap.tf_frame)
        for name, extra in plugin_sources().items():
            candidates_by_name.setdefault(name, []).extend(extra)
        for name, candidates in candidates_by_name.items():
            if name in skip:
                continue
            for src in candidates:
                if name in ("x", "y", "yaw") and src.topic in trailer_topics:
                    continue
                found = _extract_default(log, name, src)
                if found is not None and self.take(name, *found):
                    break
        joints = _topic_frame(log, JOINT_TOPIC)
        if joints is None:
            return
        for col in joints.columns:
            array, _, index = col.rpartition(".")
            if array in JOINT_ARRAYS and index.isdigit():
                name = f"{JOINT_ARRAYS[array]}{int(index) + 1}"
                if name not in skip and not _joint_family_mapped(name, user):
                    self.take(
                        name, _signal_frame(joints, pl.col(col)), SignalSource(JOINT_TOPIC, col)
                    )

    def evaluate_formulas(self, derived: Mapping[str, SignalSource]) -> None:
        parsed: dict[str, Formula] = {}
        for name, src in derived.items():  # maps built in code are checked here
            parsed[name] = _parse_formula(
                src.origin or "", f"signals.{name}.formula", src.formula or ""
            )
        pending = dict(derived)
        while pending:
            ready = [n for n in pending if not (set(parsed[n].names) & set(pending))]
            if not ready:  # circular: load_channel_map refuses these; maps built in code may not
                name = sorted(pending)[0]
                raise ChannelMapEntryError(
                    pending[name].origin or "", f"signals.{name}.formula", "is circular."
                )
            for name in ready:
                self._evaluate(name, pending.pop(name))

    def _evaluate(self, name: str, src: SignalSource) -> None:
        key = f"signals.{name}.formula"
        formula = _parse_formula(src.origin or "", key, src.formula or "")
        constants = self.robot.constants()
        inputs = [n for n in formula.names if n not in constants]
        absent = [n for n in inputs if n not in self.signals]
        if absent:
            why = "; ".join(f.message(self.log.path) for f in self.flat if f.name in absent)
            raise ChannelMapEntryError(
                src.origin or "",
                key,
                f"{src.formula!r} uses {', '.join(absent)}, which {self.log.path} does not have"
                f"{' (' + why + ')' if why else ''}. Signals found: "
                f"{', '.join(sorted(self.signals)) or '(none)'}.",
            )
        t_ns, arrays = _common_times({n: self.signals[n] for n in inputs})
        values: dict[str, np.ndarray | float] = dict(arrays)
        values.update({c: v for c, v in constants.items() if c in formula.names})
        try:
            out = formula.evaluate(values)
        except FormulaError as err:
            raise ChannelMapEntryError(src.origin or "", key, str(err)) from err
        except RecursionError as err:
            raise ChannelMapEntryError(src.origin or "", key, "is nested too deeply.") from err
        out = np.broadcast_to(out, t_ns.shape) if t_ns.size else out
        frame = pl.DataFrame(
            {TIME_COLUMN: pl.Series(t_ns, dtype=pl.Int64), "value": np.asarray(out, dtype=float)}
        )
        frame = _post(frame, src).with_columns(pl.col("value").fill_nan(None))
        dropped = frame["value"].null_count()
        if dropped:
            self.notes.append(
                f"{self.log.path}: signal {name!r} = {src.formula}: {dropped} of {frame.height} "
                "samples are undefined (division by zero or an input missing at that time); "
                "left out"
            )
        frame = frame.drop_nulls("value")
        if not frame.height:
            raise ChannelMapEntryError(
                src.origin or "", key, f"{src.formula!r} gives no finite value on this log."
            )
        self.take(name, frame, src)
        if name == "kappa_cmd" and name in self.signals:
            self.kappa_cmd_origin = KappaCmdOrigin(
                KappaCmdKind.FORMULA, src.formula or "", f"channel-map formula {src.formula}"
            )

    def note_saturated_steer(self) -> None:
        """A measured steering angle at or beyond saturation gives no curvature there: say so."""
        if "steer" not in self.signals:
            return
        values = self.signals["steer"]["value"].to_numpy()
        n_sat = int(np.count_nonzero(np.abs(values) >= STEER_SATURATION_RAD))
        if n_sat:
            self.notes.append(
                f"{self.log.path}: {n_sat} of {values.size} samples of steer "
                f"({self.sources['steer'].describe()}) are saturated (|delta| >= "
                f"{math.degrees(STEER_SATURATION_RAD):.0f} deg, up to "
                f"{math.degrees(float(np.max(np.abs(values)))):.1f} deg): no curvature is taken "
                "from them"
            )

    def derive_kappa_cmd(self) -> None:
        path = self.log.path
        if "steer_cmd" in self.signals:
            wheelbase = self.robot.wheelbase
            steer = self.sources["steer_cmd"]
            if wheelbase is None:
                self.notes.append(
                    f"{path}: a steering command steer_cmd ({steer.describe()}) is there but no "
                    "wheelbase is known, so kappa_cmd = tan(steer_cmd) / wheelbase is not "
                    "derived; set [robot] wheelbase = … (m) in the channel map or 'wheelbase' in "
                    "the logcal metadata record"
                )
                return
            frame = self.signals["steer_cmd"]
            kappa, saturated = kappa_from_steering(frame["value"].to_numpy(), wheelbase)
            n_sat = int(saturated.sum())
            if n_sat:
                peak = math.degrees(float(np.max(np.abs(frame["value"].to_numpy()))))
                self.notes.append(
                    f"{path}: {n_sat} of {frame.height} samples of steer_cmd ({steer.describe()}) "
                    f"are saturated (|delta| >= {math.degrees(STEER_SATURATION_RAD):.0f} deg, up "
                    f"to {peak:.1f} deg): tan(delta) / wheelbase runs to infinity there, so "
                    "kappa_cmd is left out on those samples"
                    + (
                        '; beyond 360 deg the values look like degrees: set unit = "deg"'
                        if peak > 360
                        else ""
                    )
                )
            expr = f"tan(steer_cmd) / {wheelbase:g}"
            out = frame.with_columns(pl.Series("value", kappa).fill_nan(None)).drop_nulls("value")
            if out.height:
                src = SignalSource(DERIVED_TOPIC, expr, formula=expr)
                self.signals["kappa_cmd"], self.sources["kappa_cmd"] = out, src
                self.kappa_cmd_origin = KappaCmdOrigin(
                    KappaCmdKind.STEERING,
                    expr,
                    f"tan(steer_cmd) / wheelbase from the steering command {steer.describe()}, "
                    f"wheelbase {wheelbase:g} m from {self.wheelbase_from}",
                    wheelbase,
                )
            return
        if "omega_cmd" in self.signals and "v_cmd" in self.signals:
            t_ns, values = _common_times(
                {n: self.signals[n] for n in ("omega_cmd", "v_cmd")}, hold=True
            )
            v_cmd, omega_cmd = values["v_cmd"], values["omega_cmd"]
            ok = np.isfinite(v_cmd) & np.isfinite(omega_cmd) & (np.abs(v_cmd) > V_CMD_MIN)
            if not ok.any():
                return
            expr = "omega_cmd / v_cmd"
            out = pl.DataFrame(
                {
                    TIME_COLUMN: pl.Series(t_ns[ok], dtype=pl.Int64),
                    "value": omega_cmd[ok] / v_cmd[ok],
                }
            )
            src = SignalSource(DERIVED_TOPIC, expr, formula=expr)
            self.signals["kappa_cmd"], self.sources["kappa_cmd"] = out, src
            w, v = self.sources["omega_cmd"], self.sources["v_cmd"]
            self.kappa_cmd_origin = KappaCmdOrigin(
                KappaCmdKind.TWIST,
                expr,
                f"omega_cmd / v_cmd from {w.describe()} and {v.describe()} where |v_cmd| > "
                f"{V_CMD_MIN} m/s",
            )
            self.notes.append(
                f"{path}: kappa_cmd is derived as omega_cmd / v_cmd ({w.describe()} / "
                f"{v.describe()}); if that field is a steering angle rather than a yaw rate, map "
                "it as steer_cmd and set [robot] wheelbase in a channel map"
            )


def _robot_config(log: LogData, cmap: ChannelMap, notes: list[str]) -> tuple[RobotConfig, str]:
    """The channel map's [robot] table with the wheelbase completed from the metadata record."""
    robot = cmap.robot
    text = log.metadata.get("logcal", {}).get("wheelbase")
    meta: float | None = None
    if text is not None:
        try:
            meta = float(text)
        except ValueError:
            meta = None
        if meta is None or not (math.isfinite(meta) and meta > 0):
            notes.append(
                f"{log.path}: the logcal metadata record's wheelbase {text!r} is not a positive "
                "number; ignored"
            )
            meta = None
    if robot.wheelbase is not None:
        where = f"the channel map {cmap.path}".rstrip() + " [robot] wheelbase"
        if meta is not None and not math.isclose(meta, robot.wheelbase, rel_tol=1e-9):
            notes.append(
                f"{log.path}: the channel map's wheelbase {robot.wheelbase:g} m differs from the "
                f"logcal metadata record's {meta:g} m; the channel map's is used"
            )
        return robot, where
    if meta is not None:
        return (
            RobotConfig(robot.type, meta, dict(robot.params)),
            "the logcal metadata record",
        )
    return robot, ""


def _flatness(name: str, frame: pl.DataFrame, src: SignalSource) -> FlatSignal | None:
    """A record when a measured rate or angle is zero in every sample (an empty twist, an
    unconnected encoder, an orientation never filled in). Commands, positions (a robot may spin
    in place) and joint signals are never flagged, nor a nonzero constant (a circle driven at
    constant speed)."""
    if name not in _ZERO_MEANS_EMPTY or frame.height < FLAT_MIN_SAMPLES:
        return None
    values = frame["value"].to_numpy()
    if np.any(np.abs(values) > 1e-12):
        return None
    return FlatSignal(name, src.topic, src.field, 0.0, frame.height)


def _common_times(
    frames: Mapping[str, pl.DataFrame], *, hold: bool = False
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Put signals on the times of the one with the most samples (others interpolated, or held
    for commands / ``hold``); NaN where an input has no sample near enough."""
    if not frames:
        return np.zeros(0, dtype=np.int64), {}
    base = max(frames, key=lambda n: frames[n].height)
    t_ns = frames[base][TIME_COLUMN].to_numpy()
    out: dict[str, np.ndarray] = {}
    for name, frame in frames.items():
        t, v = frame[TIME_COLUMN].to_numpy(), frame["value"].to_numpy()
        if name == base or (t.size == t_ns.size and np.array_equal(t, t_ns)):
            out[name] = v.astype(float)
        else:
            out[name] = resample_at(t, v, t_ns, hold=hold or name in COMMAND_SIGNALS)
    return t_ns, out


def _joint_family_mapped(name: str, user: Mapping[str, SignalSource]) -> bool:
    """A user map naming any of q1, q2, … replaces the default q signals altogether."""
    m = _JOINT_SIGNAL.match(name)
    return m is not None and any(
        (u := _JOINT_SIGNAL.match(k)) and u.group(1) == m.group(1) for k in user
    )


def _check_plausible(path: str, name: str, frame: pl.DataFrame, src: SignalSource) -> None:
    """Refuse a signal holding values no robot produces in its SI unit (see PLAUSIBLE_LIMITS)."""
    family = m.group(1) if (m := _JOINT_SIGNAL.match(name)) else name
    unit = SIGNAL_UNITS.get(family) or {"q": "rad", "qd": "rad/s", "tau": "N·m"}.get(family)
    limit = PLAUSIBLE_LIMITS.get(unit or "")
    if limit is None or not frame.height:
        return
    values = frame["value"].to_numpy()
    beyond = np.flatnonzero(np.abs(values) > limit)
    if beyond.size:
        first = float(values[beyond[0]])
        raise SignalValueError(
            f"{path}: signal {name!r} (topic {src.topic!r}, field {src.field!r}): {beyond.size} "
            f"of {values.size} samples are beyond +-{limit:g} {unit} (first: {first:.4g}); "
            f"expected {unit}. Set the unit or scale in the channel map if the field holds "
            "another unit."
        )


def _any_joint(family: str, signals: Mapping[str, pl.DataFrame]) -> bool:
    return family in ("q", "qd", "tau") and any(
        (m := _JOINT_SIGNAL.match(k)) and m.group(1) == family for k in signals
    )


def _signal_frame(frame: pl.DataFrame, value: pl.Expr, time: pl.Expr | None = None) -> pl.DataFrame:
    t = pl.col(TIME_COLUMN) if time is None else time.alias(TIME_COLUMN)
    return frame.select(t, value.alias("value"))


def _post(frame: pl.DataFrame, src: SignalSource) -> pl.DataFrame:
    """Apply scale, offset and unit: value = (value * scale + offset) * unit factor."""
    factor = UNIT_FACTORS[src.unit][1] if src.unit else 1.0
    if src.scale == 1.0 and src.offset == 0.0 and factor == 1.0:
        return frame
    value = pl.col("value").cast(pl.Float64)
    return frame.with_columns(((value * src.scale + src.offset) * factor).alias("value"))


def _where(src: SignalSource, name: str) -> tuple[str, str]:
    return src.origin or "", f"signals.{name}"


def _extract_user(log: LogData, name: str, src: SignalSource) -> pl.DataFrame:
    frame = _topic_frame(log, src.topic)
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
        if src.transform == "yaw_from_quaternion":
            need = f"{src.field}.x/.y/.z/.w"
        if src.frame:
            need += f" of the element whose child_frame_id is {src.frame!r}"
        raise ChannelMapEntryError(
            file,
            f"{key}.frame" if src.frame else f"{key}.field",
            f"takes signal {name!r} from topic {src.topic!r} field {need!r}, which that topic "
            f"of {log.path} does not have. Its fields: {fields or '(none)'}.",
        )
    value, time = got
    return _post(_signal_frame(frame, value, time), src)


def _topic_pattern(log: LogData, src: SignalSource) -> SignalSource | None:
    """A default source whose topic starts with ``*`` (``*/odom``) names the first topic (in
    sorted order) ending with the rest; None when the log has none. Other sources as given."""
    if not src.topic.startswith("*"):
        return src
    suffix = src.topic[1:]
    found = sorted(t for t in log.info if t.endswith(suffix) and log.info[t].message_count)
    return replace(src, topic=found[0]) if found else None


def _extract_default(
    log: LogData, name: str, src: SignalSource
) -> tuple[pl.DataFrame, SignalSource] | None:
    pattern = _topic_pattern(log, src)
    if pattern is None:
        return None
    src = pattern
    frame = _topic_frame(log, src.topic)
    if frame is None:
        return None
    if src.topic == JOINT_TOPIC:  # wheels from joint states only by joint name
        if not _selects_by_name(frame, name):
            return None
        side = name.removeprefix("wheel_")
        value = _by_joint_name(frame, side, src.field, also="wheel")
        if value is None:
            return None
        shown = SignalSource(src.topic, f"{src.field.rsplit('.', 1)[0]}[name~wheel,{side}]")
        return _signal_frame(frame, value), shown
    got = _value_and_time(frame, name, src, log.path)
    if got is None:
        return None
    if _selects_by_name(frame, name):
        side = name.removeprefix("wheel_")
        src = SignalSource(src.topic, f"{src.field.rsplit('.', 1)[0]}[name~{side}]")
    return _post(_signal_frame(frame, got[0], got[1]), src), src


def _topic_frame(log: LogData, topic: str) -> pl.DataFrame | None:
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
        if not all(c in frame.columns for c in _transform_columns(src.field, src.transform)):
            return None
        return TRANSFORMS[src.transform](frame, src.field)
    if _selects_by_name(frame, name):
        return _by_joint_name(frame, name.removeprefix("wheel_"), src.field)
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
        if all(c in frame.columns for c in _transform_columns(fld, src.transform)):
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
            values.append(TRANSFORMS[src.transform](frame, fld))
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


def _selects_by_name(frame: pl.DataFrame, name: str) -> bool:
    """Wheel angles from a JointState-like topic are picked by the ``name`` array."""
    return name in ("wheel_left", "wheel_right") and "name.0" in frame.columns


def _by_joint_name(
    frame: pl.DataFrame, side: str, fld: str, also: str | None = None
) -> pl.Expr | None:
    """JointState-like topics: take ``<array>.i`` where ``name.i`` names ``side`` (per message);
    with ``also``, the name must contain that word too (e.g. ``wheel``)."""
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
        if also:
            cond = cond & low.str.contains(also, literal=True)
        conds.append(cond)
    if not pairs or not frame.select(pl.any_horizontal(conds).fill_null(False).any()).item():
        return None
    return _chain(conds, [pl.col(v) for _, v in pairs])
