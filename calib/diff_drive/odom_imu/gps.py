"""The distance scale against GPS: GPS distance / odometry distance over windows of
``GPS_WINDOW_S`` while moving (the wheel radius' error, when the log has a fix)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from calib.diff_drive.odom_imu.gain import N_BOOT, block_boot, interval
from calib.diff_drive.odom_imu.windows import integrate
from calib.results import Estimate

__all__ = ["GPS_WINDOW_S", "gps_scale"]

Array = NDArray[np.float64]

GPS_WINDOW_S = 5.0


def gps_scale(
    t: Array, v: Array, lat: Array, lon: Array, rng: np.random.Generator
) -> Estimate | None:
    """GPS / odometry distance with a block-bootstrap interval; None with too little GPS or
    travel."""
    ok = np.isfinite(lat) & np.isfinite(lon) & np.isfinite(v)
    if ok.sum() < 20:
        return None
    t, v, lat, lon = t[ok], v[ok], lat[ok], lon[ok]
    r_earth = 6_371_000.0
    east = np.radians(lon - lon[0]) * r_earth * math.cos(math.radians(float(lat[0])))
    north = np.radians(lat - lat[0]) * r_earth
    dist = integrate(t, np.abs(v))
    edges = np.unique(np.searchsorted(t, np.arange(t[0], t[-1] + 1e-9, GPS_WINDOW_S)))
    a, b = edges[:-1], edges[1:]
    d_odo = dist[b] - dist[a]
    d_gps = np.hypot(east[b] - east[a], north[b] - north[a])
    use = d_odo > 1.0  # at least a metre: GPS noise is of that order
    if use.sum() < 4:
        return None
    rows = np.flatnonzero(use).astype(np.intp)
    value = float(np.sum(d_gps[rows]) / np.sum(d_odo[rows]))
    boot = np.array(
        [
            float(np.sum(d_gps[rows[i]]) / np.sum(d_odo[rows[i]]))
            for i in block_boot(rows.size, rng, N_BOOT)
        ]
    )
    return interval(
        "distance_scale_gps",
        value,
        boot,
        max(1, rows.size // max(1, round(rows.size ** (1 / 3))) - 1),
        "1",
        f"GPS distance / odometry distance over {rows.size} windows of {GPS_WINDOW_S:g} s "
        "(chord of the GPS track: slightly short on curves)",
    )
