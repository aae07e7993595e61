"""What a log holds, for ``logcal info``: topics, signals found and where from, robot, gaps,
problems."""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from calib.results import json_safe
from logtools.align import Gap, find_gaps
from logtools.errors import NoDriveSignalsError
from logtools.load import gap_notes, read_and_resolve
from logtools.loaded import FlatSignal
from logtools.readers import TopicInfo
from logtools.readers.base import TIME_COLUMN
from logtools.robot import explain_robot
from logtools.safe_text import printable
from logtools.signals import SignalOrigin, SignalSource

__all__ = ["LogSummary", "SignalSummary", "summarize_log"]


@dataclass(frozen=True)
class SignalSummary:
    """One logical signal found: source, sample count, time span (ns) and value range.

    ``source`` describes the source in one string (topic:field and scale, unit, stamp, frame;
    ``= formula`` for a derived signal).
    """

    name: str
    topic: str
    field: str
    transform: str | None
    samples: int
    first_ns: int
    last_ns: int
    min: float
    max: float
    source: str = ""


@dataclass(frozen=True)
class LogSummary:
    """The answer of ``logcal info``.

    Attributes:
        path: the log.
        topics: per topic: schema, encodings, message count, time span (ns).
        signals: logical signals found, by name.
        missing: logical signals not found.
        robot: robot type, None when neither metadata nor signals tell it.
        robot_reason: where the robot type came from, or why it is unknown.
        metadata: MCAP metadata records.
        problems: what was lost or repaired while reading and resolving signals.
        gaps: recorder stalls and dropouts of the signals found (one record per stretch).
        flat: signals found but not used because they carry nothing.
        origins: how derived signals were obtained (a formula, a robot's derivation), and for
            a signal a robot could derive, that it was logged.
    """

    path: str
    topics: list[TopicInfo]
    signals: dict[str, SignalSummary]
    missing: list[str]
    robot: str | None
    robot_reason: str
    metadata: dict[str, dict[str, str]]
    problems: list[str]
    gaps: list[Gap] = field(default_factory=list)
    flat: list[FlatSignal] = field(default_factory=list)
    origins: dict[str, SignalOrigin] = field(default_factory=dict)
    fields: dict[str, list[str]] = field(default_factory=dict)
    """Per topic read, its fields as the channel map and ``--signal`` name them (a CSV's
    columns)."""

    @property
    def span_ns(self) -> tuple[int, int] | None:
        """First and last log_time over all topics (ns), None without messages."""
        firsts = [t.first_ns for t in self.topics if t.first_ns is not None]
        lasts = [t.last_ns for t in self.topics if t.last_ns is not None]
        return (min(firsts), max(lasts)) if firsts else None

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary (the ``--json`` document)."""
        span = self.span_ns
        return json_safe(
            {
                "path": self.path,
                "start_ns": span[0] if span else None,
                "end_ns": span[1] if span else None,
                "duration_s": (span[1] - span[0]) * 1e-9 if span else None,
                "topics": [
                    {
                        "topic": t.topic,
                        "schema_name": t.schema_name,
                        "schema_encoding": t.schema_encoding,
                        "message_encoding": t.message_encoding,
                        "message_count": t.message_count,
                        "first_ns": t.first_ns,
                        "last_ns": t.last_ns,
                        "rate_hz": t.rate_hz,
                        "fields": self.fields.get(t.topic, []),
                    }
                    for t in self.topics
                ],
                "signals": {n: vars(s) for n, s in self.signals.items()},
                "missing": self.missing,
                "robot": self.robot,
                "robot_reason": self.robot_reason,
                "metadata": self.metadata,
                "problems": self.problems,
                "gaps": [g.to_dict() for g in self.gaps],
                "flat": [vars(f) for f in self.flat],
                "origins": {n: o.to_dict() for n, o in self.origins.items()},
            }
        )

    def report(self) -> str:
        """A plain-text report for the terminal."""
        span = self.span_ns
        lines = [f"log: {self.path}"]
        if span:
            dur = (span[1] - span[0]) * 1e-9
            lines.append(f"time span: {dur:.3f} s (log_time {span[0]} .. {span[1]} ns)")
        lines.append(f"robot: {self.robot or 'unknown'} ({self.robot_reason})")
        if self.robot:
            from logtools.robots import plugin_for

            plugin = plugin_for(self.robot)
            need = [s.name for s in plugin.signals if s.required and s.name not in self.signals]
            lines.append(
                f"  {plugin.title}; it reads "
                + ", ".join(f"{s.name} ({s.unit})" for s in plugin.signals)
                + (f"; required but not found: {', '.join(need)}" if need else "")
            )
        lines.append(f"topics ({len(self.topics)}):")
        for t in self.topics:
            rate = f"{t.rate_hz:.1f} Hz" if t.rate_hz else "-"
            lines.append(
                f"  {t.topic}  {t.schema_name or '-'}  [{t.message_encoding}/"
                f"{t.schema_encoding or '-'}]  {t.message_count} msgs  {rate}"
            )
            if self.fields.get(t.topic):
                lines.append(f"    fields: {', '.join(self.fields[t.topic])}")
        lines.append(f"signals found ({len(self.signals)}):")
        for s in self.signals.values():
            how = f" via {s.transform}" if s.transform else ""
            src = f"{s.topic} : {s.field}{how}" if not s.source.startswith("=") else s.source
            lines.append(
                f"  {s.name:<11} <- {src}  {s.samples} samples  [{s.min:.4g}, {s.max:.4g}]"
            )
        if not self.signals:
            lines.append("  (no drive signals; see the topics above)")
        lines += [f"{name}: {o.description}" for name, o in self.origins.items()]
        for f in self.flat:
            lines.append(
                f"not used (carries nothing): {f.name} <- {f.topic} : {f.field}, "
                f"{f.value:g} in all {f.samples} samples"
            )
        lines.append(f"signals missing: {', '.join(self.missing) or '(none)'}")
        if self.gaps:
            origin = span[0] if span else 0
            lines.append(f"gaps ({len(self.gaps)}):")
            every = set(self.signals) - _by_robot(self.origins)
            for g in self.gaps:
                who = "all signals" if every <= set(g.signals) else ", ".join(g.signals)
                lines.append(
                    f"  {(g.t0_ns - origin) * 1e-9:.3f} s .. {(g.t1_ns - origin) * 1e-9:.3f} s  "
                    f"({g.duration_s:.2f} s)  {who}"
                )
        if self.metadata:
            lines.append("metadata: " + ", ".join(sorted(self.metadata)))
        if self.problems:
            lines.append(f"problems ({len(self.problems)}):")
            lines += [f"  - {p}" for p in self.problems]
        # names and values come from the log: each line is escaped before the lines are joined,
        # so a control character or newline in a topic name cannot reach the terminal
        return "\n".join(printable(line) for line in lines)


def _by_robot(origins: Mapping[str, SignalOrigin]) -> set[str]:
    """The signals a robot derived (not recorded: their gaps are not the recording's)."""
    return {n for n, o in origins.items() if o.by_robot}


def summarize_log(
    path: str | os.PathLike[str], channel_map: Mapping[str, SignalSource] | None = None
) -> LogSummary:
    """Read ``path`` (MCAP, ROS bag or CSV) and summarise it (see :class:`LogSummary`).

    Raises:
        LogcalInputError: the log cannot be read or a signal cannot be repaired.
    """
    log, resolved = read_and_resolve(path, channel_map)  # a LoadRequest: crop, ground truth
    try:
        robot, reason = explain_robot(log, resolved)
        robot_name: str | None = robot
    except NoDriveSignalsError:
        robot_name, reason = None, "no logcal metadata and no drive signals"
    signals = {}
    for name, frame in resolved.signals.items():
        src = resolved.sources[name]
        values, times = frame["value"], frame["t_ns"]
        signals[name] = SignalSummary(
            name=name,
            topic=src.topic,
            field=src.field,
            transform=src.transform,
            samples=frame.height,
            first_ns=int(times.min()),  # type: ignore[arg-type]
            last_ns=int(times.max()),  # type: ignore[arg-type]
            min=float(values.min()),  # type: ignore[arg-type]
            max=float(values.max()),  # type: ignore[arg-type]
            source=src.describe(),
        )
    # a signal a robot derived is undefined where its inputs do not define it (the
    # tractor-trailer's omega_cmd / v_cmd while the commanded speed is zero, a stop or a spot
    # turn): those stretches are not gaps of the recording, whose own gaps show in the inputs
    recorded = {k: v for k, v in resolved.signals.items() if k not in _by_robot(resolved.origins)}
    gaps = find_gaps(recorded)
    origin = min((i.first_ns for i in log.info.values() if i.first_ns is not None), default=0)
    return LogSummary(
        path=log.path,
        topics=[log.info[t] for t in log.topic_names()],
        fields={
            t: [c for c in frame.columns if c != TIME_COLUMN] for t, frame in log.topics.items()
        },
        signals=signals,
        missing=resolved.missing,
        robot=robot_name,
        robot_reason=reason,
        metadata=log.metadata,
        problems=[
            *map(str, log.problems),
            *resolved.problems,
            *map(str, gap_notes(log.path, gaps, list(recorded), origin)),
        ],
        gaps=gaps,
        flat=resolved.flat,
        origins=dict(resolved.origins),
    )
