"""Savitzky-Golay smoothing and differentiation of uniformly sampled signals.

The same filter as ``scipy.signal.savgol_filter`` with its default ``mode="interp"``: inside,
each point is the value (or derivative) at the window's centre of the least-squares polynomial
through the window, a fixed correlation; within half a window of either end, the polynomial
fitted to the first (last) full window is evaluated at those points. Written here because
importing ``scipy.signal`` (which pulls in ``scipy.stats``) costs a noticeable share of
``logcal analyze``'s start-up CPU and memory per process (``bench/bench_cli_startup.py``), for a
filter of a few lines; the tests hold it to scipy's on random signals.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["savgol_filter"]

FloatArray = NDArray[np.float64]


@cache
def _fit_matrix(window: int, polyorder: int) -> FloatArray:
    """Pseudo-inverse ((polyorder + 1) x window) of the Vandermonde matrix at the window's
    positions scaled to u in [-1, 1] (well conditioned for long windows): row j maps the
    window's samples to the fitted u^j coefficient."""
    half = max(window // 2, 1)
    u = np.arange(-(window // 2), window // 2 + 1, dtype=float) / half
    vander = u[:, None] ** np.arange(polyorder + 1)[None, :]
    pinv = np.asarray(np.linalg.pinv(vander), dtype=np.float64)
    pinv.setflags(write=False)
    return pinv


def _evaluate(coef: FloatArray, z: FloatArray, deriv: int) -> FloatArray:
    """d^deriv/du^deriv of the polynomials ``coef`` ((order + 1) x k, rising powers) at ``z``."""
    order = coef.shape[0] - 1
    out = np.zeros((z.size, coef.shape[1]))
    for j in range(deriv, order + 1):
        factor = math.factorial(j) / math.factorial(j - deriv)
        out += factor * (z[:, None] ** (j - deriv)) * coef[j][None, :]
    return out


def savgol_filter(
    x: ArrayLike, window: int, polyorder: int, deriv: int = 0, delta: float = 1.0
) -> FloatArray:
    """Savitzky-Golay filter of ``x`` (1-D, uniformly sampled every ``delta``).

    Args:
        x: samples.
        window: odd number of samples in each fit, at most ``len(x)``.
        polyorder: polynomial order, less than ``window``.
        deriv: order of the derivative returned (0: the smoothed signal).
        delta: sample spacing (the derivative is per unit of it).

    Raises:
        ValueError: an even or too-long window, or ``polyorder >= window``.
    """
    y = np.asarray(x, dtype=float)
    if y.ndim != 1:
        raise ValueError(f"savgol_filter: a 1-D signal is expected, got shape {y.shape}")
    if window % 2 != 1 or window < 1:
        raise ValueError(f"savgol_filter: window must be a positive odd number, got {window}")
    if polyorder >= window:
        raise ValueError(f"savgol_filter: polyorder {polyorder} must be below window {window}")
    if window > y.size:
        raise ValueError(f"savgol_filter: window {window} longer than the signal ({y.size})")
    if deriv > polyorder:
        return np.zeros_like(y)
    pinv = _fit_matrix(window, polyorder)
    half = window // 2
    scale = (delta * max(half, 1)) ** -deriv  # d/dx = d/du / (delta * half)
    weights = math.factorial(deriv) * pinv[deriv] * scale
    out = np.empty_like(y)
    out[half : y.size - half] = np.correlate(y, weights, mode="valid")
    if half:
        z = np.arange(-half, 0, dtype=float) / half
        ends = np.stack([y[:window], y[-window:]], axis=1)  # window x 2
        coef = pinv @ ends
        out[:half] = _evaluate(coef[:, :1], z, deriv)[:, 0] * scale
        out[y.size - half :] = _evaluate(coef[:, 1:], -z[::-1], deriv)[:, 0] * scale
    return out
