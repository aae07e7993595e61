"""Load a drive log into one aligned frame: read -> resolve signals -> align -> derive kappa.

``load_log`` composes :func:`logtools.readers.read_log`,
:func:`logtools.channel_map.resolve_signals`, :func:`logtools.robot.infer_robot`,
:func:`logtools.align.align_signals` (its module docstring gives the alignment method and
tolerance) and :func:`logtools.curvature.derive_kappa`.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass

import polars as pl

from logtools.align import AlignMethod, align_signals
from logtools.channel_map import ResolvedSignals, resolve_signals
from logtools.curvature import derive_kappa
from logtools.errors import MissingSignalsError
from logtools.readers import LogData, read_log
from logtools.robot import METADATA_RECORD, infer_robot
from logtools.signals import ROBOT_REQUIRED_SIGNALS, Robot, SignalSource

__all__ = ["LoadedLog", "load_log", "metadata_truth"]

# Signals whose common span sets the aligned frame, per robot (those present in the log).
_SPAN_SIGNALS: dict[Robot, tuple[str, ...]] = {
    Robot.TRACTOR_TRAILER: ("psi", "kappa_cmd", "v", "omega", "x", "y", "yaw"),
    Robot.DIFF_DRIVE: ("wheel_left", "wheel_right", "v_cmd", "omega_cmd", "v", "omega"),
    Robot.MANIPULATOR_2LINK: (),  # every joint signal (q1, tau1, ...)
}
_NOT_TRUTH = ("robot", "seed")


@dataclass(frozen=True)
class LoadedLog:
    """A log read, resolved and aligned.

    Attributes:
        path: the file read.
        log: the raw frames per topic.
        signals: the logical signals found and where they came from.
        frame: aligned frame (``t_ns`` + one float64 column per signal, plus ``kappa`` (1/m)
            and ``kappa_source`` when odometry or pose allow it).
        robot: the robot type (metadata, else inferred from the signals).
        truth: true parameters from the ``logcal`` metadata record (simulated logs).
        problems: what was lost or repaired, from reading to alignment.
    """

    path: str
    log: LogData
    signals: ResolvedSignals
    frame: pl.DataFrame
    robot: Robot
    truth: dict[str, float]
    problems: list[str]


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


def _span_signals(robot: Robot, names: list[str]) -> list[str]:
    if robot is Robot.MANIPULATOR_2LINK:
        chosen = [n for n in names if n.rstrip("0123456789") in ("q", "qd", "tau")]
    else:
        chosen = [n for n in names if n in _SPAN_SIGNALS[robot]]
    return chosen or names


def _null_notes(path: str, frame: pl.DataFrame) -> list[str]:
    notes = []
    for name in frame.columns:
        if name == "t_ns":
            continue
        k = frame[name].null_count()
        if k:
            notes.append(
                f"{path}: signal {name!r} has no sample within the alignment tolerance on "
                f"{k} of {frame.height} aligned rows (dropouts or a shorter recording); "
                "those rows are null"
            )
    return notes


def load_log(
    path: str | os.PathLike[str],
    channel_map: Mapping[str, SignalSource] | None = None,
    *,
    rate_hz: float | None = None,
    method: AlignMethod = AlignMethod.INTERPOLATE,
) -> LoadedLog:
    """Read ``path`` (MCAP or CSV) and align its logical signals on one time base.

    Args:
        path: the log file.
        channel_map: signal -> source overriding the default topic/field names.
        rate_hz: rate (Hz) of the aligned grid; None: the fastest signal's median rate.
        method: interpolation or nearest-sample for continuous signals (commands are held).

    Raises:
        LogcalInputError: the file cannot be read, no logical signal is found, or the signals
            cannot be put on one time base (subclasses name file, topic and field).
    """
    log = read_log(path)
    resolved = resolve_signals(log, channel_map)
    robot = infer_robot(log, resolved)
    if not resolved.signals:
        raise MissingSignalsError(
            log.path, list(ROBOT_REQUIRED_SIGNALS[robot]), log.topic_names(), str(robot)
        )
    names = list(resolved.signals)
    frame = align_signals(
        resolved.signals,
        rate_hz=rate_hz,
        method=method,
        required=_span_signals(robot, names),
    )
    problems = [*log.problems, *resolved.problems, *_null_notes(log.path, frame)]
    has_odom = {"v", "omega"} <= set(frame.columns)
    has_pose = {"x", "y"} <= set(frame.columns)
    if robot is not Robot.MANIPULATOR_2LINK and (has_odom or has_pose):
        frame = derive_kappa(frame)
    return LoadedLog(
        path=log.path,
        log=log,
        signals=resolved,
        frame=frame,
        robot=robot,
        truth=metadata_truth(log.metadata),
        problems=problems,
    )
