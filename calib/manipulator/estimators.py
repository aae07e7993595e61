"""Estimators of the arm's base parameters.

* :func:`paper_estimator`: the JKROS 2012 constrained minimum-change estimator (Eq. 20, as
  METHODS.md gives it, with the pseudo-code's typo writing Omega for Gamma corrected): per sample
  Omega += Y^T Y, Gamma += Y^T u, W = (I + Omega^T Omega)^-1, Z = pinv(Omega W Omega^T),
  Omega_w+ = W Omega^T Z, theta = Omega_w+ Gamma + (I - Omega_w+ Omega) W theta_prev.
  Where Omega has full rank this is the least-squares solution of every row so far; the null
  space of Omega keeps (a W-weighted) previous estimate.
* :func:`rls`: recursive least squares as in the paper, P0 = 1000 I,
  P -= P Y^T (I + Y P Y^T)^-1 Y P, K = P Y^T, theta += K (u - Y theta).
* :func:`batch_wls`: weighted least squares with a heteroscedasticity- and autocorrelation-
  consistent (Newey-West) covariance. Weights are per joint, 1 / residual variance of an OLS
  pass: joints differ in torque noise (and units, for a prismatic joint), so equal weights would
  let the noisiest joint dominate. The residuals are not independent from one row to the next
  (the zero-phase filter spreads each sample's noise over ~rate/cut-off samples, adjacent momentum
  windows share an end point, and unmodelled dynamics are smooth in time), so an ordinary
  covariance would give intervals far too narrow; Newey-West sums the score autocovariances up to
  a lag set from where the residual autocorrelation dies out.

Columns are scaled to unit norm inside the solves (the condition number is reported on the
scaled regressor); every result is in the caller's units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from calib.errors import InsufficientDataError
from calib.stats import bartlett_long_run, sandwich

__all__ = ["WLSResult", "batch_wls", "condition_number", "paper_estimator", "rls"]

Array = NDArray[np.float64]
VIF_LIMIT = 1e4
"""A parameter whose column is explained by the others to 1 - 1/VIF_LIMIT is not determined."""


def condition_number(X: Array) -> float:
    """Condition number of ``X`` (rows x P) after scaling each column to unit norm."""
    A = X.reshape(-1, X.shape[-1])
    norms = np.linalg.norm(A, axis=0)
    if np.any(norms == 0):
        return float("inf")
    s = np.linalg.svd(A / norms, compute_uv=False)
    return float(s[0] / s[-1]) if s[-1] > 0 else float("inf")


@dataclass(frozen=True)
class WLSResult:
    """Batch WLS: ``theta`` with covariance ``cov`` (HAC), ``std``, per-parameter
    ``identifiable`` (variance-inflation factor below ``VIF_LIMIT`` and a finite std), joint
    weights ``sigma`` (residual std per joint), the Newey-West lag and the condition number."""

    theta: Array
    cov: Array
    std: Array
    identifiable: Array
    vif: Array
    sigma: Array
    lag: int
    condition_number: float
    residual: Array


def _nw_lag(res: Array, T: int) -> int:
    """Lag where the mean residual autocorrelation over joints first drops below 0.05, x2."""
    r = res - res.mean(axis=0)
    var = (r**2).sum(axis=0)
    var[var == 0] = 1.0
    maxlag = max(1, min(T // 4, 400))
    for lag in range(1, maxlag):
        acf = float(np.mean((r[lag:] * r[:-lag]).sum(axis=0) / var))
        if acf < 0.05:
            return min(maxlag, max(int(np.floor(4 * (T / 100) ** (2 / 9))), 2 * lag))
    return maxlag


def batch_wls(X: Array, y: Array, weights: Array | None = None) -> WLSResult:
    """Weighted least squares of ``y`` (T, n) on ``X`` (T, n, P), rows in time order.

    Raises:
        InsufficientDataError: fewer rows than parameters, or a column that is all zero.
    """
    T, n, P = X.shape
    if T * n <= P:
        raise InsufficientDataError(f"{T * n} equations for {P} parameters")
    A = X.reshape(T * n, P)
    norms = np.linalg.norm(A, axis=0)
    dead = norms == 0
    norms[dead] = 1.0
    As = A / norms
    b = y.reshape(T * n)
    if weights is None:
        th0, *_ = np.linalg.lstsq(As, b, rcond=None)
        res0 = (b - As @ th0).reshape(T, n)
        sigma = np.sqrt(np.mean(res0**2, axis=0))
        sigma[sigma == 0] = max(float(sigma.max()), 1e-12)
        sigma = np.where(sigma > 0, sigma, 1.0)
    else:
        sigma = 1.0 / np.sqrt(weights)
    w = np.tile(1.0 / sigma, T)
    Aw, bw = As * w[:, None], b * w
    ths, *_ = np.linalg.lstsq(Aw, bw, rcond=None)
    res = (b - As @ ths).reshape(T, n)
    # Newey-West on per-time scores
    scores = (Aw * (bw - Aw @ ths)[:, None]).reshape(T, n, P).sum(axis=1)
    lag = _nw_lag(res / sigma, T)
    S = bartlett_long_run(scores, lag)
    H = Aw.T @ Aw
    Hinv = np.linalg.pinv(H)
    covs = sandwich(H, S)
    with np.errstate(divide="ignore", invalid="ignore"):
        vif = np.diag(Hinv) * np.diag(H)
    vif[dead] = np.inf
    theta = ths / norms
    cov = covs / np.outer(norms, norms)
    std = np.sqrt(np.clip(np.diag(cov), 0, None))
    ident = (vif < VIF_LIMIT) & np.isfinite(std) & ~dead
    theta = np.where(dead, np.nan, theta)
    std = np.where(ident, std, np.nan)
    return WLSResult(theta, cov, std, ident, vif, sigma, lag, condition_number(A[:, ~dead]), res)


def paper_estimator(X: Array, u: Array, theta0: Array | None = None) -> Array:
    """The paper's estimator over rows ``X`` (T, n, P), ``u`` (T, n): theta after each row."""
    T, _n, P = X.shape
    th = np.zeros(P) if theta0 is None else np.asarray(theta0, float).copy()
    Om = np.zeros((P, P))
    Ga = np.zeros(P)
    eye = np.eye(P)
    out = np.empty((T, P))
    for k in range(T):
        Y = X[k]
        Om += Y.T @ Y
        Ga += Y.T @ u[k]
        W = np.linalg.inv(eye + Om.T @ Om)
        Z = np.linalg.pinv(Om @ W @ Om.T)
        Ow = W @ Om.T @ Z
        th = Ow @ Ga + (eye - Ow @ Om) @ W @ th
        out[k] = th
    return out


def rls(X: Array, u: Array, p0: float = 1000.0, theta0: Array | None = None) -> tuple[Array, Array]:
    """The paper's RLS over rows ``X`` (T, n, P), ``u`` (T, n): (theta after each row, final P)."""
    T, n, P = X.shape
    th = np.zeros(P) if theta0 is None else np.asarray(theta0, float).copy()
    Pm = p0 * np.eye(P)
    eye = np.eye(n)
    out = np.empty((T, P))
    for k in range(T):
        Y = X[k]
        PY = Pm @ Y.T
        Pm = Pm - PY @ np.linalg.solve(eye + Y @ PY, PY.T)
        Pm = 0.5 * (Pm + Pm.T)
        K = Pm @ Y.T
        th = th + K @ (u[k] - Y @ th)
        out[k] = th
    return out, Pm
