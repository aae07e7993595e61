"""Checks and repairs of one logical signal: non-finite values, timestamps, angles in degrees.

Repairs (dropping NaN/inf samples, sorting, dropping repeated timestamps) are returned as
human-readable notes; what cannot be repaired raises a :class:`logtools.errors.LogcalInputError`
naming the file, topic and field.
"""

from __future__ import annotations

import math

import numpy as np
import polars as pl

from logtools.errors import SignalValueError, TimestampError
from logtools.readers.base import TIME_COLUMN
from logtools.signals import SignalSource

__all__ = ["DEGREES_LIMIT_RAD", "check_yaw_units", "clean_signal"]

DEGREES_LIMIT_RAD = 2 * math.pi + 0.1
"""|angle| beyond this (rad) means the values are most likely degrees."""


def clean_signal(
    frame: pl.DataFrame,
    *,
    path: str,
    name: str,
    source: SignalSource,
    within_turn: bool = False,
) -> tuple[pl.DataFrame, list[str]]:
    """Return ``frame`` (``t_ns``, ``value``) as float64 with finite values and increasing time.

    Null values (empty CSV cells, absent JSON fields) are dropped without a note; a frame of
    nulls only comes back empty.

    Args:
        frame: the raw signal; ``value`` may be any numeric type.
        path: the log file, for messages.
        name: the logical signal name, for messages.
        source: where the signal came from, for messages.
        within_turn: the signal is an angle that stays within one turn
            (``SignalSpec.within_turn``): beyond 2π it is taken as degrees and refused.

    Returns:
        The cleaned frame and notes on what was repaired.

    Raises:
        SignalValueError: the values are not numbers, all are NaN/inf, or an angle within one
            turn looks like degrees (beyond 2π; for a heading see :func:`check_yaw_units`).
        TimestampError: all samples share one timestamp.
    """
    where = f"{path}: signal {name!r} (topic {source.topic!r}, field {source.field!r})"
    dtype = frame["value"].dtype
    if not (dtype.is_numeric() or dtype == pl.Boolean or dtype == pl.Null):
        raise SignalValueError(f"{where} holds {dtype} values; expected numbers.")
    # Empty cells / absent fields (null) are normal (CSV rows of other sensors): dropped quietly.
    frame = frame.with_columns(pl.col("value").cast(pl.Float64)).drop_nulls("value")
    notes: list[str] = []
    if frame.height == 0:
        return frame, notes
    finite = frame["value"].is_finite()
    bad = frame.height - int(finite.sum())
    if bad == frame.height:
        raise SignalValueError(
            f"{where}: all {bad} values are NaN or inf; expected finite numbers."
        )
    if bad:
        notes.append(f"{where}: {bad} NaN/inf values of {frame.height} were dropped")
        frame = frame.filter(finite)
    if not frame[TIME_COLUMN].is_sorted():
        frame = frame.sort(TIME_COLUMN, maintain_order=True)
        notes.append(f"{where}: timestamps were not increasing; sorted")
    # sorted by now: the first sample of each timestamp is the one whose time differs from the
    # previous sample's (a linear pass; ``unique`` hashes every timestamp)
    first = frame[TIME_COLUMN].diff().fill_null(1) != 0
    unique = frame if first.all() else frame.filter(first)
    if unique.height < frame.height:
        if unique.height == 1:
            raise TimestampError(
                f"{where}: all {frame.height} samples have the same timestamp "
                f"{frame[TIME_COLUMN][0]} ns; expected increasing MCAP log_time (or CSV 't')."
            )
        notes.append(
            f"{where}: {frame.height - unique.height} samples repeated a timestamp; "
            "the first of each was kept"
        )
        frame = unique
    if within_turn and frame.height:
        peak = float(np.max(np.abs(frame["value"].to_numpy())))
        if peak > DEGREES_LIMIT_RAD:
            raise _degrees_error(where, name, peak, "a joint angle stays within one turn")
    return frame, notes


def check_yaw_units(
    yaw: pl.DataFrame,
    omega: pl.DataFrame | None,
    *,
    path: str,
    source: SignalSource,
    name: str = "yaw",
) -> list[str]:
    """Tell a yaw in degrees from an unwrapped yaw in radians; both can exceed 2π.

    Within ±2π the yaw is taken as radians. Beyond, it is degrees when it wraps around by about
    360 between two samples, or when its rate is about 57 times (20..120 times) the yaw rate
    ``omega`` (rad/s) of the same log; otherwise it is an unwrapped yaw in radians (with a note
    unless its rate matches omega within a factor 2).

    Args:
        yaw: cleaned yaw frame (``t_ns``, ``value``).
        omega: cleaned yaw-rate frame, if the log has one.
        path: the log file, for messages.
        source: where the yaw came from, for messages.
        name: the heading's signal name, for messages.

    Raises:
        SignalValueError: the yaw looks like degrees.
    """
    where = f"{path}: signal {name!r} (topic {source.topic!r}, field {source.field!r})"
    values = yaw["value"].to_numpy()
    peak = float(np.max(np.abs(values))) if values.size else 0.0
    if peak <= DEGREES_LIMIT_RAD:
        return []
    steps = np.abs(np.diff(values))
    if peak <= 370 and np.any((steps > 300) & (steps < 420)):
        raise _degrees_error(where, name, peak, "it wraps around by about 360")
    ratio = _rate_ratio(yaw, omega) if omega is not None else None
    if ratio is not None and 20 < ratio < 120:
        raise _degrees_error(where, name, peak, f"it changes {ratio:.0f} times faster than omega")
    if ratio is not None and 0.5 < ratio < 2:
        return []  # the yaw rate matches omega: an unwrapped yaw in radians
    return [f"{where} reaches |{name}| = {peak:.4g} rad: taken as an unwrapped {name} in radians"]


def _rate_ratio(yaw: pl.DataFrame, omega: pl.DataFrame) -> float | None:
    """median |d yaw/dt| / median |omega| where |omega| > 0.01 rad/s; None with too little data."""
    t = yaw[TIME_COLUMN].to_numpy() * 1e-9
    if t.size < 10 or omega.height < 2:
        return None
    rate = np.diff(yaw["value"].to_numpy()) / np.diff(t)
    mid = 0.5 * (t[1:] + t[:-1])
    w = np.interp(mid, omega[TIME_COLUMN].to_numpy() * 1e-9, omega["value"].to_numpy())
    turning = np.abs(w) > 0.01
    if np.count_nonzero(turning) < 10:
        return None
    return float(np.median(np.abs(rate[turning])) / np.median(np.abs(w[turning])))


def _degrees_error(where: str, name: str, peak: float, why: str) -> SignalValueError:
    return SignalValueError(
        f"{where} reaches |{name}| = {peak:.4g}, beyond 2π, and {why}: it looks like degrees. "
        'Expected radians; convert the log or map the field with transform = "deg_to_rad" '
        "in a --channel-map TOML."
    )
