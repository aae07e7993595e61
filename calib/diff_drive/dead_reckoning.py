"""Dead reckoning from cumulative wheel angles.

Two schemes, both with the heading computed directly from the wheel-angle difference (paper
Eq. 38: yaw is a holonomic function of the wheel angles):

* ``"paper"``: the paper's Eq. 39, position by trapezoidal integration of the forward speed with
  the heading of the previous sample (wheel rates by central differences).
* ``"arc"`` (default): each sampling interval is driven as a circular arc (constant wheel rates
  between samples), displacement = chord along the mean heading of the interval. Exact for
  piecewise-constant wheel rates, second order in general; the odometry calibration uses the
  same scheme so that its model and the dead reckoning it corrects are one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from calib.diff_drive.kinematics import DiffDriveParams

__all__ = ["DeadReckoning", "Scheme", "arc_steps", "dead_reckon", "end_point_error"]

Array = NDArray[np.float64]
Scheme = Literal["arc", "paper"]


@dataclass(frozen=True)
class DeadReckoning:
    """A dead-reckoned trajectory: time (s) and pose (m, m, rad; yaw unwrapped)."""

    t: Array
    x: Array
    y: Array
    yaw: Array

    def to_dict(self) -> dict[str, list[float]]:
        return {k: getattr(self, k).tolist() for k in ("t", "x", "y", "yaw")}


def arc_steps(
    d_right: Array, d_left: Array, params: DiffDriveParams, yaw0: float
) -> tuple[Array, Array, Array]:
    """Per-interval displacement (dx, dy) and the yaw after each interval, for wheel-angle
    increments ``d_right``, ``d_left`` (rad) driven as arcs from heading ``yaw0``."""
    dd = 0.5 * (params.r_R * d_right + params.r_L * d_left)
    dth = (params.r_R * d_right - params.r_L * d_left) / params.b
    yaw = yaw0 + np.cumsum(dth)
    mid = yaw - 0.5 * dth
    chord = dd * np.sinc(dth / (2.0 * np.pi))  # np.sinc(x) = sin(pi x)/(pi x)
    return chord * np.cos(mid), chord * np.sin(mid), yaw


def dead_reckon(
    t: ArrayLike,
    wheel_right: ArrayLike,
    wheel_left: ArrayLike,
    params: DiffDriveParams,
    pose0: tuple[float, float, float] = (0.0, 0.0, 0.0),
    scheme: Scheme = "arc",
) -> DeadReckoning:
    """Dead-reckon from cumulative wheel angles (rad) sampled at times ``t`` (s), starting at
    ``pose0`` = (x, y, yaw) at ``t[0]``."""
    tt = np.asarray(t, dtype=float)
    pr = np.asarray(wheel_right, dtype=float)
    pl = np.asarray(wheel_left, dtype=float)
    if not (tt.shape == pr.shape == pl.shape) or tt.ndim != 1 or tt.size < 1:
        raise ValueError("t, wheel_right and wheel_left must be 1-D arrays of one length >= 1")
    x0, y0, th0 = pose0
    # Eq. 38: heading straight from the wheel-angle difference
    yaw = th0 + (params.r_R * (pr - pr[0]) - params.r_L * (pl - pl[0])) / params.b
    if tt.size == 1:
        return DeadReckoning(tt, np.array([x0]), np.array([y0]), yaw)
    if scheme == "arc":
        dx, dy, _ = arc_steps(np.diff(pr), np.diff(pl), params, th0)
    elif scheme == "paper":
        wr = np.gradient(pr, tt)
        wl = np.gradient(pl, tt)
        v = 0.5 * (params.r_R * wr + params.r_L * wl)
        step = 0.5 * (v[:-1] + v[1:]) * np.diff(tt)  # Eq. 39: trapezoid, previous heading
        dx, dy = step * np.cos(yaw[:-1]), step * np.sin(yaw[:-1])
    else:
        raise ValueError(f"unknown dead-reckoning scheme {scheme!r}; expected 'arc' or 'paper'")
    x = x0 + np.concatenate([[0.0], np.cumsum(dx)])
    y = y0 + np.concatenate([[0.0], np.cumsum(dy)])
    return DeadReckoning(tt, x, y, yaw)


def end_point_error(dr: DeadReckoning, x: ArrayLike, y: ArrayLike) -> float:
    """Distance (m) between the dead-reckoned and the true end point."""
    xa = np.asarray(x, dtype=float)
    ya = np.asarray(y, dtype=float)
    return float(np.hypot(dr.x[-1] - xa[-1], dr.y[-1] - ya[-1]))
