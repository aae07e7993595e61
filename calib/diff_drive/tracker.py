"""PD path tracking through the inverse kinematics (paper Eqs. 40-44).

The pose error of the control point (``l_c`` ahead of the axle, where the robot is
controllable, Eqs. 31-34) is formed in the world frame, the PD law plus the reference velocity
is rotated into the body frame (Eq. 42) and divided by the control point's Jacobian (Eq. 43)
to give body speed and yaw rate, and the inverse kinematics (nominal parameters) gives the
wheel rates. The robot knows its pose only by dead reckoning from its encoders (Eqs. 38-39).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from calib.diff_drive.dead_reckoning import arc_steps
from calib.diff_drive.kinematics import DiffDriveParams, control_point_inverse, inverse
from calib.diff_drive.planner import PlannedPath

__all__ = ["TrackerGains", "TrackingRun", "track"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class TrackerGains:
    """Proportional (1/s) and derivative (dimensionless, per step difference / T) gains,
    control point distance ``l_c`` (m) and wheel-rate limit (rad/s)."""

    kp: float = 1.0
    kd: float = 0.1
    l_c: float = 0.1
    w_max: float = 20.0


@dataclass(frozen=True)
class TrackingRun:
    """Time, true pose, dead-reckoned pose and the reference followed."""

    t: Array
    x: Array
    y: Array
    yaw: Array
    x_dr: Array
    y_dr: Array
    yaw_dr: Array
    reference: PlannedPath
    w_right: Array
    w_left: Array


def track(
    ref: PlannedPath,
    start: tuple[float, float, float],
    true: DiffDriveParams,
    nominal: DiffDriveParams,
    gains: TrackerGains = TrackerGains(),
    counts_per_rev: int = 0,
) -> TrackingRun:
    """Follow ``ref`` from the true pose ``start`` with a robot of parameters ``true`` whose
    controller believes ``nominal`` (dead reckoning with quantised encoders when
    ``counts_per_rev`` > 0)."""
    t = ref.t
    n = t.size
    lc = gains.l_c
    px_r = ref.x + lc * np.cos(ref.yaw)
    py_r = ref.y + lc * np.sin(ref.yaw)
    vx_r, vy_r = np.gradient(px_r, t), np.gradient(py_r, t)
    X = np.zeros((n, 3))
    E = np.zeros((n, 3))
    X[0] = E[0] = start
    phi = np.zeros(2)  # true wheel angles
    phi_seen = np.zeros(2)
    q = 2 * np.pi / counts_per_rev if counts_per_rev > 0 else 0.0
    e_prev = None
    wr_log, wl_log = np.zeros(n), np.zeros(n)
    for k in range(n - 1):
        T = t[k + 1] - t[k]
        xe, ye, the = E[k]
        e = np.array([px_r[k] - (xe + lc * np.cos(the)), py_r[k] - (ye + lc * np.sin(the))])
        de = np.zeros(2) if e_prev is None else (e - e_prev) / T
        e_prev = e
        u = np.array([vx_r[k], vy_r[k]]) + gains.kp * e + gains.kd * de
        v, om = control_point_inverse(u[0], u[1], the, lc)
        w_r, w_l = inverse(nominal, v, om)
        scale = max(1.0, abs(float(w_r)) / gains.w_max, abs(float(w_l)) / gains.w_max)
        wr, wl = float(w_r) / scale, float(w_l) / scale
        wr_log[k], wl_log[k] = wr, wl
        d = np.array([wr * T, wl * T])
        dx, dy, yaw = arc_steps(d[:1], d[1:], true, X[k, 2])
        X[k + 1] = [X[k, 0] + dx[0], X[k, 1] + dy[0], yaw[0]]
        phi += d
        new_seen = np.floor(phi / q) * q if q else phi.copy()
        inc = new_seen - phi_seen
        phi_seen = new_seen
        dx, dy, yaw = arc_steps(inc[:1], inc[1:], nominal, E[k, 2])
        E[k + 1] = [E[k, 0] + dx[0], E[k, 1] + dy[0], yaw[0]]
    return TrackingRun(t, X[:, 0], X[:, 1], X[:, 2], E[:, 0], E[:, 1], E[:, 2], ref, wr_log, wl_log)
