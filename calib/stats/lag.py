"""The time offset between two clocks that recorded one motion: the lag at which two rate
signals (e.g. a log's turn rate and a ground truth's yaw rate) correlate best.

Both are resampled on one step over their own spans and cross-correlated by FFT with masks, so
that every lag is judged by its own overlap (a Pearson correlation over the samples both have),
and lags whose overlap is under ``min_overlap`` of the shorter signal are not considered. The
peak is refined to a fraction of the step by a parabola through its neighbours. No guess of
the offset is needed: clocks a thousand seconds apart are found as readily as close ones.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.signal import fftconvolve

__all__ = ["ClockLag", "clock_lag"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class ClockLag:
    """``offset_s``: seconds to add to the second signal's stamps to put them on the first's
    clock; ``correlation``: the Pearson correlation at that lag; ``overlap_s``: the time both
    cover there; ``step_s``: the resampling step (the offset's resolution before refinement)."""

    offset_s: float
    correlation: float
    overlap_s: float
    step_s: float


def _on_grid(t: Array, v: Array, step: float) -> tuple[float, Array, Array]:
    ok = np.isfinite(t) & np.isfinite(v)
    t, v = t[ok], v[ok]
    grid = np.arange(t[0], t[-1], step)
    return float(t[0]), np.interp(grid, t, v), np.ones(grid.size)


def _xc(a: Array, b: Array) -> Array:
    """Sum over j of a[j + k] b[j] for every shift k (index k + len(b) - 1)."""
    return np.asarray(fftconvolve(a, b[::-1], mode="full"))


def clock_lag(
    t_a: Array, a: Array, t_b: Array, b: Array, *, step_s: float, min_overlap: float = 0.5
) -> ClockLag | None:
    """The offset (s) to add to ``t_b`` so that ``b`` follows ``a`` best (module docstring);
    None when the signals are too short or carry no variation."""
    if t_a.size < 4 or t_b.size < 4 or not step_s > 0:
        return None
    a0, ga, ma = _on_grid(t_a, a, step_s)
    b0, gb, mb = _on_grid(t_b, b, step_s)
    if ga.size < 4 or gb.size < 4:
        return None
    n = np.rint(_xc(ma, mb))
    s_a, s_b = _xc(ga, mb), _xc(ma, gb)
    s_ab, s_aa, s_bb = _xc(ga, gb), _xc(ga**2, mb), _xc(ma, gb**2)
    with np.errstate(invalid="ignore", divide="ignore"):
        cov = s_ab - s_a * s_b / n
        var = (s_aa - s_a**2 / n) * (s_bb - s_b**2 / n)
        r = cov / np.sqrt(var)
    r[(n < min_overlap * min(ga.size, gb.size)) | ~np.isfinite(r)] = -np.inf
    k = int(np.argmax(r))
    if not np.isfinite(r[k]) or r[k] <= 0:
        return None
    frac = 0.0
    if 0 < k < r.size - 1 and np.isfinite(r[k - 1]) and np.isfinite(r[k + 1]):
        den = r[k - 1] - 2 * r[k] + r[k + 1]
        frac = 0.5 * (r[k - 1] - r[k + 1]) / den if den < 0 else 0.0
    shift = (k - (gb.size - 1)) + frac  # a[j + shift] pairs with b[j]
    offset = float(a0 - b0 + shift * step_s)
    return ClockLag(offset, float(r[k]), float(n[k]) * step_s, step_s)
