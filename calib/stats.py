"""Shared statistics for the estimators: high-frequency noise level and HAC covariances."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "Z95",
    "autocorrelation",
    "bartlett_bandwidth",
    "detect_quantum",
    "fft_length",
    "hac_covariance",
    "hf_noise_std",
    "hf_noise_std_t",
    "long_run_variance_ratio",
]

FloatArray = NDArray[np.float64]

_MAD_TO_STD = 1.482602218505602
Z95 = 1.959963984540054
"""The two-sided 95 % quantile of the standard normal distribution."""


def hf_noise_std(x: np.ndarray) -> float:
    """White-noise standard deviation of a smooth signal sampled densely, from its second
    differences: x[i+1] - 2 x[i] + x[i-1] has variance 6 sigma^2 (robust MAD estimate).

    Args:
        x: samples (any unit), evenly spaced, NaN-free.

    Returns:
        sigma in the unit of ``x``; 0 for fewer than 5 samples.
    """
    x = np.asarray(x, dtype=float)
    if x.size < 5:
        return 0.0
    d2 = x[2:] - 2.0 * x[1:-1] + x[:-2]
    mad = float(np.median(np.abs(d2 - np.median(d2))))
    return _MAD_TO_STD * mad / math.sqrt(6.0)


def local_line_errors(t: np.ndarray, x: np.ndarray) -> FloatArray:
    """Each sample of ``x`` (at uneven times ``t``) against the line through its neighbours,
    e_i = (x_i - (a x_(i-1) + b x_(i+1))) / sqrt(1 + a^2 + b^2): for white noise of std sigma,
    e has std sigma (NaN samples and repeated stamps left out)."""
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    ok = np.isfinite(t) & np.isfinite(x)
    t, x = t[ok], x[ok]
    if x.size < 5:
        return np.zeros(0)
    h0, h1 = t[1:-1] - t[:-2], t[2:] - t[1:-1]
    span = h0 + h1
    good = span > 0
    a = np.where(good, h1 / np.where(good, span, 1.0), 0.5)
    b = 1.0 - a
    e = (x[1:-1] - a * x[:-2] - b * x[2:]) / np.sqrt(1.0 + a * a + b * b)
    out: FloatArray = e[good]
    return out


def hf_noise_std_t(t: np.ndarray, x: np.ndarray) -> float:
    """``hf_noise_std`` for samples at uneven times ``t``: the robust (MAD) std of
    :func:`local_line_errors`."""
    e = local_line_errors(t, x)
    if e.size < 3:
        return 0.0
    return _MAD_TO_STD * float(np.median(np.abs(e - np.median(e))))


def fft_length(n: int) -> int:
    """The smallest 2^i 3^j 5^k >= n: an FFT length numpy transforms fast (a power of two
    can be nearly twice as long, and past the cache several times slower)."""
    best = 1 << max(0, (n - 1).bit_length())
    p5 = 1
    while p5 < best:
        p35 = p5
        while p35 < best:
            m = p35
            while m < n:
                m *= 2
            best = min(best, m)
            p35 *= 3
        p5 *= 5
    return best


def autocorrelation(r: np.ndarray, max_lag: int) -> FloatArray:
    """Sample autocorrelation of ``r`` (mean removed) at lags 0..max_lag, via the FFT
    (zero-padded to at least n + max_lag samples, so lags up to max_lag do not wrap around);
    zeros for a constant ``r``."""
    r = r - r.mean()
    m = fft_length(r.size + max_lag)
    f = np.fft.rfft(r, m)
    ac = np.fft.irfft(f * np.conj(f), m)[: max_lag + 1]
    return ac / ac[0] if ac[0] > 0 else np.zeros(max_lag + 1)


def bartlett_bandwidth(r: np.ndarray, factor: float = 3.0) -> int:
    """Bartlett-kernel lag window for residuals ``r``.

    The larger of the Newey-West rule 4 (n/100)^(2/9) and ``factor`` times the first lag at
    which the residual autocorrelation drops below 0.05, capped at n/4.
    """
    r = np.asarray(r, dtype=float)
    n = r.size
    nw = math.floor(4.0 * (n / 100.0) ** (2.0 / 9.0))
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
    lag = max(1, round(n ** (1 / 3)))
    lrv = v0 + 2 * sum((1 - k / (lag + 1)) * float(x[k:] @ x[:-k]) / n for k in range(1, lag + 1))
    return lrv / v0


_FFT_MIN_LAGS = 64
"""From this many lags on, the lagged cross-products come from one FFT (O(n log n)) instead of
one product per lag (O(n * lags)): the same sums to rounding (~1e-12 relative)."""


def _bartlett_long_run(s: np.ndarray, lags: int, bandwidth: int) -> FloatArray:
    """sum_{|l| <= lags} w_l G_l with G_l = sum_t s_{t+l} s_t^T and Bartlett weights
    w_l = 1 - |l| / (bandwidth + 1)."""
    n, p = s.shape
    S: FloatArray = s.T @ s
    if lags < _FFT_MIN_LAGS:
        for lag in range(1, lags + 1):
            g = s[lag:].T @ s[:-lag]
            S += (1.0 - lag / (bandwidth + 1.0)) * (g + g.T)
        return S
    nfft = fft_length(n + lags)
    F = np.fft.rfft(s, nfft, axis=0)  # (nfft // 2 + 1, p)
    w = 1.0 - np.arange(1, lags + 1) / (bandwidth + 1.0)
    for i in range(p):
        # G_l[i, j] = sum_t s[t + l, i] s[t, j] = irfft(F_i conj(F_j))[l]
        cross = np.fft.irfft(F[:, i : i + 1] * np.conj(F), nfft, axis=0)[1 : lags + 1]
        row = w @ cross  # (p,): sum_l w_l G_l[i, :]
        S[i, :] += row
        S[:, i] += row
    return S


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
    S = _bartlett_long_run(s, min(bandwidth, n - 1), bandwidth)
    S *= n / max(n - s.shape[1], 1)
    H_inv = np.linalg.pinv(jac.T @ jac)
    cov = H_inv @ S @ H_inv
    return 0.5 * (cov + cov.T)


def detect_quantum(x: np.ndarray, min_levels: int = 3) -> float:
    """Quantisation step of ``x`` (an encoder's tick), or 0 when the values are not on a
    lattice: the smallest non-zero difference of the distinct values, accepted when at least
    95 % of the differences are whole multiples of it (to 1 %)."""
    u = np.unique(np.asarray(x, dtype=float)[np.isfinite(x)])
    if u.size < min_levels:
        return 0.0
    d = np.diff(u)
    d = d[d > 1e-12 * max(1.0, float(np.max(np.abs(u))))]
    if d.size < min_levels - 1:
        return 0.0
    q = float(np.min(d))
    ratio = d / q
    whole = np.abs(ratio - np.round(ratio)) < 0.01
    return q if whole.mean() >= 0.95 else 0.0
