"""Autocorrelation-robust (Newey-West, Bartlett-kernel) covariances, one implementation for
every estimator of the three robots.

A least-squares estimate from residuals that are correlated over many samples (a smooth
misfit, a filtered sensor, consecutive segments sharing slip) has a covariance the Fisher
information underrates. The sandwich H^-1 S H^-1 with S the Bartlett-weighted long-run
covariance of the score contributions is robust to it (Newey & West 1987; statsmodels'
``cov_hac`` is the test reference). The pieces are public because robots sum their scores
differently (per sample, per segment, per time step over joints): :func:`bartlett_long_run`
of the scores, then :func:`sandwich`; :func:`hac_covariance` composes them for a Jacobian and
residuals.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from calib.stats.samples import autocorrelation, fft_length

__all__ = [
    "bartlett_bandwidth",
    "bartlett_long_run",
    "cube_root_lag",
    "hac_covariance",
    "long_run_variance_ratio",
    "newey_west_rule_lag",
    "sandwich",
]

FloatArray = NDArray[np.float64]

_FFT_MIN_LAGS = 64
"""From this many lags on, the lagged cross-products come from one FFT (O(n log n)) instead of
one product per lag (O(n * lags)): the same sums to rounding (~1e-12 relative)."""


def newey_west_rule_lag(n: int) -> int:
    """The Newey-West rule of thumb floor(4 (n / 100)^(2/9))."""
    return math.floor(4.0 * (n / 100.0) ** (2.0 / 9.0))


def cube_root_lag(n: int) -> int:
    """The lag window n^(1/3) (at least 1) for sums over few, long-correlated terms."""
    return max(1, round(n ** (1 / 3)))


def bartlett_bandwidth(r: np.ndarray, factor: float = 3.0) -> int:
    """Bartlett-kernel lag window for residuals ``r``.

    The larger of the Newey-West rule 4 (n/100)^(2/9) and ``factor`` times the first lag at
    which the residual autocorrelation drops below 0.05, capped at n/4.
    """
    r = np.asarray(r, dtype=float)
    n = r.size
    nw = newey_west_rule_lag(n)
    cap = max(1, n // 4)
    rho = autocorrelation(r, cap)
    below = np.nonzero(rho < 0.05)[0]
    first = int(below[0]) if below.size else cap
    return int(min(cap, max(nw, math.ceil(factor * first))))


def long_run_variance_ratio(x: np.ndarray) -> float:
    """Bartlett long-run variance over plain variance of a centred series ``x`` (lag window
    n^(1/3)): how much a sum over many consecutive terms holds of their variances (above 1:
    positively correlated terms; below 1: terms that cancel). 1.0 for fewer than 8 terms or a
    zero series; callers centre, trim and bound it as their use needs."""
    n = x.size
    if n < 8:
        return 1.0
    v0 = float(x @ x) / n
    if v0 <= 0:
        return 1.0
    lag = cube_root_lag(n)
    lrv = v0 + 2 * sum((1 - k / (lag + 1)) * float(x[k:] @ x[:-k]) / n for k in range(1, lag + 1))
    return lrv / v0


def bartlett_long_run(s: np.ndarray, lags: int, bandwidth: int | None = None) -> FloatArray:
    """sum_{|l| <= lags} w_l G_l of score contributions ``s`` (n, p), with
    G_l = sum_t s_{t+l} s_t^T and Bartlett weights w_l = 1 - |l| / (bandwidth + 1)
    (``bandwidth`` defaults to ``lags``)."""
    s = np.asarray(s, dtype=float)
    bw = lags if bandwidth is None else bandwidth
    n, p = s.shape
    lags = min(lags, n - 1)
    S: FloatArray = s.T @ s
    if lags < _FFT_MIN_LAGS:
        for lag in range(1, lags + 1):
            g = s[lag:].T @ s[:-lag]
            S += (1.0 - lag / (bw + 1.0)) * (g + g.T)
        return S
    nfft = fft_length(n + lags)
    F = np.fft.rfft(s, nfft, axis=0)  # (nfft // 2 + 1, p)
    w = 1.0 - np.arange(1, lags + 1) / (bw + 1.0)
    for i in range(p):
        # G_l[i, j] = sum_t s[t + l, i] s[t, j] = irfft(F_i conj(F_j))[l]
        cross = np.fft.irfft(F[:, i : i + 1] * np.conj(F), nfft, axis=0)[1 : lags + 1]
        row = w @ cross  # (p,): sum_l w_l G_l[i, :]
        S[i, :] += row
        S[:, i] += row
    return S


def sandwich(h: np.ndarray, s: np.ndarray, *, equilibrate: bool = False) -> FloatArray:
    """H^-1 S H^-1 with a pseudo-inverse of ``h``; ``equilibrate``: scale H to a unit diagonal
    before inverting, so that parameters on very different scales (a time shift across a step
    against a length) are not cut off as rank-deficient."""
    h = np.asarray(h, dtype=float)
    if equilibrate:
        d = np.sqrt(np.clip(np.diag(h), 0.0, None))
        d = np.where(d > 0, d, 1.0)
        inv = np.linalg.pinv(h / np.outer(d, d), rcond=1e-12) / np.outer(d, d)
    else:
        inv = np.linalg.pinv(h)
    out: FloatArray = inv @ s @ inv
    return out


def hac_covariance(jac: np.ndarray, resid: np.ndarray, bandwidth: int) -> FloatArray:
    """Sandwich covariance of a least-squares estimate with autocorrelated residuals.

    cov = H^-1 S H^-1 with H = J^T J and S the Bartlett-weighted (Newey-West) long-run
    covariance of the score contributions s_i = J_i r_i, with the n/(n-p)
    small-sample factor.

    Args:
        jac: Jacobian of the residuals w.r.t. the parameters, shape (n, p).
        resid: residuals at the estimate, shape (n,).
        bandwidth: Bartlett lag window (samples); 0 gives the White (heteroscedastic) form.

    Returns:
        (p, p) covariance in the parameters' units squared.
    """
    jac = np.asarray(jac, dtype=float)
    s = jac * np.asarray(resid, dtype=float)[:, None]
    n = s.shape[0]
    S = bartlett_long_run(s, min(bandwidth, n - 1), bandwidth)
    S *= n / max(n - s.shape[1], 1)
    cov = sandwich(jac.T @ jac, S)
    return 0.5 * (cov + cov.T)
