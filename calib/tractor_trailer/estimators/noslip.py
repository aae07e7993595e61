"""Link lengths from the trailer's pose and the joint angle: the tractor axle's no-slip
constraint, a linear regression.

With the trailer axle C2 and heading theta2 measured, and psi the joint angle, the tractor's
heading is theta1 = theta2 + psi and its reference point is C1 = C2 + L2 e(theta2) + L1 e(theta1)
(e(a) = (cos a, sin a); L1 > 0 behind link 1's axle). That point does not slip sideways,
dC1 . e_perp(theta1) = 0, which is linear in the link lengths:

    -dC2 . e_perp(theta1) = L1 d theta1 + L2 cos(psi) d theta2

No speed, no curvature and no tractor pose are needed: a trailer tracked by motion capture plus
the hitch encoder is enough ("a trailer pose plus the hitch angle is as good as a
tractor pose"). Increments are summed over windows of about one second, so that the noise of
the poses, which telescopes in these sums, stays small next to the signal, which grows with the
window; windows never span a gap. Least squares over the windows with a Newey-West covariance.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from calib.errors import InsufficientDataError
from calib.results import CalibrationResult
from calib.stats import bartlett_bandwidth, hac_covariance
from calib.tractor_trailer.estimators._result import (
    calibration_result,
    information_criteria,
    method_result,
)
from calib.tractor_trailer.estimators.drive_path import default_gap_s
from calib.tractor_trailer.estimators.identifiability import IdentifiabilityVerdict, identifiability
from calib.tractor_trailer.results import Family, MethodResult

__all__ = ["NoSlipRegression"]

_ADVICE = "drive turns in both directions with the joint angle changing, or lower the pose noise"


class NoSlipRegression:
    """Fit (L1, L2) from the trailer pose and the joint angle.

    Args:
        window_s: length of the windows the increments are summed over (s).
        rel_tol: "determined" threshold on the 95 % half-width, relative to
            max(|value|, (|L1| + |L2|) / 2).

    Attributes (after ``fit``): L1_, L2_, cov_, verdict_, result_, method_result_, n_windows_.
    """

    name = "No-slip (trailer pose)"

    def __init__(self, *, window_s: float = 1.0, rel_tol: float = 0.1) -> None:
        self.window_s = window_s
        self.rel_tol = rel_tol

    def fit(
        self,
        t_s: ArrayLike,
        x2_m: ArrayLike,
        y2_m: ArrayLike,
        yaw2_rad: ArrayLike,
        psi_rad: ArrayLike,
    ) -> NoSlipRegression:
        """Fit to the trailer pose (x2, y2, yaw2) and the joint angle, all at times ``t_s``.

        Raises:
            InsufficientDataError: fewer than 8 windows, or no turning.
        """
        arrs = [np.asarray(a, dtype=float).ravel() for a in (t_s, x2_m, y2_m, yaw2_rad, psi_rad)]
        ok = np.all([np.isfinite(a) for a in arrs], axis=0)
        t, x, y, yaw, psi = (a[ok] for a in arrs)
        if t.size < 10:
            raise InsufficientDataError(f"{self.name}: {t.size} samples; need 10")
        th2 = np.unwrap(yaw)
        th1 = th2 + psi
        mid1 = 0.5 * (th1[1:] + th1[:-1])
        y_inc = np.diff(x) * np.sin(mid1) - np.diff(y) * np.cos(mid1)
        a_inc = np.diff(th1)
        b_inc = np.cos(0.5 * (psi[1:] + psi[:-1])) * np.diff(th2)
        dt = np.diff(t)
        keep = dt <= default_gap_s(t)
        # window index: a new window every window_s, and after every gap
        clock = np.concatenate([[0.0], np.cumsum(np.where(keep, dt, 0.0))])
        win = np.floor(clock[:-1] / self.window_s).astype(np.int64)
        win = win + np.cumsum(~keep)  # a gap always starts a new window
        win = np.unique(win[keep], return_inverse=True)[1]
        Y = np.bincount(win, weights=y_inc[keep])
        A = np.column_stack(
            [np.bincount(win, weights=a_inc[keep]), np.bincount(win, weights=b_inc[keep])]
        )
        if Y.size < 8:
            raise InsufficientDataError(
                f"{self.name}: {Y.size} windows of {self.window_s} s; need 8"
            )
        if np.linalg.matrix_rank(A) < 2:
            raise InsufficientDataError(f"{self.name}: the trailer never turns")
        beta, *_ = np.linalg.lstsq(A, Y, rcond=None)
        r = Y - A @ beta
        J = -A
        bw = bartlett_bandwidth(r)
        cov = hac_covariance(J, r, bw)
        self.L1_, self.L2_ = float(beta[0]), float(beta[1])
        self.cov_ = cov
        self.n_windows_ = int(Y.size)
        scale = 0.5 * (abs(self.L1_) + abs(self.L2_))
        self.verdict_: IdentifiabilityVerdict = identifiability(
            cov,
            (self.L1_, self.L2_),
            rel_tol=self.rel_tol,
            method=self.name,
            advice=_ADVICE,
            scale=scale,
        )
        aic, bic = information_criteria(float(r @ r), r.size, 2)
        self.result_: CalibrationResult = calibration_result(
            self.name,
            self.verdict_,
            cov,
            converged=True,
            aic=aic,
            bic=bic,
            details={
                "estimator": "no-slip regression of the tractor axle on the trailer pose",
                "windows": self.n_windows_,
                "window_s": self.window_s,
                "hac_bandwidth": bw,
                "identifiability": self.verdict_.to_dict(),
            },
        )
        sv = np.linalg.svd(A, compute_uv=False)
        self.method_result_: MethodResult = method_result(
            self.name,
            Family.NOSLIP,
            self.verdict_,
            condition_number=float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf,
        )
        return self
