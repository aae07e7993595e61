"""A parameter over one robot's logs in time order: a step change (a hitch that was moved) and
a linear trend (a wheel that wore), each with a test that uses the per-log standard errors.

Step: the likelihood-ratio statistic of one change in the mean at an unknown log, for
Gaussian estimates with their stated std (Hinkley's change-point test with known variances):
LR = S0 - min_m [S_left(m) + S_right(m)], S = sum w_i (x_i - weighted mean)^2, w = 1/s^2,
each side holding at least ``MIN_SIDE`` logs. Its null distribution (no change) is not
chi^2 (the split is searched), so the p-value is a parametric bootstrap: ``DRAWS`` sets of
x_i ~ N(pooled mean, s_i^2) with a fixed seed (reproducible). ``change_point`` is flagged when
p < ``CHANGE_ALPHA``.

The test trusts the stated std: when the scatter around the two levels still exceeds it
(``dispersion`` = S_min / (k - 2) beyond its chi^2 99 % point), the report says the flag may
come from underestimated per-log uncertainty rather than from a change.

Trend: weighted least squares of the value on time (days since the first log); slope with its
std and the two-sided z-test p-value (known variances).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import stats

from calib.results import json_safe

__all__ = ["CHANGE_ALPHA", "DRAWS", "MIN_SIDE", "DriftResult", "detect_drift"]

CHANGE_ALPHA = 0.01
DRAWS = 2000
MIN_SIDE = 2
_SEED = 20240516
_NS_PER_DAY = 86_400e9


@dataclass(frozen=True)
class DriftResult:
    """Drift of one parameter of one robot over its logs (in time order).

    Attributes:
        n_logs: logs used (determined estimates with a known time).
        status: ``ok``, or ``too few logs`` (fewer than 2 * MIN_SIDE) with nothing tested.
        change_point: a step change is flagged (p_change < CHANGE_ALPHA).
        p_change: bootstrap p-value of the step test.
        change_after: the last log before the step; ``change_before``: the first after it.
        level_before, level_after, shift, shift_std: the weighted means on each side, their
            difference and its std.
        dispersion: S_min / (k - 2): ~1 when the two levels and the stated std explain the
            logs; ``overdispersed``: beyond its chi^2 99 % point.
        slope_per_day, slope_std, p_trend: weighted linear trend over time (None when all logs
            share one time).
        note: one sentence for the report.
    """

    n_logs: int
    status: str
    change_point: bool = False
    p_change: float | None = None
    change_after: str | None = None
    change_before: str | None = None
    level_before: float | None = None
    level_after: float | None = None
    shift: float | None = None
    shift_std: float | None = None
    dispersion: float | None = None
    overdispersed: bool = False
    slope_per_day: float | None = None
    slope_std: float | None = None
    p_trend: float | None = None
    note: str = ""

    def to_dict(self) -> dict[str, Any]:
        return json_safe(dict(self.__dict__))


def _split_costs(x: NDArray[np.float64], w: NDArray[np.float64]) -> NDArray[np.float64]:
    """S_left(m) + S_right(m) for m = MIN_SIDE .. k - MIN_SIDE (rows of ``x`` are draws)."""
    cw, cwx, cwx2 = np.cumsum(w), np.cumsum(w * x, axis=-1), np.cumsum(w * x * x, axis=-1)
    k = x.shape[-1]
    m = np.arange(MIN_SIDE, k - MIN_SIDE + 1)
    left = cwx2[..., m - 1] - cwx[..., m - 1] ** 2 / cw[m - 1]
    rw = cw[-1] - cw[m - 1]
    rwx = cwx[..., -1:] - cwx[..., m - 1]
    rwx2 = cwx2[..., -1:] - cwx2[..., m - 1]
    right = rwx2 - rwx**2 / rw
    return np.asarray(left + right, dtype=float)


def _total_cost(x: NDArray[np.float64], w: NDArray[np.float64]) -> NDArray[np.float64]:
    sw, swx = np.sum(w), np.sum(w * x, axis=-1)
    return np.asarray(np.sum(w * x * x, axis=-1) - swx**2 / sw, dtype=float)


def detect_drift(
    logs: Sequence[str],
    start_ns: Sequence[int],
    values: Sequence[float],
    stds: Sequence[float],
    unit: str = "",
) -> DriftResult:
    """Test one parameter's per-log estimates (already in time order, determined, std > 0)
    for a step change and a linear trend (see the module docstring)."""
    k = len(values)
    if k < 2 * MIN_SIDE:
        return DriftResult(
            k,
            "too few logs",
            note=f"{k} log(s): a step change needs at least {2 * MIN_SIDE} determined logs",
        )
    x = np.asarray(values, dtype=float)
    s = np.asarray(stds, dtype=float)
    w = 1.0 / s**2
    costs = _split_costs(x, w)
    best = int(np.argmin(costs))
    m = best + MIN_SIDE
    lr = float(_total_cost(x, w) - costs[best])
    mean = float(np.sum(w * x) / np.sum(w))
    rng = np.random.default_rng(_SEED)
    draws = mean + s * rng.standard_normal((DRAWS, k))
    lr_null = _total_cost(draws, w) - np.min(_split_costs(draws, w), axis=-1)
    p_change = float((1 + np.sum(lr_null >= lr)) / (DRAWS + 1))
    wl, wr = float(np.sum(w[:m])), float(np.sum(w[m:]))
    before = float(np.sum(w[:m] * x[:m]) / wl)
    after = float(np.sum(w[m:] * x[m:]) / wr)
    shift_std = math.sqrt(1 / wl + 1 / wr)
    dispersion = float(costs[best]) / (k - 2)
    overdispersed = bool(float(costs[best]) > stats.chi2.ppf(0.99, k - 2))
    flagged = p_change < CHANGE_ALPHA
    t_days = (np.asarray(start_ns, dtype=float) - float(start_ns[0])) / _NS_PER_DAY
    slope = slope_std = p_trend = None
    if np.ptp(t_days) > 0:
        tw = float(np.sum(w * t_days) / np.sum(w))
        sxx = float(np.sum(w * (t_days - tw) ** 2))
        slope = float(np.sum(w * (t_days - tw) * (x - mean)) / sxx)
        slope_std = 1.0 / math.sqrt(sxx)
        p_trend = float(2 * stats.norm.sf(abs(slope) / slope_std))
    u = f" {unit}" if unit else ""
    if flagged:
        note = (
            f"step change after {logs[m - 1]}: {before:.4g} -> {after:.4g}{u} "
            f"(shift {after - before:+.3g} ± {shift_std:.2g}{u}; bootstrap p = "
            f"{p_change:.2g}, the smallest {DRAWS} draws can give is {1 / (DRAWS + 1):.1g})"
        )
        if overdispersed:
            note += (
                "; the logs scatter beyond their stated uncertainty around both levels "
                f"(dispersion {dispersion:.2g}), so the flag may come from understated "
                "per-log uncertainty or gradual drift"
            )
    else:
        note = f"no step change (p = {p_change:.2g})"
    return DriftResult(
        k,
        "ok",
        flagged,
        p_change,
        logs[m - 1],
        logs[m],
        before,
        after,
        after - before,
        shift_std,
        dispersion,
        overdispersed,
        slope,
        slope_std,
        p_trend,
        note,
    )
