"""Output-error fit of the transient joint-angle kinematics to a drive log.

d psi/dt = v kappa (1 + (L1/L2) cos psi) - v sin(psi) / L2
(calib.tractor_trailer.models.hitch_kinematics).
psi is simulated forward from the measured yaw rate u = v kappa and speed v, and (L1, L2, psi0)
minimise the squared difference to the measured psi. The joint angle relaxes towards the
steady-state curve over a distance set by L2, which separates L2 from L1 where a steady-state
fit sees only L1 + L2.

Noise on the curvature input: the inputs are summarised per bin of 1/``rate_hz`` s by their
mean and slope (which keeps their integral, what drives psi, and averages white noise down);
what is left enters psi through the kinematics as low-pass, autocorrelated error that a naive
(white-residual) Fisher interval ignores. The covariance adds that error, propagated through the
linearised kinematics, and is raised to a Newey-West (HAC) estimate where that is larger.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import least_squares

from calib.errors import InsufficientDataError, SolverError
from calib.results import CalibrationResult
from calib.stats import bartlett_bandwidth, hac_covariance, hf_noise_std
from calib.tractor_trailer.estimators._integrate import plan_steps, simulate_psi
from calib.tractor_trailer.estimators._propagate import propagated_covariance
from calib.tractor_trailer.estimators._result import (
    calibration_result,
    information_criteria,
    method_result,
)
from calib.tractor_trailer.estimators.identifiability import IdentifiabilityVerdict, identifiability
from calib.tractor_trailer.results import Family, MethodResult

__all__ = ["TransientFit", "block_average"]

_START_BATCH = 32  # start-grid trajectories simulated together


@dataclass(frozen=True)
class Bins:
    """Per-bin summary of a time series on bins of equal length (s).

    ``edges`` (n + 1,), ``tbar`` mean sample time (n,), ``count`` samples per bin;
    ``mean``/``slope`` per column (NaN mean where a bin has no finite sample; slope 0 where
    it has fewer than two).
    """

    edges: np.ndarray
    tbar: np.ndarray
    count: np.ndarray
    mean: list[np.ndarray]
    slope: list[np.ndarray]


START_SPAN_S = 600.0
"""Length of log (s) the start grid of :class:`TransientFit` is scored on."""


def block_average(t_s: np.ndarray, columns: list[np.ndarray], h_s: float) -> Bins:
    """Mean and least-squares slope of each column over consecutive bins of ``h_s`` seconds
    (NaNs ignored); empty bins are given the bin centre as mean time."""
    idx = np.floor((t_s - t_s[0]) / h_s + 1e-9).astype(np.int64)
    nb = int(idx[-1]) + 1
    edges = t_s[0] + np.arange(nb + 1) * h_s
    count = np.bincount(idx, minlength=nb).astype(float)
    tsum = np.bincount(idx, weights=t_s, minlength=nb)
    centre = 0.5 * (edges[:-1] + edges[1:])
    tbar = np.where(count > 0, tsum / np.maximum(count, 1.0), centre)
    means, slopes = [], []
    for c in columns:
        ok = np.isfinite(c)
        i, tt, cc = idx[ok], t_s[ok] - tbar[idx[ok]], c[ok]
        m = np.bincount(i, minlength=nb).astype(float)
        sx = np.bincount(i, weights=tt, minlength=nb)
        sy = np.bincount(i, weights=cc, minlength=nb)
        sxx = np.bincount(i, weights=tt * tt, minlength=nb)
        sxy = np.bincount(i, weights=tt * cc, minlength=nb)
        mm = np.maximum(m, 1.0)
        mean_t, mean_y = sx / mm, sy / mm
        var_t = sxx / mm - mean_t**2
        cov_ty = sxy / mm - mean_t * mean_y
        ok_s = (m >= 2) & (var_t > 1e-12 * h_s * h_s)
        slope = np.where(ok_s, cov_ty / np.where(ok_s, var_t, 1.0), 0.0)
        # the line through the column's own mean time, moved to tbar
        mean = np.where(m > 0, mean_y - slope * mean_t, np.nan)
        means.append(mean)
        slopes.append(slope)
    return Bins(edges, tbar, count, means, slopes)


def sample_average(
    full: np.ndarray, tbar: np.ndarray, edges: np.ndarray, var_t: np.ndarray
) -> np.ndarray:
    """Average of psi over each bin's sample times, from psi at (tbar[0], edges[1], tbar[1],
    ...): psi(tbar) + psi'' var_t / 2, psi'' from the parabola through the bin's edges and
    tbar (no correction in the first and last bin).

    Args:
        full: simulated psi, shape (2 n - 1, m) (rad).
        tbar, edges: mean sample times (n,) and bin edges (n + 1,) (s).
        var_t: variance of the sample times in each bin (s^2).

    Returns:
        shape (n, m) (rad).
    """
    nodes = full[::2]
    out = nodes.copy()
    if nodes.shape[0] > 2:
        pe0, pm, pe1 = full[1:-2:2], full[2:-1:2], full[3::2]
        e0, m, e1 = edges[1:-2], tbar[1:-1], edges[2:-1]
        # a bin with one sample has var_t = 0 and may have its sample on an edge: no
        # correction there (and no division by a zero width)
        ok = ((e1 - m) > 0) & ((m - e0) > 0) & (var_t[1:-1] > 0)
        w1 = np.where(ok, e1 - m, 1.0)[:, None]
        w0 = np.where(ok, m - e0, 1.0)[:, None]
        d2 = 2.0 * ((pe1 - pm) / w1 - (pm - pe0) / w0) / (e1 - e0)[:, None]
        out[1:-1] += np.where(ok[:, None], 0.5 * d2 * var_t[1:-1, None], 0.0)
    return out


def _fill(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Linear interpolation over NaNs (held constant beyond the ends)."""
    ok = np.isfinite(x)
    return x if ok.all() else np.interp(t, t[ok], x[ok])


def _hf(x: np.ndarray) -> float:
    """High-frequency noise std of the finite samples of ``x``."""
    return hf_noise_std(x[np.isfinite(x)])


def _inflate(cov: np.ndarray, other: np.ndarray) -> np.ndarray:
    """``cov`` with each parameter's variance raised to ``other``'s where that is larger
    (correlations kept); ``other`` where ``cov`` has no variance."""
    d, e = np.diag(cov), np.diag(other)
    if np.any(d <= 0):
        return other
    s = np.sqrt(np.maximum(1.0, e / d))
    return cov * np.outer(s, s)


def _sample_time_variance(t: np.ndarray, b: Bins) -> np.ndarray:
    """Variance (s^2) of the sample times in each bin (0 where a bin has < 2 samples)."""
    h = b.edges[1] - b.edges[0]
    idx = np.floor((t - b.edges[0]) / h + 1e-9).astype(np.int64)
    d = t - b.tbar[idx]
    m = np.maximum(b.count, 1.0)
    return np.bincount(idx, weights=d * d, minlength=b.tbar.size) / m


_ADVICE = (
    "drive with faster curvature changes (steps or turns shorter than a few trailer lengths) "
    "and larger joint angles, or lower the sensor noise"
)


class TransientFit:
    """Output-error fit of (L1, L2, psi0) to the joint-angle time series.

    Its rows and messages carry ``TransientFit.name`` ("Transient-ML", in the JSON ``name``)
    and the family "TRANSIENT" it shares with ``PathTransientFit`` ("Transient-path"): refer
    to it through ``TransientFit.name`` rather than retyping the string.

    Args:
        rate_hz: rate of the even grid the log is block-averaged onto (Hz).
        rel_tol: a quantity is "determined" when its 95 % half-width <= rel_tol |value|.
        covariance: "propagated" (default): white psi noise plus the curvature and speed
            noise carried through the linearised kinematics (noise levels from second
            differences), each variance raised to the Newey-West (HAC) one where that is
            larger; "hac": Newey-West sandwich only; "iid": the naive white-residual sandwich
            (undercovers with noisy inputs; kept for comparison).
        v_min_mps: |v| below which a non-finite curvature is taken as zero yaw rate (m/s).
        bounds_L1_m, bounds_L2_m: parameter bounds (m). The lower L2 bound sets the RK4
            substeps (stability of the relaxation at the highest speed).

    Attributes (after ``fit``):
        L1_, L2_, psi0_: estimates (m, m, rad). cov_: 3 x 3 covariance of (L1, L2, psi0).
        verdict_: IdentifiabilityVerdict of (L1, L2). result_: CalibrationResult.
        method_result_: MethodResult row "Transient-ML". converged_: optimiser success.
        sound_: converged, finite covariance, L2 interval clear of its lower bound and
        residual rms <= 1.5 expected + 1e-4 rad. residual_rms_: rms of psi residuals (rad).
        expected_rms_: rms (rad) the sensor noise alone would leave (psi noise of the bin means
        plus the curvature and speed noise carried through the kinematics).
        cov_propagated_, cov_hac_: the two covariances behind ``cov_``; cov_iid_: the naive
        white-residual sandwich, for comparison.
        t_grid_s_, psi_fit_: bin mean times (s) and fitted psi (rad).
    """

    name = "Transient-ML"

    def __init__(
        self,
        *,
        rate_hz: float = 10.0,
        rel_tol: float = 0.1,
        covariance: Literal["propagated", "hac", "iid"] = "propagated",
        v_min_mps: float = 0.05,
        bounds_L1_m: tuple[float, float] = (0.0, 50.0),
        bounds_L2_m: tuple[float, float] = (0.2, 50.0),
    ) -> None:
        self.rate_hz = rate_hz
        self.rel_tol = rel_tol
        self.covariance = covariance
        self.v_min_mps = v_min_mps
        self.bounds_L1_m = bounds_L1_m
        self.bounds_L2_m = bounds_L2_m

    # ---------------------------------------------------------------- preparation
    def _validate(
        self, t_s: ArrayLike, kappa: ArrayLike, v: ArrayLike, psi: ArrayLike
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        arrs = [np.asarray(a, dtype=float).ravel() for a in (t_s, kappa, v, psi)]
        sizes = {a.size for a in arrs}
        if len(sizes) != 1:
            raise InsufficientDataError(
                "TransientFit.fit: t_s, kappa, v, psi must have equal lengths, got "
                f"{[a.size for a in arrs]}"
            )
        t, k, vv, p = arrs
        keep = np.isfinite(t) & np.isfinite(vv)
        t, k, vv, p = t[keep], k[keep], vv[keep], p[keep]
        if t.size < 20:
            raise InsufficientDataError(
                f"TransientFit.fit: {t.size} samples with finite time and speed; need 20"
            )
        if np.any(np.diff(t) <= 0):
            raise InsufficientDataError("TransientFit.fit: t_s must be strictly increasing")
        return t, k, vv, p

    def _grid(self, t: np.ndarray, k: np.ndarray, v: np.ndarray, p: np.ndarray) -> Bins:
        u = k * v
        u = np.where(~np.isfinite(u) & (np.abs(v) < self.v_min_mps), 0.0, u)
        b = block_average(t, [u, v, p], 1.0 / self.rate_hz)
        if np.sum(np.isfinite(b.mean[0])) < 2:
            raise InsufficientDataError("TransientFit.fit: no finite curvature (kappa) samples")
        if np.sum(np.isfinite(b.mean[2])) < 10:
            raise InsufficientDataError("TransientFit.fit: fewer than 10 finite psi samples")
        return b

    # ---------------------------------------------------------------- fitting
    def _sim(self, theta: np.ndarray) -> np.ndarray:
        """psi (n, m) for parameter sets theta (3, m) = (L1, L2, psi0)."""
        full = simulate_psi(self._plan, theta[0], theta[1], theta[2])
        return sample_average(full, self._tbar, self._edges, self._var_t)

    def _start(self, psi0: float) -> np.ndarray:
        """Best point of a coarse (L1, L2) grid, scored on the first ``START_SPAN_S`` of the
        log: the grid only picks the basin the local fit starts in, so its cost need not grow
        with the log's length (225 trajectories)."""
        lo1, hi1 = self.bounds_L1_m
        lo2, hi2 = self.bounds_L2_m
        g1 = np.concatenate([[max(lo1, 0.0)], np.geomspace(max(lo1, 0.1), min(hi1, 20.0), 14)])
        g2 = np.geomspace(lo2, min(hi2, 20.0), 15)
        A, B = np.meshgrid(g1, g2, indexing="ij")
        th = np.vstack([A.ravel(), B.ravel(), np.full(A.size, psi0)])
        n = self._start_bins
        cost = np.empty(th.shape[1])
        for a in range(0, th.shape[1], _START_BATCH):  # batches: memory of 32 trajectories
            b = min(a + _START_BATCH, th.shape[1])
            full = simulate_psi(self._start_plan, th[0, a:b], th[1, a:b], th[2, a:b])
            sim = sample_average(full, self._tbar[:n], self._edges[: n + 1], self._var_t[:n])
            cost[a:b] = np.nansum((self._psi[:n, None] - sim) ** 2 * self._w[:n, None], axis=0)
        return th[:, int(np.argmin(cost))]

    def fit(self, t_s: ArrayLike, kappa: ArrayLike, v: ArrayLike, psi: ArrayLike) -> TransientFit:
        """Fit to a time-ordered log.

        Args:
            t_s: sample times (s), strictly increasing.
            kappa: measured curvature of C1 (1/m); NaN allowed where the robot stands still.
            v: measured speed of C1 (m/s).
            psi: measured joint angle (rad); NaN where missing.

        Raises:
            InsufficientDataError: too few samples, unequal lengths, no curvature or psi.
            SolverError: the optimiser produced a non-finite result.
        """
        t, k, vv, p = self._validate(t_s, kappa, v, psi)
        b = self._grid(t, k, vv, p)
        tc = b.tbar
        pb = b.mean[2]
        npsi = np.bincount(
            np.floor((t[np.isfinite(p)] - t[0]) * self.rate_hz + 1e-9).astype(np.int64),
            minlength=tc.size,
        ).astype(float)
        vmax = float(np.nanmax(np.abs(vv)))
        h = 1.0 / self.rate_hz
        n_sub = max(1, math.ceil(0.5 * h * vmax / (0.7 * self.bounds_L2_m[0])))
        u_mean, v_mean = _fill(tc, b.mean[0]), _fill(tc, b.mean[1])
        self._plan = plan_steps(tc, b.edges, u_mean, b.slope[0], v_mean, b.slope[1], n_sub)
        n = min(tc.size, max(10, math.ceil(START_SPAN_S * self.rate_hz)))
        self._start_bins = n
        self._start_plan = (
            self._plan
            if n == tc.size
            else plan_steps(
                tc[:n],
                b.edges[: n + 1],
                u_mean[:n],
                b.slope[0][:n],
                v_mean[:n],
                b.slope[1][:n],
                n_sub,
            )
        )
        self._tbar, self._edges = tc, b.edges
        self._var_t = _sample_time_variance(t, b)
        self._psi = pb
        self._w = np.isfinite(pb).astype(float)
        valid = np.isfinite(pb)
        psi0 = float(pb[valid][0])
        x0 = self._start(psi0)
        lo = np.array([self.bounds_L1_m[0], self.bounds_L2_m[0], -math.pi])
        hi = np.array([self.bounds_L1_m[1], self.bounds_L2_m[1], math.pi])
        x0 = np.clip(x0, lo + 1e-6, hi - 1e-6)
        cache: dict[bytes, np.ndarray] = {}

        def sims(x: np.ndarray) -> np.ndarray:
            key = x.tobytes()
            if key not in cache:
                d = 1e-6 * np.maximum(np.abs(x), 1.0)
                th = np.column_stack([x, x[:, None] + np.diag(d)])  # (3, 4)
                cache.clear()
                cache[key] = self._sim(th)[valid]
            return cache[key]

        def fun(x: np.ndarray) -> np.ndarray:
            return pb[valid] - sims(x)[:, 0]

        def jac(x: np.ndarray) -> np.ndarray:
            s = sims(x)
            d = 1e-6 * np.maximum(np.abs(x), 1.0)
            return -(s[:, 1:] - s[:, :1]) / d

        sol = least_squares(
            fun, x0, jac=jac, bounds=(lo, hi), xtol=1e-10, ftol=1e-12, gtol=1e-10, max_nfev=100
        )
        if not np.all(np.isfinite(sol.x)):
            raise SolverError(f"TransientFit.fit: non-finite estimate {sol.x!r}")
        r = fun(sol.x)
        J = jac(sol.x)
        noise = (hf_noise_std(p[np.isfinite(p)]), _hf(k * vv), _hf(vv))
        lin = self._linearise(sol.x, valid, npsi, b.count, u_mean, v_mean, noise)
        bw = bartlett_bandwidth(r) if self.covariance != "iid" else 0
        cov_hac = hac_covariance(J, r, bw)
        J_full = np.zeros((valid.size, J.shape[1]))
        J_full[valid] = -J  # d psi_model / d theta
        cov_prop = propagated_covariance(J_full, *lin)
        self.cov_propagated_, self.cov_hac_ = cov_prop, cov_hac
        self.cov_iid_ = hac_covariance(J, r, 0)
        cov = _inflate(cov_prop, cov_hac) if self.covariance == "propagated" else cov_hac
        self.L1_, self.L2_, self.psi0_ = (float(c) for c in sol.x)
        self.cov_ = cov
        self.converged_ = bool(sol.success)
        self.bandwidth_ = bw
        self.n_ = int(r.size)
        self.t_grid_s_ = tc
        self.psi_fit_ = self._sim(sol.x[:, None])[:, 0]
        self.residual_rms_ = float(np.sqrt(np.mean(r * r)))
        self.psi_noise_std_ = noise[0]
        self.expected_rms_ = float(np.sqrt(np.mean(lin[3][valid] + self._input_var[valid])))
        self.sound_ = self._is_sound()
        self._build_results(r, J)
        return self

    def _linearise(
        self,
        x: np.ndarray,
        valid: np.ndarray,
        npsi: np.ndarray,
        count: np.ndarray,
        u: np.ndarray,
        v: np.ndarray,
        noise: tuple[float, float, float],
    ) -> tuple[np.ndarray, ...]:
        """Linearised dynamics along the fit and per-node noise variances: (a, b_u, b_v,
        var_psi, var_u, var_v) for ``propagated_covariance``. Also sets ``_input_var``, the
        variance of psi (rad^2) caused by the input noise at each node."""
        L1, L2, _ = x
        ps = self._sim(x[:, None])[:, 0]
        h = np.append(np.diff(self._tbar), 0.0)
        r = L1 / L2
        a = np.exp(h * (-u * r * np.sin(ps) - v * np.cos(ps) / L2))
        b_u = h * (1.0 + r * np.cos(ps))
        b_v = -h * np.sin(ps) / L2
        sp, su, sv = noise
        var_psi = np.where(valid, sp * sp / np.maximum(npsi, 1.0), 0.0)
        var_u = su * su / np.maximum(count, 1.0)
        var_v = sv * sv / np.maximum(count, 1.0)
        q = b_u * b_u * var_u + b_v * b_v * var_v
        iv = np.zeros(ps.size)
        a2, ql = (a * a).tolist(), q.tolist()
        acc = 0.0
        for i in range(ps.size - 1):
            acc = a2[i] * acc + ql[i]
            iv[i + 1] = acc
        self._input_var = iv
        return a, b_u, b_v, var_psi, var_u, var_v

    def _is_sound(self) -> bool:
        """Converged, finite covariance, L2's interval clear of its lower bound (the fit is not
        pushing towards an instantaneous joint angle), residuals at the noise level."""
        cov = self.cov_
        if not (self.converged_ and np.all(np.isfinite(cov)) and np.all(np.diag(cov) > 0)):
            return False
        lo2 = self.L2_ - 1.96 * math.sqrt(cov[1, 1])
        if lo2 <= self.bounds_L2_m[0]:
            return False
        return self.residual_rms_ <= 1.5 * self.expected_rms_ + 1e-4

    def _build_results(self, r: np.ndarray, J: np.ndarray) -> None:
        cov = self.cov_
        cov2 = cov[:2, :2]
        self.verdict_ = identifiability(
            cov2, (self.L1_, self.L2_), rel_tol=self.rel_tol, method=self.name, advice=_ADVICE
        )
        aic, bic = information_criteria(float(r @ r), r.size, 3)
        self.result_ = calibration_result(
            self.name,
            self.verdict_,
            cov2,
            converged=self.converged_,
            aic=aic,
            bic=bic,
            details={
                "estimator": "output-error ML of the transient joint-angle kinematics",
                "psi0_rad": self.psi0_,
                "psi0_std_rad": float(np.sqrt(max(cov[2, 2], 0.0))),
                "grid_rate_hz": self.rate_hz,
                "covariance": self.covariance,
                "hac_bandwidth": self.bandwidth_,
                "n_grid_samples": self.n_,
                "residual_rms_rad": self.residual_rms_,
                "expected_rms_rad": self.expected_rms_,
                "sound": self.sound_,
                "identifiability": self.verdict_.to_dict(),
            },
        )
        sv = np.linalg.svd(J[:, :2], compute_uv=False)
        cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf
        self.method_result_: MethodResult = method_result(
            self.name,
            Family.TRANSIENT,
            self.verdict_,
            condition_number=cond,
            extra={"psi0_rad": self.psi0_, "residual_rms_rad": self.residual_rms_},
        )

    @property
    def verdict(self) -> IdentifiabilityVerdict:
        """The identifiability verdict (after ``fit``)."""
        return self.verdict_

    @property
    def calibration(self) -> CalibrationResult:
        """The CalibrationResult (after ``fit``)."""
        return self.result_
