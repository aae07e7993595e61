"""Effective track width of a skid-steer robot (Husky, Jackal class): its wheels slide sideways
when it turns, so the yaw rate is (r_R w_R - r_L w_L) / b_eff with b_eff wider than the
geometric track. b_eff comes from comparing wheel odometry with a gyro's yaw rate or the
ground-truth heading over segments:

    b_eff * (yaw change) = r_R * (right wheel turn) - r_L * (left wheel turn),

one linear unknown, fitted through the origin; interval from a moving-block bootstrap over the
segments (same reasoning as :mod:`calib.diff_drive.odometry_lsq`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from calib.errors import InsufficientDataError
from calib.results import Estimate

__all__ = ["EffectiveTrack", "effective_track"]

Array = NDArray[np.float64]

MIN_TURN_RAD = np.pi / 2
"""Total |yaw change| over the segments below which the track is not determined."""


@dataclass(frozen=True)
class EffectiveTrack:
    """The effective track (m), its bootstrap replicates and where the yaw came from."""

    estimate: Estimate
    boot: Array
    source: str
    n_segments: int


def effective_track(
    t: ArrayLike,
    wheel_right: ArrayLike,
    wheel_left: ArrayLike,
    r_R: float,
    r_L: float,
    *,
    yaw: ArrayLike | None = None,
    yaw_rate: ArrayLike | None = None,
    segment_s: float = 2.0,
    n_boot: int = 300,
    seed: int = 0,
) -> EffectiveTrack:
    """Effective track (m) from a heading (``yaw``, rad) or a gyro (``yaw_rate``, rad/s).

    Raises:
        InsufficientDataError: neither yaw nor yaw rate, or the robot hardly turns.
    """
    tt = np.asarray(t, dtype=float)
    pr, pl = np.asarray(wheel_right, dtype=float), np.asarray(wheel_left, dtype=float)
    source: Literal["gyro", "pose"]
    if yaw_rate is not None:
        rate = np.asarray(yaw_rate, dtype=float)
        heading = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(tt))])
        source = "gyro"
    elif yaw is not None:
        heading = np.unwrap(np.asarray(yaw, dtype=float))
        source = "pose"
    else:
        raise InsufficientDataError("the effective track needs a gyro yaw rate or a heading")
    ok = np.isfinite(tt) & np.isfinite(pr) & np.isfinite(pl) & np.isfinite(heading)
    tt, pr, pl, heading = tt[ok], pr[ok], pl[ok], heading[ok]
    if tt.size < 4:
        raise InsufficientDataError("too few samples for the effective track")
    idx = np.unique(np.searchsorted(tt, np.arange(tt[0], tt[-1] + 1e-9, segment_s)))
    idx = np.append(idx, tt.size - 1) if idx[-1] != tt.size - 1 else idx
    a, b = idx[:-1], idx[1:]
    s = r_R * (pr[b] - pr[a]) - r_L * (pl[b] - pl[a])
    dpsi = heading[b] - heading[a]
    if float(np.sum(np.abs(dpsi))) < MIN_TURN_RAD or a.size < 4:
        raise InsufficientDataError(
            f"the robot turns only {float(np.sum(np.abs(dpsi))):.2f} rad in all: the effective "
            "track is not determined"
        )

    def fit(rows: NDArray[np.intp]) -> float:
        return float(np.sum(s[rows] * dpsi[rows]) / np.sum(dpsi[rows] ** 2))

    n = a.size
    value = fit(np.arange(n, dtype=np.intp))
    rng = np.random.default_rng(seed)
    blk = max(1, round(n ** (1 / 3)))
    boot = []
    for _ in range(n_boot):
        starts = rng.integers(0, n - blk + 1, size=int(np.ceil(n / blk)))
        rows = (starts[:, None] + np.arange(blk)).ravel()[:n].astype(np.intp)
        if np.sum(dpsi[rows] ** 2) > 0:
            boot.append(fit(rows))
    bs = np.array(boot)
    std = float(np.std(bs, ddof=1)) if bs.size > 1 else np.nan
    ci = (value - 1.96 * std, value + 1.96 * std)
    est = Estimate(
        "effective_track",
        value,
        std,
        ci,
        bool(np.isfinite(std)),
        "m",
        f"from the {source} heading over {n} segments of {segment_s:g} s with radii "
        f"{r_R * 1e3:.3f} / {r_L * 1e3:.3f} mm; block bootstrap",
    )
    return EffectiveTrack(est, bs, source, n)
