"""How many independent samples a correlated series holds: autocorrelation (by FFT), the
effective sample size, and the lag-1 factor.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "autocorrelation",
    "effective_samples",
    "fft_length",
    "lag1_autocorrelation",
    "lag1_factor",
]

FloatArray = NDArray[np.float64]


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
    out: FloatArray = ac / ac[0] if ac[0] > 0 else np.zeros(max_lag + 1)
    return out


def effective_samples(r: np.ndarray) -> float:
    """n / (1 + 2 sum of the residual's autocorrelation up to its first non-positive lag)."""
    x = np.asarray(r, dtype=float)
    x = x[np.isfinite(x)]
    n = x.size
    if n < 8 or not np.any(x != x[0]):
        return float(n)
    rho = autocorrelation(x, min(n // 4, 500))[1:]
    cut = np.nonzero(rho <= 0)[0]
    rho = rho[: cut[0]] if cut.size else rho
    return float(n / max(1.0, 1.0 + 2.0 * float(rho.sum())))


def lag1_autocorrelation(r: np.ndarray, rows: np.ndarray | None = None) -> float:
    """Lag-1 autocorrelation of ``r`` (mean removed) over ``rows`` (a boolean mask; pairs that
    straddle a gap of the mask are skipped); 0 for a constant series."""
    r = np.asarray(r, dtype=float)
    mk = np.ones(r.size, dtype=bool) if rows is None else np.asarray(rows, dtype=bool)
    if not mk.any():
        return 0.0
    pair = mk[1:] & mk[:-1]
    x = r - r[mk].mean()
    den = float(np.sum(x[mk] ** 2))
    return 0.0 if den <= 0 else float(np.sum((x[1:] * x[:-1])[pair]) / den)


def lag1_factor(r: np.ndarray, rows: np.ndarray | None = None, max_rho: float = 0.995) -> float:
    """Effective-sample factor (1 - rho) / (1 + rho) of an AR(1)-like series, rho its lag-1
    autocorrelation clipped to [0, ``max_rho``] (1.0 for an empty mask)."""
    mk = None if rows is None else np.asarray(rows, dtype=bool)
    if mk is not None and not mk.any():
        return 1.0
    rho = min(max(lag1_autocorrelation(r, mk), 0.0), max_rho)
    return (1.0 - rho) / (1.0 + rho)
