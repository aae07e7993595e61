"""PD path tracking through the inverse kinematics (paper Eqs. 40-44), two laws:

* ``"paper"`` (Eqs. 40-44 as printed): the world-frame pose error e = (x, y, heading) of the
  axle centre, u = Kp e(nT) + Kd (e(nT) - e((n-1)T)) (Eq. 41: Kd multiplies the step
  difference) plus the reference velocity (the text beside Eq. 41), rotated into the body
  frame by M^T (Eq. 42) and through the inverse kinematics (Eq. 44): the body speed is the
  forward component of u, the yaw rate its heading component. The body-lateral component is
  dropped (a wheel cannot move sideways), so a lateral offset from the reference is never
  fed back: once the heading matches the reference's, an offset stays. That is why the paper
  needs the planned path.
* ``"control_point"``: the error of the control point ``l_c`` ahead of the axle (Eqs. 31-34),
  where the robot is controllable, divided by that point's Jacobian (Eq. 43 with the
  control-point kinematics): lateral offsets are fed back through the heading.

The inverse kinematics uses the nominal parameters; wheel rates beyond the motor's limit are
scaled down together (keeping the commanded curvature). The robot knows its pose only by dead
reckoning from its encoders (Eqs. 38-39).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from calib.diff_drive.dead_reckoning import arc_steps
from calib.diff_drive.kinematics import DiffDriveParams, control_point_inverse, inverse
from calib.diff_drive.planner import PlannedPath

__all__ = ["TrackerGains", "TrackingRun", "track"]

Array = NDArray[np.float64]


TrackingLaw = Literal["paper", "control_point"]


@dataclass(frozen=True)
class TrackerGains:
    """Proportional gain ``kp`` (1/s); derivative gain ``kd`` (``"paper"`` law: 1/s, times the
    step difference of the error as in Eq. 41; ``"control_point"``: dimensionless, times the
    error rate); control point distance ``l_c`` (m, ``"control_point"`` only) and wheel-rate
    limit ``w_max`` (rad/s)."""

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
    law: TrackingLaw = "control_point",
) -> TrackingRun:
    """Follow ``ref`` from the true pose ``start`` with a robot of parameters ``true`` whose
    controller believes ``nominal`` (dead reckoning with quantised encoders when
    ``counts_per_rev`` > 0), by the tracking ``law`` (see the module docstring)."""
    if law not in ("paper", "control_point"):
        raise ValueError(f"unknown tracking law {law!r}: 'paper' or 'control_point'")
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
    vxa, vya = ref.v * np.cos(ref.yaw), ref.v * np.sin(ref.yaw)
    for k in range(n - 1):
        T = t[k + 1] - t[k]
        xe, ye, the = E[k]
        if law == "paper":
            e = np.array(
                [ref.x[k] - xe, ref.y[k] - ye, float(np.angle(np.exp(1j * (ref.yaw[k] - the))))]
            )
            de = np.zeros(3) if e_prev is None else e - e_prev  # Eq. 41: step difference
            e_prev = e
            u = np.array([vxa[k], vya[k], ref.omega[k]]) + gains.kp * e + gains.kd * de
            v = np.cos(the) * u[0] + np.sin(the) * u[1]  # Eq. 42: M^T, forward row
            om = u[2]
        else:
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
