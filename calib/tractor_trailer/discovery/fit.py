"""Nonlinear least-squares fit of a model spec, held-out RMS, BIC and intervals.

Residuals are weighted by each output's white-noise level on the fitting grid. Evidence and
intervals use an effective sample size n (1 - rho) / (1 + rho) per output, rho the lag-1
autocorrelation of the residual, so that correlated residuals on 10 Hz data are not counted as
independent samples.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from calib.errors import SolverError
from calib.stats import bartlett_long_run, bic_channels, lag1_factor, sandwich
from calib.tractor_trailer.discovery.data import RESOLUTION, DiscoveryData
from calib.tractor_trailer.discovery.model import ModelSpec, Vector, predict

__all__ = [
    "CommandFit",
    "bic",
    "covariance",
    "fit_model",
    "holdout_rms",
    "neff_factors",
    "param_std",
]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True)
class CommandFit:
    """A fitted spec: parameter vector, residuals (recorded - modelled) on the fitting grid
    (arrays read-only: a fit is remembered and shared, ``fit_model``)."""

    spec: ModelSpec
    theta: FloatArray
    residuals: dict[str, FloatArray]
    mask: BoolArray
    jac: FloatArray
    success: bool

    @property
    def names(self) -> list[str]:
        return self.spec.param_names

    def rss(self, mask: BoolArray | None = None) -> dict[str, float]:
        """Unweighted residual sum of squares per output on ``mask`` (default: fitted rows)."""
        mk = self.mask if mask is None else mask
        return {c: float(np.sum(r[mk] ** 2)) for c, r in self.residuals.items()}

    def rms(self, mask: BoolArray | None = None) -> dict[str, float]:
        mk = self.mask if mask is None else mask
        return {c: float(np.sqrt(np.mean(r[mk] ** 2))) for c, r in self.residuals.items()}


def _residuals(
    spec: ModelSpec, theta: Vector, data: DiscoveryData, fine: bool = False
) -> dict[str, FloatArray]:
    pred = predict(spec, theta, data, fine=fine)
    return {c: data.outputs_d[c] - pred[c] for c in data.channels}


def _starts(spec: ModelSpec, theta0: Vector) -> list[np.ndarray]:
    """theta0, plus the extra starting values of the last effect's parameters."""
    base = np.asarray(theta0, dtype=float)
    if not spec.effects:
        return [base]
    last = spec.effects[-1].params
    i0 = len(base) - len(last)
    options = [(base[i0 + j], *p.starts) for j, p in enumerate(last)]
    out = []
    for combo in itertools.product(*options):
        th = base.copy()
        th[i0:] = combo
        out.append(th)
    return out


def fit_model(
    spec: ModelSpec,
    data: DiscoveryData,
    theta0: Vector,
    mask: BoolArray | None = None,
    *,
    fine: bool = False,
    tol: float = 1e-8,
    max_nfev: int | None = None,
) -> CommandFit:
    """Least-squares fit of ``spec`` on the fitting-grid rows in ``mask`` (default all).

    ``theta0`` is the starting vector (L1, L2 in m, then effect parameters); every start of the
    last effect's parameters is evaluated and the solve starts from the best. ``fine``: see
    ``model.predict``; ``tol`` the relative tolerances, ``max_nfev`` the evaluation budget.
    The fit is remembered on ``data`` (selection and confirmation ask for some fits twice);
    its arrays are read-only.
    """
    mk = np.ones(data.n_fit, dtype=bool) if mask is None else mask
    th0 = np.asarray(theta0, dtype=float)
    key = (spec, th0.tobytes(), mk.tobytes(), fine, tol, max_nfev)
    return data.recall("fit", key, lambda: _fit(spec, data, th0, mk, fine, tol, max_nfev))


def _fit(
    spec: ModelSpec,
    data: DiscoveryData,
    theta0: FloatArray,
    mk: BoolArray,
    fine: bool,
    tol: float,
    max_nfev: int | None,
) -> CommandFit:
    specs = spec.param_specs
    lo = np.array([p.lower for p in specs])
    hi = np.array([p.upper for p in specs])
    w = {c: 1.0 / data.sigma_d[c] for c in data.channels}

    def fun(theta: np.ndarray) -> np.ndarray:
        res = _residuals(spec, theta, data, fine)
        return np.concatenate([res[c][mk] * w[c] for c in data.channels])

    starts = [
        np.clip(th, lo + 1e-9 * (hi - lo), hi - 1e-9 * (hi - lo)) for th in _starts(spec, theta0)
    ]
    if fine or len(starts) == 1:
        x0 = starts[0]
    else:  # one cheap evaluation per start, then one solve from the best
        x0 = min(starts, key=lambda th: float(np.sum(fun(th) ** 2)))
    try:
        best = least_squares(
            fun, x0, bounds=(lo, hi), x_scale="jac", ftol=tol, xtol=tol, max_nfev=max_nfev
        )
    except (ValueError, np.linalg.LinAlgError) as err:  # pragma: no cover - defensive
        raise SolverError(f"discovery: fit of {spec.param_names} failed: {err}") from err
    fit = CommandFit(
        spec=spec,
        theta=np.array(best.x, dtype=float),
        residuals=_residuals(spec, best.x, data, fine),
        mask=mk.copy(),
        jac=np.array(best.jac, dtype=float),
        success=bool(best.success),
    )
    for a in (fit.theta, fit.mask, fit.jac, *fit.residuals.values()):
        a.flags.writeable = False
    return fit


def neff_factors(fit: CommandFit, mask: BoolArray | None = None) -> dict[str, float]:
    """Effective-sample factor (1 - rho)/(1 + rho) per output, rho clipped to [0, 0.995].

    Computed on contiguous rows of ``mask`` only (pairs that straddle a gap are skipped).
    """
    mk = fit.mask if mask is None else mask
    return {c: lag1_factor(r, mk) for c, r in fit.residuals.items()}


def bic(fit: CommandFit, factors: Mapping[str, float]) -> float:
    """BIC with per-output unknown noise variance and effective sample sizes.

    -2 log L = sum_c n_eff,c log(RSS_c / n_c); penalty k log(sum_c n_eff,c), k = number of
    parameters (the per-output variances are common to every model and left out).
    """
    return bic_channels(fit.rss(), int(fit.mask.sum()), factors, len(fit.theta))


def holdout_rms(
    spec: ModelSpec, theta: Vector, data: DiscoveryData, mask: BoolArray
) -> dict[str, float]:
    """RMS of recorded - modelled per output on the held-out rows ``mask``."""
    res = _residuals(spec, theta, data)
    return {c: float(np.sqrt(np.mean(r[mask] ** 2))) for c, r in res.items()}


def covariance(fit: CommandFit, data: DiscoveryData, *, robust: bool = True) -> FloatArray:
    """Parameter covariance: Gauss-Newton Fisher information, each output's residual variance
    taken from the fit and inflated by (1 + rho)/(1 - rho) for its autocorrelation; each
    variance raised to the Newey-West one where that is larger (``_hac_covariance``; not with
    ``robust=False``)."""
    mk = fit.mask
    n = int(mk.sum())
    fac = neff_factors(fit)
    rss = fit.rss()
    rows = []
    for i, c in enumerate(data.channels):
        jc = fit.jac[i * n : (i + 1) * n]
        # jac is of r / sigma_d; rescale to r / sigma_hat, then by the effective-sample factor
        # never below the resolution floor: a noise-free log's numerical error is no precision
        floor2 = RESOLUTION[c] ** 2 / data.m
        s_hat2 = max(rss[c] / max(n - len(fit.theta), 1), floor2, 1e-300)
        rows.append(jc * math.sqrt(data.sigma_d[c] ** 2 / s_hat2 * fac[c]))
    j = np.vstack(rows)
    info = j.T @ j
    # equilibrate before the pseudo-inverse: parameters on very different scales (a time shift
    # across a step against a length) must not have the smaller ones cut off as rank-deficient
    d = np.sqrt(np.clip(np.diag(info), 0.0, None))
    d = np.where(d > 0, d, 1.0)
    try:
        inv = np.linalg.pinv(info / np.outer(d, d), rcond=1e-12) / np.outer(d, d)
    except np.linalg.LinAlgError:  # pragma: no cover - defensive
        return np.full_like(info, np.nan)
    cov = np.asarray(inv, dtype=float)
    hac = _hac_covariance(fit, data, fac) if robust else None
    if hac is not None:
        # each variance at least the autocorrelation-robust one (correlations kept)
        f_diag = np.clip(np.diag(cov), 1e-300, None)
        scale = np.sqrt(np.clip(np.diag(hac) / f_diag, 1.0, 1e6))
        cov = cov * np.outer(scale, scale)
    return cov


def _hac_covariance(
    fit: CommandFit, data: DiscoveryData, fac: Mapping[str, float]
) -> FloatArray | None:
    """Newey-West (Bartlett) sandwich covariance of the least-squares parameters: robust to
    residuals that are correlated over many samples (a smooth misfit the model leaves), which
    the lag-1 inflation of the Fisher covariance underrates. Bandwidth 3 (1 + rho)/(1 - rho)
    rows (rho the largest lag-1 autocorrelation), at most a quarter of the rows."""
    mk = fit.mask
    n = int(mk.sum())
    k = len(fit.theta)
    if n < 4 * k or not np.all(np.isfinite(fit.jac)):
        return None
    g = np.zeros((n, k))
    for i, c in enumerate(data.channels):
        jc = fit.jac[i * n : (i + 1) * n]
        r = fit.residuals[c][mk] / data.sigma_d[c]
        g += jc * r[:, None]
    f_min = min(fac.values()) if fac else 1.0
    bw = int(min(n // 4, math.ceil(3.0 / max(f_min, 1e-3))))
    try:
        out = sandwich(fit.jac.T @ fit.jac, bartlett_long_run(g, bw), equilibrate=True)
    except np.linalg.LinAlgError:  # pragma: no cover - defensive
        return None
    return np.asarray(out, dtype=float) if np.all(np.isfinite(out)) else None


def param_std(fit: CommandFit, cov: FloatArray, name: str, time_shift: bool, dt_s: float) -> float:
    """Standard error of parameter ``name``: the Fisher variance, plus for a time shift (a
    dead time, a clock offset, a lag's time constant) the resolution dt^2 / 12 (a jump is only
    known to lie within one sample period; ``DiscoveryData.time_resolution_s``)."""
    i = fit.names.index(name)
    var = max(float(cov[i, i]), 0.0) + (dt_s**2 / 12.0 if time_shift else 0.0)
    return math.sqrt(var) if var > 0 and math.isfinite(var) else math.nan
