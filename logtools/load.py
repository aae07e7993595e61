"""Load a drive log into one aligned frame: read -> resolve signals -> align -> derive kappa.

``load_log`` composes :func:`logtools.readers.read_log`,
:func:`logtools.channel_map.resolve_signals`, :func:`logtools.robot.infer_robot`,
:func:`logtools.align.align_signals` (its module docstring gives the alignment method and
tolerance), :func:`logtools.align.find_gaps` and :func:`logtools.curvature.derive_kappa`.
The signal resolution excludes single-sample outliers (:mod:`logtools.outliers`); they are
listed in ``problems`` with their times.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import polars as pl

from logtools.align import AlignMethod, Gap, align_signals, find_gaps
from logtools.channel_map import ResolvedSignals, resolve_signals
from logtools.curvature import KappaCmdOrigin
from logtools.errors import MissingSignalsError
from logtools.problems import Problem, ProblemKind
from logtools.readers import DEFAULT_DECODERS, ColumnFilter, Decoders, LogData, read_log
from logtools.robot import METADATA_RECORD, infer_robot
from logtools.signals import RobotConfig, SignalSource

__all__ = ["LoadedLog", "gap_notes", "load_log", "metadata_truth"]

_NOT_TRUTH = ("robot", "seed")


@dataclass(frozen=True)
class LoadedLog:
    """A log read, resolved and aligned.

    Attributes:
        path: the file read.
        log: the raw frames per topic.
        signals: the logical signals found (raw per-signal frames ``signals.signals``), where
            they came from, the ones that carry nothing, and how kappa_cmd was obtained.
        frame: aligned frame (``t_ns`` + one float64 column per signal, plus ``kappa`` (1/m)
            and ``kappa_source`` when odometry, pose or steering allow it).
        robot: the robot type, a plugin's name (channel map, metadata, else inferred from the
            signals).
        truth: true parameters from the ``logcal`` metadata record (simulated logs).
        problems: what was lost or repaired, from reading to alignment (``str(p)`` is the
            sentence; the signal resolution's sentences are ``ProblemKind.SIGNAL`` records).
        gaps: recorder stalls and dropouts of the signals, one record per stretch of time.
    """

    path: str
    log: LogData
    signals: ResolvedSignals
    frame: pl.DataFrame
    robot: str
    truth: dict[str, float]
    problems: list[Problem]
    gaps: list[Gap] = field(default_factory=list)

    @property
    def kappa_cmd_origin(self) -> KappaCmdOrigin | None:
        """How ``kappa_cmd`` was obtained (logged, formula, steering, twist); None without it."""
        return self.signals.kappa_cmd_origin

    @property
    def robot_config(self) -> RobotConfig:
        """The channel map's [robot] table (wheelbase completed from the metadata record)."""
        return self.signals.robot


def metadata_truth(metadata: Mapping[str, Mapping[str, str]]) -> dict[str, float]:
    """Numeric entries of the ``logcal`` metadata record (not ``robot`` or ``seed``)."""
    out: dict[str, float] = {}
    for key, text in metadata.get(METADATA_RECORD, {}).items():
        if key in _NOT_TRUTH:
            continue
        try:
            value = float(text)
        except (TypeError, ValueError):
            continue
        if math.isfinite(value):
            out[key] = value
    return out


def _span_signals(span: tuple[str, ...], names: list[str]) -> list[str]:
    """The signals among ``names`` whose common span sets the aligned frame: those the robot
    names in ``span`` (a joint signal ``q3`` matches ``q``); all when none match."""
    chosen = [n for n in names if n in span or n.rstrip("0123456789") in span]
    return chosen or names


def gap_notes(path: str, gaps: list[Gap], names: list[str], origin_ns: int) -> list[Problem]:
    """One ``GAP`` record per gap for ``problems`` (sentence times relative to ``origin_ns``;
    ``topic`` is the one signal without samples, None when several are)."""
    notes = []
    for gap in gaps:
        who = (
            f"every signal ({len(gap.signals)}) at once: a recorder stall"
            if set(names) <= set(gap.signals)
            else f"signals {', '.join(gap.signals)}"
        )
        notes.append(
            Problem(
                ProblemKind.GAP,
                gap.signals[0] if len(gap.signals) == 1 else None,
                gap.t0_ns,
                gap.t1_ns,
                count=len(gap.signals),
                message=f"{path}: no samples for {gap.duration_s:.2f} s from "
                f"{(gap.t0_ns - origin_ns) * 1e-9:.3f} s to "
                f"{(gap.t1_ns - origin_ns) * 1e-9:.3f} s (relative to the first sample) on "
                f"{who}; aligned rows there are null",
            )
        )
    return notes


def _null_notes(path: str, frame: pl.DataFrame, gaps: list[Gap]) -> list[Problem]:
    """Null rows per signal that the gaps (reported once each) do not explain."""
    notes = []
    t = frame["t_ns"].to_numpy()
    for name in frame.columns:
        if name == "t_ns":
            continue
        null = frame[name].is_null().to_numpy()
        base = name.split(".", 1)[0]
        for gap in gaps:
            if base in gap.signals:
                null &= ~gap.covers(t)
        k = int(np.count_nonzero(null))
        if k:
            notes.append(
                Problem(
                    ProblemKind.DROPOUT,
                    name,
                    count=k,
                    message=f"{path}: signal {name!r} has no sample within the alignment "
                    f"tolerance on {k} of {frame.height} aligned rows (dropouts or a shorter "
                    "recording); those rows are null",
                )
            )
    return notes


_COVARIANCE = re.compile(r"(^|\.)covariance\.\d+$")


def analysis_columns(
    channel_map: Mapping[str, SignalSource] | None = None,
) -> ColumnFilter | None:
    """The columns ``load_log`` reads: all but covariance matrices (``pose.covariance.0`` ..
    ``.35`` of ROS Odometry and PoseWithCovariance), unless the channel map names one.

    No estimator uses a covariance the log carries (each measures its own noise), and they
    are most of a ROS 2 log's frames: 72 of /odom's 90 columns, 380 of 420 MB on a 1-hour
    100 Hz log (issue 14). ``read_log`` and ``logcal info`` still read everything.
    """
    sources = getattr(channel_map, "signals", channel_map) or {}
    if any("covariance" in str(getattr(s, "field", "")) for s in sources.values()):
        return None
    return lambda _topic, column: _COVARIANCE.search(column) is None


def load_log(
    path: str | os.PathLike[str],
    channel_map: Mapping[str, SignalSource] | None = None,
    *,
    rate_hz: float | None = None,
    method: AlignMethod = AlignMethod.INTERPOLATE,
    decoders: Decoders = DEFAULT_DECODERS,
) -> LoadedLog:
    """Read ``path`` (MCAP, ROS bag or CSV) and align its logical signals on one time base.

    Args:
        path: the log file, rosbag2 folder or ROS 1 bag.
        channel_map: a :class:`logtools.channel_map.ChannelMap` or signal -> source mapping
            overriding the default topic/field names.
        rate_hz: rate (Hz) of the aligned grid; None: the fastest signal's median rate.
        method: interpolation or nearest-sample for continuous signals (commands are held).
        decoders: MCAP message encoding -> decoder, as :func:`logtools.readers.read_log`.

    Raises:
        LogcalInputError: the file cannot be read, no logical signal is found, or the signals
            cannot be put on one time base (subclasses name file, topic and field).
    """
    log = read_log(path, decoders=decoders, keep=analysis_columns(channel_map))
    resolved = resolve_signals(log, channel_map)
    from logtools.robots import plugin_for

    robot = infer_robot(log, resolved)
    plugin = plugin_for(robot, where=log.path)
    if not resolved.signals:
        raise MissingSignalsError(log.path, list(plugin.required), log.topic_names(), robot)
    names = list(resolved.signals)
    frame = align_signals(
        resolved.signals,
        rate_hz=rate_hz,
        method=method,
        required=_span_signals(plugin.span_signals, names),
    )
    gaps = find_gaps(resolved.signals)
    origin = min((i.first_ns for i in log.info.values() if i.first_ns is not None), default=0)
    problems = [
        *log.problems,
        *(Problem(ProblemKind.SIGNAL, message=p) for p in resolved.problems),
        *resolved.outliers,
        *gap_notes(log.path, gaps, names, origin),
        *_null_notes(log.path, frame, gaps),
    ]
    if plugin.prepare is not None:
        frame = plugin.prepare(frame, resolved.robot)
    return LoadedLog(
        path=log.path,
        log=log,
        signals=resolved,
        frame=frame,
        robot=robot,
        truth=metadata_truth(log.metadata),
        problems=problems,
        gaps=gaps,
    )
