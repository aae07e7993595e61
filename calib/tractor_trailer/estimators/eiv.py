"""Errors-in-variables maximum likelihood for the exact steady-state relation.

Model: the true points lie on kappa = g(psi) = sin(psi) / (L2 + L1 cos(psi)); both kappa (1/m)
and psi (rad) are measured with white Gaussian noise of standard deviations s_k and s_p. The
log-likelihood is maximised over (L1, L2) and the n true joint angles; the latter are profiled
out by a vectorised 1-D Gauss-Newton projection of each measured point onto the curve, weighted
by the noise (nested projection = variable projection). Only the ratio s_k / s_p matters for the
estimate; both are estimated from the measurements' second differences (high-frequency noise).

Covariance: sandwich H^-1 S H^-1 of the profiled (effective) residuals, with a Newey-West lag
window chosen from the residual autocorrelation (time-ordered logs are not independent).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import least_squares

from calib.errors import InsufficientDataError, SolverError
from calib.lsq.base import triangular_factor_by_rows
from calib.results import CalibrationResult
from calib.stats import bartlett_bandwidth, hac_covariance, hf_noise_std
from calib.tractor_trailer.estimators._result import (
    calibration_result,
    information_criteria,
    method_result,
)
from calib.tractor_trailer.estimators.identifiability import IdentifiabilityVerdict, identifiability
from calib.tractor_trailer.results import Family, MethodResult

__all__ = ["SteadyStateEIV", "project_onto_curve"]

_PSI_MAX = 1.5  # rad: projection stays inside (-pi/2, pi/2)


def _g(p: np.ndarray, L1: float, L2: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Curve value g, derivative dg/dpsi and denominator D = L2 + L1 cos(psi)."""
    c, s = np.cos(p), np.sin(p)
    D = L2 + L1 * c
    return s / D, (L2 * c + L1) / (D * D), D


def _profiled_jacobian(
    k: np.ndarray, p: np.ndarray, ph: np.ndarray, L1: float, L2: float, sk: float, sp: float
) -> np.ndarray:
    """Exact Jacobian of the profiled residuals ((k - g(ph)) / sk, (p - ph) / sp) to (L1, L2).

    Each projected angle ph minimises w_k (k - g(ph))^2 + w_p (p - ph)^2, so it moves with
    (L1, L2) as the implicit function theorem says: d ph / d L = -F_L / F_ph, F = w_k (k - g)
    g_ph + w_p (p - ph) the stationarity condition. Analytic rather than finite differences:
    it halves the fit's cost on a 1-hour log and moves the estimate by ~1e-7 of
    itself. A point held at the clip bound does not move.
    """
    wk, wp = 1.0 / sk**2, 1.0 / sp**2
    n = k.size
    out = np.empty((2 * n, 2))
    for a in range(0, n, _BLOCK):  # in blocks: a dozen temporaries of the block's size
        b = min(a + _BLOCK, n)
        q = ph[a:b]
        c, s = np.cos(q), np.sin(q)
        D = L2 + L1 * c
        g = s / D
        dg = (L2 * c + L1) / D**2
        d2g = s * (2.0 * L1 * L1 + L1 * L2 * c - L2 * L2) / D**3
        r = k[a:b] - g
        f_ph = wk * (r * d2g - dg * dg) - wp
        partials = (
            (-s * c / D**2, (D - 2.0 * c * (L2 * c + L1)) / D**3),  # g_L1, g_ph,L1
            (-s / D**2, (c * D - 2.0 * (L2 * c + L1)) / D**3),
        )  # g_L2, g_ph,L2
        held = np.abs(q) >= _PSI_MAX
        for j, (g_l, dg_l) in enumerate(partials):
            dph = -wk * (r * dg_l - g_l * dg) / f_ph
            dph[held] = 0.0
            out[a:b, j] = -(g_l + dg * dph) / sk
            out[n + a : n + b, j] = -dph / sp
    return out


_BLOCK = 65536  # points projected together: the per-point iterations are independent


def project_onto_curve(
    kappa: np.ndarray,
    psi: np.ndarray,
    L1: float,
    L2: float,
    std_kappa: float,
    std_psi: float,
    n_iter: int = 30,
    start: np.ndarray | None = None,
) -> np.ndarray:
    """Joint angles (rad) of the curve points closest to the measurements in the noise metric.

    Minimises ((kappa - g(p)) / s_k)^2 + ((psi - p) / s_p)^2 per point by Newton's method (the
    Gauss-Newton step where the cost's curvature is below half the Gauss-Newton one: far from
    the curve, where Newton's step could run to a maximum); Newton converges in 3-4 iterations
    where Gauss-Newton needed ~7 for a model far from the data. Only
    the points still moving (by 1e-13 rad or more) are iterated: a point held at the clip bound
    or one that converged costs nothing further, so long logs cost what their slow points need.
    The points are taken 65536 at a time (each point's iterations do not depend on the
    others), so the working arrays stay a few MB whatever the log's length.
    ``start``: initial angles (rad), e.g. the projection at nearby (L1, L2); default ``psi``.
    """
    kappa = np.asarray(kappa, dtype=float)
    psi = np.asarray(psi, dtype=float)
    first = psi if start is None else start
    p = np.clip(first, -_PSI_MAX, _PSI_MAX).astype(float, copy=True)
    for lo in range(0, p.size, _BLOCK):
        hi = min(lo + _BLOCK, p.size)
        _project_block(kappa[lo:hi], psi[lo:hi], p[lo:hi], L1, L2, std_kappa, std_psi, n_iter)
    return p


def _project_block(
    kappa: np.ndarray,
    psi: np.ndarray,
    p: np.ndarray,
    L1: float,
    L2: float,
    std_kappa: float,
    std_psi: float,
    n_iter: int,
) -> None:
    """``project_onto_curve`` on one block; ``p`` holds the start and receives the result."""
    wk, wp = 1.0 / std_kappa**2, 1.0 / std_psi**2
    active = np.arange(p.size)
    ka, sa, pa = kappa, psi, p.copy()
    for _ in range(n_iter):
        c, s = np.cos(pa), np.sin(pa)
        D = L2 + L1 * c
        g = s / D
        dg = (L2 * c + L1) / (D * D)
        d2g = s * (2.0 * L1 * L1 + L1 * L2 * c - L2 * L2) / (D * D * D)
        F = wk * (ka - g) * dg + wp * (sa - pa)
        curv = wk * (dg * dg - (ka - g) * d2g) + wp
        gn = wk * dg * dg + wp
        step = F / np.where(curv > 0.5 * gn, curv, gn)
        new = np.clip(pa + step, -_PSI_MAX, _PSI_MAX)
        p[active] = new
        moving = np.abs(new - pa) >= 1e-13
        if not moving.any():
            break
        active = active[moving]
        ka, sa, pa = kappa[active], psi[active], new[moving]


def _initial_guess(kappa: np.ndarray, psi: np.ndarray) -> np.ndarray:
    """OLS of sin(psi) = L1 kappa cos(psi) + L2 kappa (EM1), kept physical; else a 1:2 split of
    the small-angle slope."""
    A = np.column_stack([kappa * np.cos(psi), kappa])
    beta, *_ = np.linalg.lstsq(A, np.sin(psi), rcond=None)
    if np.all(beta > 0.05) and np.all(np.isfinite(beta)):
        return beta
    a = float(np.dot(kappa, psi) / max(np.dot(kappa, kappa), 1e-300))
    a = max(abs(a), 0.1)
    return np.array([a / 3.0, 2.0 * a / 3.0])


class SteadyStateEIV:
    """EIV maximum-likelihood fit of sin(psi) - kappa (L2 + L1 cos(psi)) = 0.

    Args:
        noise_std: (s_kappa in 1/m, s_psi in rad) if known; default: estimated from the data's
            second differences (needs densely sampled, time-ordered data).
        hac: use a Newey-West (autocorrelation-robust) covariance; else the i.i.d. sandwich.
        rel_tol: a quantity is "determined" when its 95 % half-width <= rel_tol |value|.
        bounds_m: bounds on L1 and L2 (m).

    Attributes (after ``fit``):
        L1_, L2_: estimates (m). cov_: 2 x 2 covariance (m^2). noise_std_: (s_k, s_p) used.
        psi_hat_: profiled true joint angles (rad). verdict_: IdentifiabilityVerdict.
        result_: CalibrationResult. method_result_: MethodResult row "EIV-ML".
        converged_: optimiser success. n_: samples used. bandwidth_: HAC lag window.
    """

    name = "EIV-ML"

    def __init__(
        self,
        *,
        noise_std: tuple[float, float] | None = None,
        hac: bool = True,
        rel_tol: float = 0.1,
        bounds_m: tuple[float, float] = (1e-3, 100.0),
    ) -> None:
        self.noise_std = noise_std
        self.hac = hac
        self.rel_tol = rel_tol
        self.bounds_m = bounds_m

    def _validate(self, kappa: ArrayLike, psi: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        k = np.asarray(kappa, dtype=float).ravel()
        p = np.asarray(psi, dtype=float).ravel()
        if k.shape != p.shape:
            raise InsufficientDataError(
                f"SteadyStateEIV.fit: kappa has {k.size} samples but psi has {p.size}"
            )
        ok = np.isfinite(k) & np.isfinite(p)
        k, p = k[ok], p[ok]
        if k.size < 10:
            raise InsufficientDataError(
                f"SteadyStateEIV.fit: {k.size} finite (kappa, psi) samples; need at least 10"
            )
        if float(np.ptp(k)) <= 0.0:
            raise InsufficientDataError("SteadyStateEIV.fit: kappa is constant; nothing to fit")
        return k, p

    def _noise(self, k: np.ndarray, p: np.ndarray) -> tuple[float, float]:
        if self.noise_std is not None:
            sk, sp = (float(x) for x in self.noise_std)
        else:
            sk, sp = hf_noise_std(k), hf_noise_std(p)
        floor_k = 1e-9 * max(float(np.max(np.abs(k))), 1e-6)
        floor_p = 1e-9 * max(float(np.max(np.abs(p))), 1e-6)
        return max(sk, floor_k), max(sp, floor_p)

    def fit(self, kappa: ArrayLike, psi: ArrayLike) -> SteadyStateEIV:
        """Fit to measured curvature ``kappa`` (1/m) and joint angle ``psi`` (rad), time-ordered.

        Raises:
            InsufficientDataError: fewer than 10 finite samples or constant curvature.
            SolverError: the optimiser produced a non-finite result.
        """
        k, p = self._validate(kappa, psi)
        sk, sp = self._noise(k, p)
        lo, hi = self.bounds_m

        last: list[np.ndarray | None] = [None]
        cache: dict[bytes, np.ndarray] = {}

        def project(theta: np.ndarray) -> np.ndarray:
            key = theta.tobytes()
            if key not in cache:
                # started from the previous projection: the optimiser's points are close
                ph = project_onto_curve(k, p, theta[0], theta[1], sk, sp, start=last[0])
                last[0] = ph
                cache.clear()
                cache[key] = ph
            return cache[key]

        compressed: dict[bytes, np.ndarray] = {}

        def reduced(theta: np.ndarray) -> np.ndarray:
            """R (3 x 3) of [J r] at ``theta``: the 2n residuals folded into three (below)."""
            key = theta.tobytes()
            if key not in compressed:
                ph = project(theta)
                g, _, _ = _g(ph, theta[0], theta[1])
                r = np.concatenate([(k - g) / sk, (p - ph) / sp])
                J = _profiled_jacobian(k, p, ph, theta[0], theta[1], sk, sp)

                def rows(a: int, b: int, out: np.ndarray) -> None:
                    out[:, :2] = J[a:b]
                    out[:, 2] = r[a:b]

                compressed.clear()
                compressed[key] = triangular_factor_by_rows(r.size, 3, rows)
            return compressed[key]

        # The optimiser sees the 2n residuals r and their Jacobian J through the R factor of
        # [J r]: three residuals R[:, 2] with Jacobian R[:, :2] have the same sum of squares,
        # the same J^T J and the same J^T r at every point, so every step, acceptance test and
        # stopping rule of least_squares is the one it takes on the 2n residuals (up to
        # rounding), without the six copies of the 2n x 2 Jacobian it makes inside
        # (on a 1-hour log, the analysis's peak).
        def resid(theta: np.ndarray) -> np.ndarray:
            return reduced(theta)[:, 2].copy()

        def jac(theta: np.ndarray) -> np.ndarray:
            return reduced(theta)[:, :2].copy()

        x0 = np.clip(_initial_guess(k, p), lo * 1.01, hi * 0.99)
        sol = least_squares(
            resid,
            x0,
            jac=jac,
            bounds=([lo, lo], [hi, hi]),
            x_scale=1.0,
            xtol=1e-12,
            ftol=1e-12,
            gtol=1e-12,
            max_nfev=200,
        )
        if not np.all(np.isfinite(sol.x)):
            raise SolverError(f"SteadyStateEIV.fit: non-finite estimate {sol.x!r}")
        L1, L2 = (float(v) for v in sol.x)
        ph = project_onto_curve(k, p, L1, L2, sk, sp)
        e, J = self._effective(k, p, ph, L1, L2, sk, sp)
        bw = bartlett_bandwidth(e) if self.hac else 0
        cov = hac_covariance(J, e, bw)
        self.L1_, self.L2_, self.cov_ = L1, L2, cov
        self.noise_std_ = (sk, sp)
        self.psi_hat_ = ph
        self.converged_ = bool(sol.success)
        self.n_ = int(k.size)
        self.bandwidth_ = bw
        self.cost_ = float(np.sum(e * e))
        span = hi - lo
        self.on_bound_ = [
            n for n, v in (("L1", L1), ("L2", L2)) if v - lo < 1e-4 * span or hi - v < 1e-4 * span
        ]
        self.verdict_ = identifiability(
            cov,
            (L1, L2),
            rel_tol=self.rel_tol,
            method=self.name,
            not_determined=self.on_bound_,
        )
        self.result_ = self._calibration(J, e)
        self.method_result_ = self._method_row(J)
        return self

    @staticmethod
    def _effective(
        k: np.ndarray, p: np.ndarray, ph: np.ndarray, L1: float, L2: float, sk: float, sp: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """Signed noise-metric distance of each point to the curve and its (L1, L2) gradient
        with the true angle profiled out (Schur complement of the full Fisher information)."""
        g, dg, D = _g(ph, L1, L2)
        d = np.sqrt(((k - g) / sk) ** 2 + ((p - ph) / sp) ** 2)
        e = np.sign(k - g) * d
        scale = np.sqrt(sk * sk + dg * dg * sp * sp)
        s = np.sin(ph)
        dgdL1 = -s * np.cos(ph) / (D * D)
        dgdL2 = -s / (D * D)
        J = -np.column_stack([dgdL1, dgdL2]) / scale[:, None]
        return e, J

    def _calibration(self, J: np.ndarray, e: np.ndarray) -> CalibrationResult:
        aic, bic = information_criteria(float(np.sum(e * e)), e.size, 2)
        return calibration_result(
            self.name,
            self.verdict_,
            self.cov_,
            converged=self.converged_,
            aic=aic,
            bic=bic,
            details={
                "estimator": "errors-in-variables ML, steady-state relation",
                "noise_std_kappa": self.noise_std_[0],
                "noise_std_psi": self.noise_std_[1],
                "hac_bandwidth": self.bandwidth_,
                "n_samples": self.n_,
                "reduced_chi2": float(np.sum(e * e)) / max(e.size - 2, 1),
                "identifiability": self.verdict_.to_dict(),
            },
        )

    def _method_row(self, J: np.ndarray) -> MethodResult:
        sv = np.linalg.svd(J, compute_uv=False)
        cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf
        return method_result(self.name, Family.EIV, self.verdict_, condition_number=cond)

    @property
    def verdict(self) -> IdentifiabilityVerdict:
        """The identifiability verdict (after ``fit``)."""
        return self.verdict_
