"""UMBmark (Borenstein and Feng 1996, "Measurement and correction of systematic odometry errors
in mobile robots"): square runs clockwise and counter-clockwise; the centres of gravity of
the end-point errors give the two systematic errors and their corrections,

* Type B, unequal wheel diameters: Ed = r_R / r_L (the heading drifts by beta on each side),
* Type A, uncertain track: Eb = b_actual / b_nominal (each 90 deg turn is off by alpha).

UMBmark does not determine the mean wheel radius (it keeps the nominal one).

The classic closed-form corrections assume one particular start direction and sign convention.
Rather than copying them, the end-point error of an ideal square (side L) is linearised here in
(alpha, beta) for each direction (a few evaluations of the square's geometry, no data), and the
four mean error coordinates are solved for (alpha, beta) by least squares: the same first-order
theory, valid for any start heading once the runs are expressed in their start frame.
Intervals: delta method from the standard errors of the per-direction means (few runs: a
Student t quantile with n - 1 degrees of freedom).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import stats

from calib.diff_drive.data import DriveRun
from calib.diff_drive.dead_reckoning import dead_reckon
from calib.diff_drive.kinematics import DiffDriveParams
from calib.errors import InsufficientDataError
from calib.results import CalibrationResult, Estimate, as_matrix

__all__ = ["UmbmarkResult", "square_end_error", "umbmark"]

Array = NDArray[np.float64]


def square_end_error(L: float, direction: int, alpha: float, beta: float) -> Array:
    """End point (m, start frame: x along the initial heading) of a square of side ``L`` that
    odometry believes closed, when each side bends the heading by ``beta`` (rad, CCW positive)
    and each turn of ``direction`` * 90 deg (+1 CCW, -1 CW) turns ``direction`` * alpha more."""
    pos = np.zeros(2)
    th = 0.0
    for _ in range(4):
        if abs(beta) < 1e-12:
            pos += L * np.array([np.cos(th), np.sin(th)])
        else:  # arc of length L, heading change beta
            rad = L / beta
            pos += rad * np.array([np.sin(th + beta) - np.sin(th), np.cos(th) - np.cos(th + beta)])
        th += beta
        th += direction * (np.pi / 2 + alpha)
    return pos


def _jacobian(L: float, direction: int, h: float = 1e-6) -> Array:
    """d(end point)/d(alpha, beta) at (0, 0), central differences of the ideal geometry."""
    ja = (square_end_error(L, direction, h, 0) - square_end_error(L, direction, -h, 0)) / (2 * h)
    jb = (square_end_error(L, direction, 0, h) - square_end_error(L, direction, 0, -h)) / (2 * h)
    return np.stack([ja, jb], axis=1)


@dataclass(frozen=True)
class UmbmarkResult:
    """Per-direction end-point errors (m, start frame) and the fitted errors and corrections."""

    side: float
    errors_cw: Array
    errors_ccw: Array
    alpha: float
    beta: float
    cov_ab: Array
    Ed: float
    Eb: float
    Ed_std: float
    Eb_std: float
    params: DiffDriveParams
    params_std: tuple[float, float, float]
    params_cov: Array
    """Covariance of (r_R, r_L, b) (m^2) from that of (alpha, beta); its diagonal is
    ``params_std`` squared (the radii move together, in opposite directions)."""


def _start_frame_error(run: DriveRun, nominal: DiffDriveParams) -> Array:
    dr = dead_reckon(
        run.t, run.wheel_right, run.wheel_left, nominal, (run.x[0], run.y[0], run.yaw[0])
    )
    e = np.array([run.x[-1] - dr.x[-1], run.y[-1] - dr.y[-1]])
    c, s = np.cos(run.yaw[0]), np.sin(run.yaw[0])
    return np.array([c * e[0] + s * e[1], -s * e[0] + c * e[1]])


def umbmark(
    runs: Sequence[DriveRun], nominal: DiffDriveParams, side: float | None = None
) -> UmbmarkResult:
    """UMBmark on square runs: the direction of each run from its total turn (about -2 pi:
    clockwise, +2 pi: counter-clockwise).

    Args:
        runs: square runs with wheel angles and ground-truth pose.
        nominal: the parameters odometry used (the corrections apply to them).
        side: side of the square (m); None: a quarter of the mean true path length.

    Raises:
        InsufficientDataError: not at least one run per direction (two for intervals), or runs
            that are not closed loops of one full turn.
    """
    cw = [r for r in runs if -2.5 * np.pi < r.yaw[-1] - r.yaw[0] < -1.5 * np.pi]
    ccw = [r for r in runs if 1.5 * np.pi < r.yaw[-1] - r.yaw[0] < 2.5 * np.pi]
    if len(cw) < 2 or len(ccw) < 2:
        raise InsufficientDataError(
            f"UMBmark needs at least two square runs each way (one full turn, -2 pi or +2 pi); "
            f"found {len(cw)} clockwise and {len(ccw)} counter-clockwise"
        )
    L = side if side is not None else float(np.mean([r.path_length() for r in cw + ccw])) / 4
    e_cw = np.array([_start_frame_error(r, nominal) for r in cw])
    e_ccw = np.array([_start_frame_error(r, nominal) for r in ccw])
    J = np.vstack([_jacobian(L, -1), _jacobian(L, +1)])
    m = np.concatenate([e_cw.mean(axis=0), e_ccw.mean(axis=0)])
    cov_m = np.zeros((4, 4))
    cov_m[:2, :2] = np.cov(e_cw.T, ddof=1) / len(cw)
    cov_m[2:, 2:] = np.cov(e_ccw.T, ddof=1) / len(ccw)
    pinv = np.linalg.pinv(J)
    alpha, beta = (float(v) for v in pinv @ m)
    cov_ab = pinv @ cov_m @ pinv.T
    # corrections: actual turn = (pi/2) b_nom / b  ->  b = b_nom (pi/2) / (pi/2 + alpha);
    # beta = L (r_R - r_L) / (b rbar) = (L / b) 2 (Ed - 1) / (Ed + 1)
    Eb = (np.pi / 2) / (np.pi / 2 + alpha)
    b = nominal.b * Eb
    k = beta * b / (2 * L)
    Ed = (1 + k) / (1 - k)
    dEb = -Eb / (np.pi / 2 + alpha)
    dEd_dk = 2 / (1 - k) ** 2
    # Ed depends on beta and (through b) on alpha
    g_Ed = np.array([dEd_dk * beta * nominal.b * dEb / (2 * L), dEd_dk * b / (2 * L)])
    Ed_std = float(np.sqrt(g_Ed @ cov_ab @ g_Ed))
    Eb_std = float(abs(dEb) * np.sqrt(cov_ab[0, 0]))
    rbar = 0.5 * (nominal.r_R + nominal.r_L)
    r_R, r_L = 2 * rbar * Ed / (1 + Ed), 2 * rbar / (1 + Ed)
    dr = 2 * rbar / (1 + Ed) ** 2 * Ed_std  # both radii move by this (opposite signs)
    # Jacobian of (r_R, r_L, b) in (alpha, beta)
    jac = np.vstack(
        [2 * rbar / (1 + Ed) ** 2 * g_Ed, -2 * rbar / (1 + Ed) ** 2 * g_Ed, [nominal.b * dEb, 0.0]]
    )
    return UmbmarkResult(
        side=L,
        errors_cw=e_cw,
        errors_ccw=e_ccw,
        alpha=alpha,
        beta=beta,
        cov_ab=cov_ab,
        Ed=float(Ed),
        Eb=float(Eb),
        Ed_std=Ed_std,
        Eb_std=Eb_std,
        params=DiffDriveParams(float(r_R), float(r_L), float(b)),
        params_std=(float(dr), float(dr), float(nominal.b * Eb_std)),
        params_cov=jac @ cov_ab @ jac.T,
    )


def umbmark_result(res: UmbmarkResult, n_cw: int, n_ccw: int) -> CalibrationResult:
    """``res`` as a :class:`CalibrationResult` (method ``"UMBmark"``); intervals use a Student
    t quantile with min(n_cw, n_ccw) - 1 degrees of freedom.

    UMBmark determines the ratio of the wheel radii (derived ``wheel_radius_ratio`` = Ed, with
    its interval from the end points' scatter) and the track width for the nominal mean radius,
    not each radius: their mean stays nominal, so each radius is reported as not determined
    (its value the nominal mean split by Ed, no interval; an interval of the ratio's spread
    alone would read as a radius known to a micrometre). ``covariance`` is that of the
    corrections for the nominal mean radius."""
    q = float(stats.t.ppf(0.975, max(1, min(n_cw, n_ccw) - 1)))
    p = res.params
    rbar = 0.5 * (p.r_R + p.r_L)
    note = (
        f"UMBmark on {n_cw} clockwise and {n_ccw} counter-clockwise squares of side "
        f"{res.side:.2f} m; the mean radius stays nominal (UMBmark does not determine it)"
    )
    radius_note = (
        f"UMBmark determines only r_R/r_L = {res.Ed:.5g} [{res.Ed - q * res.Ed_std:.5g}, "
        f"{res.Ed + q * res.Ed_std:.5g}]; the mean radius stays the nominal {rbar:.5g} m"
    )
    nan = float("nan")
    est = {
        name: Estimate(name, v, nan, (nan, nan), False, "m", radius_note)
        for name, v in (("wheel_radius_right", p.r_R), ("wheel_radius_left", p.r_L))
    }
    b_std = res.params_std[2]
    est["track_width"] = Estimate(
        "track_width", p.b, b_std, (p.b - q * b_std, p.b + q * b_std), True, "m", note
    )
    ratio = Estimate(
        "wheel_radius_ratio",
        res.Ed,
        res.Ed_std,
        (res.Ed - q * res.Ed_std, res.Ed + q * res.Ed_std),
        True,
        "",
        "r_R / r_L from the clockwise and counter-clockwise end points (" + note + ")",
    )
    return CalibrationResult(
        method="UMBmark",
        parameters=est,
        derived={"wheel_radius_ratio": ratio},
        covariance=as_matrix(res.params_cov),
        verdict=(
            f"UMBmark: Ed = r_R/r_L = {res.Ed:.5f} ± {res.Ed_std:.1g}, "
            f"Eb = b/b_nominal = {res.Eb:.4f} ± {res.Eb_std:.1g}"
        ),
        details={
            "Ed": res.Ed,
            "Ed_std": res.Ed_std,
            "Eb": res.Eb,
            "Eb_std": res.Eb_std,
            "alpha_rad": res.alpha,
            "beta_rad": res.beta,
            "side_m": res.side,
            "end_errors_cw_m": res.errors_cw.tolist(),
            "end_errors_ccw_m": res.errors_ccw.tolist(),
        },
    )
