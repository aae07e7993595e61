"""Noise levels read off a signal itself: the white-noise standard deviation of a smooth signal
(from its second differences, or from each sample against the line through its neighbours at
uneven times), a robust scale, and a sensor's quantisation step.

One name, one meaning: :func:`hf_noise_std_t` is the one estimate at uneven times every robot
uses (robust, and not fooled by a signal that mostly repeats its last value).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "MAD_TO_STD",
    "TIED_SHARE",
    "detect_quantum",
    "hf_noise_std",
    "hf_noise_std_t",
    "local_line_errors",
    "mad_std",
]

FloatArray = NDArray[np.float64]

MAD_TO_STD = 1.482602218505602
"""1 / Phi^-1(3/4): the median absolute deviation of a normal sample times this is its std."""
TIED_SHARE = 0.3
"""When more than this share of the local-line errors are exactly zero (a signal that mostly
repeats its last value: a current reading 0 while a joint rests), the median absolute deviation
collapses and the RMS of the errors is used instead."""


def mad_std(x: np.ndarray) -> float:
    """Robust standard deviation of the finite values of ``x``: MAD x ``MAD_TO_STD`` (0 for
    none)."""
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    return MAD_TO_STD * float(np.median(np.abs(x - np.median(x)))) if x.size else 0.0


def hf_noise_std(x: np.ndarray, min_samples: int = 5) -> float:
    """White-noise standard deviation of a smooth signal sampled densely, from its second
    differences: x[i+1] - 2 x[i] + x[i-1] has variance 6 sigma^2 (robust MAD estimate).

    Args:
        x: samples (any unit), evenly spaced, NaN-free.
        min_samples: fewer samples than this give 0.

    Returns:
        sigma in the unit of ``x``.
    """
    x = np.asarray(x, dtype=float)
    if x.size < max(min_samples, 3):
        return 0.0
    d2 = x[2:] - 2.0 * x[1:-1] + x[:-2]
    mad = float(np.median(np.abs(d2 - np.median(d2))))
    return MAD_TO_STD * mad / math.sqrt(6.0)


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
    """White-noise std of ``x`` at times ``t`` from :func:`local_line_errors`: a robust (MAD)
    estimate, or the RMS where more than ``TIED_SHARE`` of the errors are exact ties."""
    e = local_line_errors(t, x)
    if e.size < 3:
        return 0.0
    finite = np.asarray(x, dtype=float)
    finite = finite[np.isfinite(finite)]
    scale = float(np.max(np.abs(finite))) if finite.size else 1.0
    if np.mean(np.abs(e) <= 1e-12 * (scale or 1.0)) > TIED_SHARE:
        return math.sqrt(float(np.mean(e * e)))
    return MAD_TO_STD * float(np.median(np.abs(e - np.median(e))))


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
