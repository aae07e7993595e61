"""Load a log into one aligned frame: read -> resolve signals -> align -> the robot completes it.

``load_log`` composes :func:`logtools.readers.read_log`,
:func:`logtools.channel_map.resolve_signals`, :func:`logtools.robot.infer_robot`,
:func:`logtools.align.align_signals` (its module docstring gives the alignment method and
tolerance), :func:`logtools.align.find_gaps` and the robot plugin's ``prepare`` (the
tractor-trailer's measured curvature); the result is a :class:`~logtools.loaded.LoadedLog`
(a record of :mod:`logtools.loaded`, named here too).
The signal resolution excludes single-sample outliers (:mod:`logtools.outliers`); they are
listed in ``problems`` with their times.

What the command line adds to reading a log travels with the channel map, so that every library
call that takes one (``analyze_logs``, ``analyze_log``, ``batch``) honours it: a
:class:`LoadRequest` is a channel map plus a ground-truth file joined as ``x``, ``y``, ``yaw``
(``--ground-truth``) and a span to keep (``--start``/``--end``, seconds from the log's start).
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import polars as pl

from logtools.align import AlignMethod, Gap, align_signals, find_gaps
from logtools.channel_map import ChannelMap, resolve_signals
from logtools.channel_map.names import command_signals, heading_signals
from logtools.errors import LogcalInputError, MissingSignalsError
from logtools.loaded import LoadedLog, ResolvedSignals
from logtools.problems import Problem, ProblemKind
from logtools.readers import (
    DEFAULT_DECODERS,
    ColumnFilter,
    Decoders,
    LogData,
    in_span,
    read_log,
)
from logtools.robot import METADATA_RECORD, infer_robot
from logtools.signals import SignalSource

__all__ = [
    "GROUND_TRUTH_SIGNALS",
    "LoadRequest",
    "LoadedLog",
    "crop_log",
    "gap_notes",
    "join_ground_truth",
    "load_log",
    "metadata_truth",
    "read_and_resolve",
    "read_input",
]

GROUND_TRUTH_SIGNALS = ("x", "y", "yaw")
"""The signals a ground-truth file (``--ground-truth``) gives."""


@dataclass(frozen=True, eq=False)
class LoadRequest(ChannelMap):
    """A channel map plus what else the command line asks of reading a log.

    Attributes:
        ground_truth: a pose file (TUM ``t x y z qx qy qz qw``, or any log with ``x``, ``y``,
            ``yaw``) on the log's clock whose ``x``, ``y``, ``yaw`` replace the log's own.
        start_s: keep samples from this many seconds after the log's first sample (None: 0).
        end_s: keep samples up to this many seconds after the log's first sample (None: all).
        origin_ns: the time (ns) ``start_s`` and ``end_s`` count from, when known before
            reading (a windowed analysis): the read then asks the reader for that span only
            (:func:`logtools.readers.read_log` ``span_ns``). None: the log's first sample.
    """

    ground_truth: str | None = None
    start_s: float | None = None
    end_s: float | None = None
    origin_ns: int | None = None

    @classmethod
    def of(
        cls,
        channel_map: ChannelMap | None,
        *,
        ground_truth: str | os.PathLike[str] | None = None,
        start_s: float | None = None,
        end_s: float | None = None,
        origin_ns: int | None = None,
    ) -> ChannelMap | None:
        """``channel_map`` with these settings (unchanged when none is given)."""
        if ground_truth is None and start_s is None and end_s is None:
            return channel_map
        base = channel_map if channel_map is not None else ChannelMap()
        return cls(
            dict(base.signals),
            base.off,
            base.robot,
            base.tf_frame,
            base.path,
            ground_truth=os.fspath(ground_truth) if ground_truth is not None else None,
            start_s=start_s,
            end_s=end_s,
            origin_ns=origin_ns,
        )


_NOT_TRUTH = ("robot", "seed")


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
    100 Hz log. ``read_log`` and ``logcal info`` still read everything.
    """
    sources = getattr(channel_map, "signals", channel_map) or {}
    if any("covariance" in str(getattr(s, "field", "")) for s in sources.values()):
        return None
    return lambda _topic, column: _COVARIANCE.search(column) is None


def _log_origin(log: LogData) -> int | None:
    firsts = [i.first_ns for i in log.info.values() if i.first_ns is not None]
    return min(firsts) if firsts else None


def _log_end(log: LogData) -> int | None:
    lasts = [i.last_ns for i in log.info.values() if i.last_ns is not None]
    return max(lasts) if lasts else None


def crop_log(
    log: LogData,
    start_s: float | None = None,
    end_s: float | None = None,
    *,
    origin_ns: int | None = None,
) -> LogData:
    """``log`` with only the samples from ``start_s`` to ``end_s`` seconds after ``origin_ns``
    (default: the log's first sample); a ``SIGNAL`` problem says what was kept.

    Raises:
        LogcalInputError: a negative start, an end not after the start, or a start at or after
            the log's end (the message names the file and the log's duration).
    """
    if start_s is None and end_s is None:
        return log
    origin = _log_origin(log) if origin_ns is None else origin_ns
    last = _log_end(log)
    if origin is None or last is None:
        return log
    duration = (last - origin) * 1e-9
    lo = 0.0 if start_s is None else float(start_s)
    hi = math.inf if end_s is None else float(end_s)
    if not math.isfinite(lo) or lo < 0 or math.isnan(hi):
        raise LogcalInputError(
            f"{log.path}: --start {lo:g} s: expected seconds >= 0 from the log's start"
        )
    if hi <= lo:
        raise LogcalInputError(f"{log.path}: --end {hi:g} s is not after --start {lo:g} s")
    if origin_ns is None and lo >= duration:
        raise LogcalInputError(
            f"{log.path}: --start {lo:g} s is at or after the log's end ({duration:.3f} s "
            "after its first sample)"
        )
    t0 = origin + round(lo * 1e9)
    t1 = last if math.isinf(hi) else origin + round(hi * 1e9)
    cut = in_span(log, t0, t1)
    shown_hi = min(hi, duration)
    note = Problem(
        ProblemKind.SIGNAL,
        message=f"{log.path}: cropped to {lo:.3f} s .. {shown_hi:.3f} s after the log's first "
        f"sample (--start/--end; the log spans {duration:.3f} s)",
    )
    return LogData(log.path, cut.topics, cut.info, log.metadata, [*log.problems, note])


def read_input(
    path: str | os.PathLike[str],
    channel_map: Mapping[str, SignalSource] | None = None,
    *,
    decoders: Decoders = DEFAULT_DECODERS,
    keep: ColumnFilter | None = None,
) -> LogData:
    """Read ``path`` with :func:`logtools.readers.read_log` (any registered format, TUM
    trajectories included); cropped as a :class:`LoadRequest` says."""
    span = None
    if isinstance(channel_map, LoadRequest) and channel_map.origin_ns is not None:
        o = channel_map.origin_ns
        span = (
            o + round((channel_map.start_s or 0.0) * 1e9),
            o + round(channel_map.end_s * 1e9) if channel_map.end_s is not None else 2**63 - 1,
        )
    log = read_log(path, decoders=decoders, keep=keep, span_ns=span)
    if isinstance(channel_map, LoadRequest):
        log = crop_log(log, channel_map.start_s, channel_map.end_s, origin_ns=channel_map.origin_ns)
    return log


def read_and_resolve(
    path: str | os.PathLike[str],
    channel_map: Mapping[str, SignalSource] | None = None,
    *,
    decoders: Decoders = DEFAULT_DECODERS,
    keep: ColumnFilter | None = None,
) -> tuple[LogData, ResolvedSignals]:
    """Read ``path`` (:func:`read_input`) and find its logical signals, with a
    :class:`LoadRequest`'s span and ground truth applied (what ``load_log`` and ``logcal info``
    read)."""
    log = read_input(path, channel_map, decoders=decoders, keep=keep)
    resolved = resolve_signals(log, channel_map)
    if isinstance(channel_map, LoadRequest) and channel_map.ground_truth is not None:
        crop = channel_map.start_s is not None or channel_map.end_s is not None
        resolved = join_ground_truth(log, resolved, channel_map.ground_truth, crop=crop)
    return log, resolved


def join_ground_truth(
    log: LogData,
    resolved: ResolvedSignals,
    ground_truth: str | os.PathLike[str],
    *,
    crop: bool = False,
) -> ResolvedSignals:
    """``resolved`` (the signals of ``log``) with ``x``, ``y``, ``yaw`` taken from the
    ground-truth file instead.

    The file (TUM, or any log logcal reads that has ``x``, ``y``, ``yaw``) must be stamped on
    ``log``'s clock; with ``crop`` it is cut to the span ``log`` covers (a cropped log).

    Raises:
        LogcalInputError: the file cannot be read, has no pose, or shares no time with the log.
    """
    gt_path = os.fspath(ground_truth)
    gt_log = read_log(gt_path)
    origin, last = _log_origin(log), _log_end(log)
    if crop and origin is not None and last is not None and last > origin:
        gt_log = crop_log(gt_log, 0.0, (last - origin) * 1e-9, origin_ns=origin)
    gt = resolve_signals(gt_log)
    have = [n for n in GROUND_TRUTH_SIGNALS if n in gt.signals]
    if not {"x", "y"} <= set(have):
        raise LogcalInputError(
            f"{gt_path}: a ground truth needs the pose x, y (and yaw); it holds "
            f"{', '.join(sorted(gt.signals)) or 'no signal'}"
        )
    g0 = min(int(gt.signals[n]["t_ns"][0]) for n in have)
    g1 = max(int(gt.signals[n]["t_ns"][-1]) for n in have)
    if origin is None or last is None or g1 < origin or g0 > last:
        raise LogcalInputError(
            f"{gt_path}: its poses span {g0 * 1e-9:.3f} .. {g1 * 1e-9:.3f} s and the log "
            f"{log.path} {(origin or 0) * 1e-9:.3f} .. {(last or 0) * 1e-9:.3f} s: no common "
            "time. The ground truth must be stamped on the log's clock (e.g. both in epoch "
            "seconds)."
        )
    name = Path(gt_path).name
    signals = {k: v for k, v in resolved.signals.items() if k not in GROUND_TRUTH_SIGNALS}
    sources = {k: v for k, v in resolved.sources.items() if k not in GROUND_TRUTH_SIGNALS}
    notes = list(resolved.problems)
    replaced = [n for n in GROUND_TRUTH_SIGNALS if n in resolved.signals]
    if replaced:
        notes.append(
            f"{log.path}: {', '.join(replaced)} taken from the ground truth {gt_path}, not from "
            + ", ".join(sorted({resolved.sources[n].describe() for n in replaced}))
        )
    for n in have:
        signals[n] = gt.signals[n]
        src = gt.sources[n]
        sources[n] = SignalSource(name, src.field, src.transform, origin=gt_path)
    notes += [str(p) for p in gt_log.problems] + list(gt.problems)
    return ResolvedSignals(
        signals,
        sources,
        [m for m in resolved.missing if m not in have],
        notes,
        flat=resolved.flat,
        origins=resolved.origins,
        robot=resolved.robot,
        outliers=[*resolved.outliers, *gt.outliers],
    )


def load_log(
    path: str | os.PathLike[str],
    channel_map: Mapping[str, SignalSource] | None = None,
    *,
    rate_hz: float | None = None,
    method: AlignMethod = AlignMethod.INTERPOLATE,
    decoders: Decoders = DEFAULT_DECODERS,
    ground_truth: str | os.PathLike[str] | None = None,
    start_s: float | None = None,
    end_s: float | None = None,
) -> LoadedLog:
    """Read ``path`` (MCAP, ROS bag, CSV or a TUM trajectory) and align its logical signals on
    one time base.

    Args:
        path: the log file, rosbag2 folder or ROS 1 bag.
        channel_map: a :class:`logtools.channel_map.ChannelMap` or signal -> source mapping
            overriding the default topic/field names; a :class:`LoadRequest` also carries the
            three settings below.
        ground_truth: a pose file on the log's clock (TUM) whose x, y, yaw replace the log's.
        start_s: keep the samples from this many seconds after the log's first sample.
        end_s: keep the samples up to this many seconds after the log's first sample.
        rate_hz: rate (Hz) of the aligned grid; None: the fastest signal's median rate.
        method: interpolation or nearest-sample for continuous signals (commands are held).
        decoders: MCAP message encoding -> decoder, as :func:`logtools.readers.read_log`.

    Raises:
        LogcalInputError: the file cannot be read, no logical signal is found, or the signals
            cannot be put on one time base (subclasses name file, topic and field).
    """
    if ground_truth is not None or start_s is not None or end_s is not None:
        req = channel_map if isinstance(channel_map, LoadRequest) else LoadRequest()
        base = (
            channel_map
            if isinstance(channel_map, ChannelMap)
            else ChannelMap(dict(channel_map or {}))
        )
        channel_map = LoadRequest.of(
            base,
            ground_truth=req.ground_truth if ground_truth is None else ground_truth,
            start_s=req.start_s if start_s is None else start_s,
            end_s=req.end_s if end_s is None else end_s,
            origin_ns=req.origin_ns,
        )
    log, resolved = read_and_resolve(
        path, channel_map, decoders=decoders, keep=analysis_columns(channel_map)
    )
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
        hold=command_signals(),
        wrap=heading_signals(),
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
