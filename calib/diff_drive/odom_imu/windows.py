"""The odometry + IMU log cut into windows: per window of ``WINDOW_S``, the yaw change each
sensor saw, the duration, the mean |turn rate| and speed the odometry reports. The gain is fitted
on windows (not samples) so that the two sensors' sample noise and small timing differences
average out; the gyro is first shifted onto the odometry's clock by the lag that best aligns
them (:func:`lag`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "FOLD_S",
    "MAX_LAG_S",
    "MIN_TURN_RAD_S",
    "WINDOW_S",
    "Windows",
    "integrate",
    "lag",
    "windows",
]

Array = NDArray[np.float64]

WINDOW_S = 0.5
FOLD_S = 10.0
"""Length of the alternating time blocks of the two held-out folds."""
MAX_LAG_S = 0.3
MIN_TURN_RAD_S = 0.05
"""Windows whose odometry yaw rate stays below this (rad/s) carry nothing about the gain."""


@dataclass(frozen=True)
class Windows:
    """Per window: mid time ``t``, the odometry's and the gyro's yaw change (rad), duration
    ``dt`` (s), |odometry yaw rate| ``rate`` (rad/s), |odometry speed| ``speed`` (m/s); ``a``,
    ``b``: each window's first and last sample index."""

    t: Array
    odo: Array
    gyro: Array
    dt: Array
    rate: Array
    speed: Array
    a: NDArray[np.intp]
    b: NDArray[np.intp]


def integrate(t: Array, x: Array) -> Array:
    """Cumulative trapezoid integral of ``x`` over ``t``, 0 at the first sample."""
    return np.concatenate([[0.0], np.cumsum(0.5 * (x[1:] + x[:-1]) * np.diff(t))])


def lag(t: Array, odo: Array, gyro: Array) -> float:
    """Lag (s, gyro behind odometry when positive) maximising their correlation."""
    dt = float(np.median(np.diff(t)))
    if not dt > 0:
        return 0.0
    m = max(1, int(MAX_LAG_S / dt))
    a, b = odo - odo.mean(), gyro - gyro.mean()
    cs = []
    for k in range(-m, m + 1):
        x, y = a[max(0, -k) : a.size - max(0, k)], b[max(0, k) : b.size - max(0, -k)]
        cs.append(float(np.dot(x, y)) / math.sqrt(float(np.dot(x, x) * np.dot(y, y)) or 1.0))
    at = int(np.argmax(cs))
    if at in (0, len(cs) - 1) or cs[at] - cs[m] < 0.01:
        return 0.0  # no clear peak inside the search range: not shifted
    return (at - m) * dt


def windows(t: Array, odo: Array, gyro: Array, speed: Array) -> Windows:
    """The log cut into windows of ``WINDOW_S`` (the last one ends at the last sample)."""
    edges = np.unique(np.searchsorted(t, np.arange(t[0], t[-1] + 1e-9, WINDOW_S)))
    if edges[-1] != t.size - 1:
        edges = np.append(edges, t.size - 1)
    a, b = edges[:-1], edges[1:]
    io, ig, iv = integrate(t, odo), integrate(t, gyro), integrate(t, np.abs(speed))
    dt = t[b] - t[a]
    return Windows(
        0.5 * (t[a] + t[b]),
        io[b] - io[a],
        ig[b] - ig[a],
        dt,
        np.abs(io[b] - io[a]) / dt,
        (iv[b] - iv[a]) / dt,
        a.astype(np.intp),
        b.astype(np.intp),
    )
