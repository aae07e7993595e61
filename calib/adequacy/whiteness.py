"""Whiteness of a residual: the Ljung-Box portmanteau test, shared by every robot's adequacy
check and by the tractor-trailer's command-driven discovery."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.special import chdtrc

__all__ = ["ljung_box"]


def ljung_box(r: NDArray[np.float64], lags: int = 20) -> tuple[float, float]:
    """Ljung-Box statistic Q and its p-value (chi-square, ``lags`` dof) for whiteness of ``r``."""
    x = np.asarray(r, dtype=float) - np.mean(r)
    n = x.size
    lags = max(1, min(lags, n // 4))
    den = float(np.dot(x, x))
    if den <= 0 or n < 8:
        return 0.0, 1.0
    rho = np.array([np.dot(x[k:], x[:-k]) / den for k in range(1, lags + 1)])
    q = float(n * (n + 2) * np.sum(rho**2 / (n - np.arange(1, lags + 1))))
    return q, float(chdtrc(lags, q))  # chi2(lags).sf(q), without importing scipy.stats
