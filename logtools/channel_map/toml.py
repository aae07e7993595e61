"""Channel-map files: a TOML naming, per logical signal, the topic and field to read it from,
and the ``--signal NAME=TOPIC:FIELD[:UNIT]`` entries of the command line. Every table and key
is checked here, and an error names the file and the key::

    [robot]                       # optional
    type = "…"                    # a robot plugin's name (logtools.robots)
    track = 0.42                  # numbers: nominal parameters (m or rad); the keys a robot
                                  # declares (RobotPlugin.robot_keys) are checked as it says

    [tf]                          # optional: the /tf child frame whose pose is x, y, yaw
    child_frame = "truck_link"

    [signals.yaw]
    topic = "/mocap/pose"
    field = "pose.orientation"
    unit = "deg"                  # optional: deg -> rad (see logtools.signals.UNIT_FACTORS)
    scale = 1.0                   # optional: value = (field * scale + offset) in `unit`
    offset = 0.0
    stamp = "header"              # optional: "log" (default) | "header" (header.stamp)
    transform = "yaw_from_quaternion"   # optional: a name of channel_map.transforms.TRANSFORMS
    frame = "truck_link"          # optional: element of a TFMessage-like array by child frame

    [signals.omega_cmd]
    formula = "v_cmd / track"     # derived from other signals and the numbers (safe, no eval)

    [signals.omega]
    off = true                    # switch a default off

Entries of a channel map take precedence; signals it does not name still use the defaults.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from logtools import toml_bounded
from logtools.channel_map.names import (
    element_families,
    is_logical_signal,
    logical_signals,
    robot_keys,
    si_unit,
)
from logtools.channel_map.transforms import TRANSFORMS
from logtools.errors import ChannelMapEntryError, ChannelMapError
from logtools.robots import UnknownRobotError, plugin_for
from logtools.signals import (
    DERIVED_TOPIC,
    UNIT_FACTORS,
    Formula,
    FormulaError,
    RobotConfig,
    SignalSource,
    Stamp,
)

__all__ = [
    "MAX_CHANNEL_MAP_BYTES",
    "MAX_FORMULA_CHARS",
    "SIGNAL_OPTION",
    "ChannelMap",
    "load_channel_map",
    "parse_formula",
    "parse_signal_option",
    "with_signal_options",
]

_ENTRY_KEYS = ("topic", "field", "transform", "scale", "offset", "unit", "stamp", "frame")

MAX_CHANNEL_MAP_BYTES = 2**20
"""Largest channel-map TOML read (1 MiB)."""
MAX_FORMULA_CHARS = 1000
"""Longest formula (its parse and evaluation recurse once per nested term: a bound keeps them
far from Python's recursion limit)."""


def parse_formula(file: str, key: str, text: str) -> Formula:
    """``Formula.parse`` within :data:`MAX_FORMULA_CHARS`; errors name the file and key."""
    if len(text) > MAX_FORMULA_CHARS:
        raise ChannelMapEntryError(
            file, key, f"is {len(text)} characters long; a formula has at most {MAX_FORMULA_CHARS}."
        )
    try:
        return Formula.parse(text)
    except FormulaError as err:
        raise ChannelMapEntryError(file, key, str(err)) from err
    except (RecursionError, MemoryError) as err:
        raise ChannelMapEntryError(
            file,
            key,
            "is nested too deeply to parse; write it with fewer parentheses and unary signs.",
        ) from err


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
        doc = toml_bounded.loads(raw.decode("utf-8"))
    except FileNotFoundError as err:
        raise ChannelMapError(f"{p}: no such channel-map file.") from err
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as err:
        raise ChannelMapError(f"{p}: not a readable TOML channel map ({err}).") from err
    except (toml_bounded.TomlTooDeepError, RecursionError) as err:
        raise ChannelMapError(
            f"{p}: not a readable TOML channel map (arrays or tables nested too deeply)."
        ) from err
    file = str(p)
    table = doc.get("signals")
    if not (doc.get("robot") or doc.get("tf")) and (not isinstance(table, dict) or not table):
        raise ChannelMapError(
            f"{p}: expected a [signals.NAME] table with topic and field, e.g. "
            '[signals.omega] topic = "/imu/data" field = "angular_velocity.z" (and optionally '
            "[robot], [tf])."
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
            SIGNAL_OPTION,
            f"signals.{name or '?'}",
            f"{text!r} is not NAME=TOPIC:FIELD[:UNIT]; e.g. --signal "
            "omega=/imu:angular_velocity.z:deg/s or "
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
            file, "robot", "must be a table: [robot] type = …, then nominal numbers name = …"
        )
    rtype: str | None = None
    declared = robot_keys()
    texts: dict[str, str] = {}
    params: dict[str, float] = {}
    for key, value in table.items():
        spec = declared.get(key)
        if key == "type":
            try:
                rtype = plugin_for(str(value)).name
            except UnknownRobotError as err:
                raise ChannelMapEntryError(
                    file, "robot.type", f"is {value!r}; expected one of {', '.join(err.known)}."
                ) from None
        elif spec is not None and spec.text:
            if not isinstance(value, str) or not value:
                raise ChannelMapEntryError(
                    file, f"robot.{key}", f"is {value!r}; expected {spec.meaning}."
                )
            texts[key] = value
        elif not _is_number(value) or not math.isfinite(value):
            words = " / ".join(["type = …", *(f"{k} = …" for k, s in declared.items() if s.text)])
            raise ChannelMapEntryError(
                file, f"robot.{key}", f"is {value!r}; expected a number (m or rad), or {words}"
            )
        elif spec is not None and spec.positive and value <= 0:
            raise ChannelMapEntryError(
                file, f"robot.{key}", f"is {value!r}; expected a positive length in {spec.unit}."
            )
        else:
            params[key] = float(value)
    return RobotConfig(rtype, params, texts)


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


def _named_signals() -> list[str]:
    """The logical signals a channel map may name as they are (joint families by element)."""
    return [n for n in logical_signals() if n not in element_families()]


def _elements_text() -> str:
    """``, or q1, qd1, … per joint`` for the declared families of per-element signals."""
    families = list(element_families())
    return f", or {', '.join(f'{f}1' for f in families)}, … per joint" if families else ""


def _entry(file: str, name: str, entry: object, robot: RobotConfig) -> SignalSource | None:
    key = f"signals.{name}"
    if not is_logical_signal(name):
        raise ChannelMapEntryError(
            file,
            key,
            f"{name!r} is not a logical signal; expected one of {', '.join(_named_signals())}"
            f"{_elements_text()}.",
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
    if transform is not None and TRANSFORMS[transform].converts_unit and unit is not None:
        raise ChannelMapEntryError(
            file, f"{key}.unit", f'and transform = "{transform}" both convert; keep one of them.'
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
            file, f"{key}.unit", f'is {unit!r}; expected a unit name (a string, e.g. "deg").'
        )
    if unit is not None:
        si = si_unit(name)
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
    formula = parse_formula(file, f"{key}.formula", text)
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
