"""Resolution: the logical signals of one log, from a channel map's entries, the defaults, the
channel map's formulas and the robots' derived signals, each cleaned and checked.

Without a channel map, the defaults of :mod:`logtools.signals` are tried in order (our JSON
names, ROS 2 types on our topics, then the standard ROS names ``/cmd_vel``, ``/odom``,
``/joint_states``, ``/tf``), then the sources the robot plugins declare; ``/joint_states``
arrays become ``q1, q2, …``, ``qd1, …``, ``tau1, …``, and the columns of a CSV log are taken by
their logical names. Entries of a channel map (:mod:`logtools.channel_map.toml`) take precedence.

Measured signals that carry nothing (a speed, rate or angle that is zero in every sample, like
the twist of an ``Odometry`` filled only with a pose) are detected, reported with topic and
field, and not used: the next default source is tried (which signals an all-zero record means
empty is declared with each signal, ``SignalSpec.empty_when_zero``). Commands may be constant;
so may a nonzero speed or yaw rate, and a position (a robot may spin in place).

After the formulas, every robot plugin's derived signals (``RobotPlugin.derived_signals``) are
asked for the signals the log lacks (e.g. a command derived from another command and a
nominal dimension); :attr:`ResolvedSignals.origins` says how each derived signal was obtained.
A number a robot declares ``RobotKey.from_metadata`` is the channel map's ``[robot]`` entry,
else the ``logcal`` metadata record's entry of that name.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

import numpy as np
import polars as pl

from logtools.align import common_times
from logtools.channel_map.extract import (
    extract_default,
    extract_user,
    signal_frame,
    to_si,
    topic_frame,
)
from logtools.channel_map.names import (
    JOINT_TOPIC,
    command_signals,
    element_families,
    element_family,
    is_logical_signal,
    joint_arrays,
    logical_signals,
    plugin_sources,
    robot_keys,
    signal_spec,
    vocabulary,
)
from logtools.channel_map.toml import ChannelMap, parse_formula
from logtools.errors import ChannelMapEntryError, SignalValueError
from logtools.loaded import FlatSignal, ResolvedSignals
from logtools.outliers import drop_outliers
from logtools.problems import Problem
from logtools.readers import CSV_TOPIC, TIME_COLUMN, LogData
from logtools.robots import plugins
from logtools.robots.base import FoundSignals
from logtools.signals import (
    Formula,
    FormulaError,
    OriginKind,
    RobotConfig,
    RobotKey,
    SignalOrigin,
    SignalSource,
    default_candidates,
)
from logtools.validate import check_yaw_units, clean_signal

__all__ = [
    "FLAT_MIN_SAMPLES",
    "PLAUSIBLE_LIMITS",
    "resolve_signals",
]

FLAT_MIN_SAMPLES = 5
"""A signal needs at least this many samples to be called constant."""

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
        that carry nothing, and how derived signals were obtained.

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
        state.take(name, extract_user(log, name, src), src)
    skip = set(direct) | set(derived) | set(cmap.off)
    state.take_defaults(skip, user=direct)
    state.evaluate_formulas(derived)
    state.derive(cmap.off)
    signals, sources, notes = state.signals, state.sources, state.notes
    for heading in (s for s in vocabulary().values() if s.heading and s.name in signals):
        rate = heading.heading_rate
        notes += check_yaw_units(
            signals[heading.name],
            signals.get(rate) if rate else None,
            path=log.path,
            source=sources[heading.name],
            name=heading.name,
        )
    missing = [s for s in logical_signals() if s not in signals and not _any_joint(s, signals)]
    return ResolvedSignals(
        signals,
        sources,
        missing,
        notes,
        flat=state.flat,
        origins=state.origins,
        robot=state.robot,
        outliers=state.outliers,
    )


class _Resolution:
    """The signals found so far and what was noted on the way."""

    def __init__(self, log: LogData, cmap: ChannelMap) -> None:
        self.log, self.cmap = log, cmap
        self.signals: dict[str, pl.DataFrame] = {}
        self.sources: dict[str, SignalSource] = {}
        self.notes: list[str] = []
        self.flat: list[FlatSignal] = []
        self.origins: dict[str, SignalOrigin] = {}
        self.robot, self.params_from = _robot_config(log, cmap, self.notes)
        self.outliers: list[Problem] = []
        firsts = [i.first_ns for i in log.info.values() if i.first_ns is not None]
        self.origin = min(firsts, default=0)

    def take(self, name: str, frame: pl.DataFrame, src: SignalSource) -> bool:
        """Clean and keep the signal; False (and a record) when it is empty or carries nothing.

        Outliers are excluded (and recorded); values beyond :data:`PLAUSIBLE_LIMITS` refused."""
        spec = signal_spec(name)
        cleaned, repaired = clean_signal(
            frame,
            path=self.log.path,
            name=name,
            source=src,
            within_turn=spec is not None and spec.within_turn,
        )
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
                    self.take(c, signal_frame(frame, pl.col(c)), SignalSource(CSV_TOPIC, c))
            return
        candidates_by_name = default_candidates(self.cmap.tf_frame)
        for name, extra in plugin_sources().items():
            candidates_by_name.setdefault(name, []).extend(extra)
        other_bodies = _topics_of_other_bodies(user)
        for name, candidates in candidates_by_name.items():
            if name in skip:
                continue
            body = _body(name)
            for src in candidates:
                if body is not None and src.topic in other_bodies.get(body, ()):
                    continue
                found = extract_default(log, name, src)
                if found is not None and self.take(name, *found):
                    break
        joints = topic_frame(log, JOINT_TOPIC)
        if joints is None:
            return
        arrays = joint_arrays()
        for col in joints.columns:
            array, _, index = col.rpartition(".")
            if array in arrays and index.isdigit():
                name = f"{arrays[array]}{int(index) + 1}"
                if name not in skip and not _joint_family_mapped(name, user):
                    self.take(
                        name, signal_frame(joints, pl.col(col)), SignalSource(JOINT_TOPIC, col)
                    )

    def evaluate_formulas(self, derived: Mapping[str, SignalSource]) -> None:
        parsed: dict[str, Formula] = {}
        for name, src in derived.items():  # maps built in code are checked here
            parsed[name] = parse_formula(
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
        formula = parse_formula(src.origin or "", key, src.formula or "")
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
        t_ns, arrays = common_times({n: self.signals[n] for n in inputs}, held=command_signals())
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
        frame = to_si(frame, src).with_columns(pl.col("value").fill_nan(None))
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
        if self.take(name, frame, src):
            self.origins[name] = SignalOrigin(
                OriginKind.FORMULA, src.formula or "", f"channel-map formula {src.formula}"
            )

    def derive(self, off: frozenset[str]) -> None:
        """Every robot plugin's derived signals (``RobotPlugin.derived_signals``): one the log
        lacks (and the channel map does not switch off) is derived, one it holds is recorded as
        logged; then each derivation's check adds its notes."""
        derivations = [d for p in plugins() for d in p.derived_signals]
        for d in derivations:
            if d.name in self.signals:
                if d.name not in self.origins:
                    src = self.sources[d.name]
                    self.origins[d.name] = SignalOrigin(
                        OriginKind.LOGGED, f"{src.topic}:{src.field}", f"logged on {src.describe()}"
                    )
                continue
            if d.name in off:
                continue
            got = d.derive(self.found())
            self.notes += got.notes
            if got.signal is not None and got.source is not None:
                self.signals[d.name], self.sources[d.name] = got.signal, got.source
                if got.origin is not None:
                    self.origins[d.name] = got.origin
        found = self.found()
        for d in derivations:
            if d.check is not None:
                self.notes += d.check(found)

    def found(self) -> FoundSignals:
        """The signals found so far, as a derivation sees them."""
        return FoundSignals(self.log.path, self.signals, self.sources, self.robot, self.params_from)


def _robot_config(
    log: LogData, cmap: ChannelMap, notes: list[str]
) -> tuple[RobotConfig, dict[str, str]]:
    """The channel map's [robot] table completed from the ``logcal`` metadata record (the keys
    a robot declares ``from_metadata``), and where each of those numbers came from."""
    robot, where = cmap.robot, {}
    for key in (k for k in robot_keys().values() if k.from_metadata and not k.text):
        meta = _metadata_number(log, key, notes)
        given = robot.number(key.name)
        if given is not None:
            where[key.name] = f"the channel map {cmap.path}".rstrip() + f" [robot] {key.name}"
            if meta is not None and not math.isclose(meta, given, rel_tol=1e-9):
                notes.append(
                    f"{log.path}: the channel map's {key.name} {given:g} {key.unit} differs from "
                    f"the logcal metadata record's {meta:g} {key.unit}; the channel map's is used"
                )
        elif meta is not None:
            robot = replace(robot, params={**robot.params, key.name: meta})
            where[key.name] = "the logcal metadata record"
    return robot, where


def _metadata_number(log: LogData, key: RobotKey, notes: list[str]) -> float | None:
    """The ``logcal`` metadata record's number ``key.name``; None (with a note when it is there
    but not a usable number)."""
    text = log.metadata.get("logcal", {}).get(key.name)
    if text is None:
        return None
    try:
        meta: float | None = float(text)
    except ValueError:
        meta = None
    if meta is None or not math.isfinite(meta) or (key.positive and meta <= 0):
        what = "a positive number" if key.positive else "a number"
        notes.append(
            f"{log.path}: the logcal metadata record's {key.name} {text!r} is not {what}; ignored"
        )
        return None
    return meta


def _flatness(name: str, frame: pl.DataFrame, src: SignalSource) -> FlatSignal | None:
    """A record when a measured rate or angle is zero in every sample (an empty twist, an
    unconnected encoder, an orientation never filled in). Commands, positions (a robot may spin
    in place) and joint signals are never flagged, nor a nonzero constant (a circle driven at
    constant speed)."""
    spec = signal_spec(name)
    if spec is None or not spec.empty_when_zero or frame.height < FLAT_MIN_SAMPLES:
        return None
    values = frame["value"].to_numpy()
    if np.any(np.abs(values) > 1e-12):
        return None
    return FlatSignal(name, src.topic, src.field, 0.0, frame.height)


def _body(name: str) -> str | None:
    spec = signal_spec(name)
    return spec.body if spec is not None else None


def _topics_of_other_bodies(user: Mapping[str, SignalSource]) -> dict[str, set[str]]:
    """Per body, the topics the channel map reads another body's pose from: those give this
    body's pose by no default name (a second body tracked on ``/odom`` is not the base)."""
    mapped = {(b, s.topic) for n, s in user.items() if (b := _body(n)) is not None}
    bodies = {b for b, _ in mapped} | {s.body for s in vocabulary().values() if s.body is not None}
    return {b: {t for other, t in mapped if other != b} for b in bodies}


def _joint_family_mapped(name: str, user: Mapping[str, SignalSource]) -> bool:
    """A user map naming any element of a family (``NAME1``, ``NAME2``, …) replaces the
    family's default elements altogether."""
    family = element_family(name)
    return family is not None and any(element_family(k) == family for k in user)


def _check_plausible(path: str, name: str, frame: pl.DataFrame, src: SignalSource) -> None:
    """Refuse a signal holding values no robot produces in its SI unit (see PLAUSIBLE_LIMITS)."""
    spec = signal_spec(name)
    unit = spec.unit if spec is not None else None
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
    return family in element_families() and any(element_family(k) == family for k in signals)
