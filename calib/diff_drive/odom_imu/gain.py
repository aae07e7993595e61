"""The constant yaw-rate gain G = odometry yaw rate / gyro yaw rate, fitted on windows by least
squares (gyro yaw change = odometry's / G + bias x duration), with moving-block bootstrap
intervals, per bin of turn rate or speed, and widened under a misfit on the slope 1 / G (which
is well behaved where G is not)."""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from scipy.stats import t as student_t

from calib.adequacy import Adequacy, under_misfit
from calib.adequacy.intervals import Z95
from calib.diff_drive.odom_imu.windows import Windows
from calib.results import Estimate

__all__ = ["N_BOOT", "binned", "block_boot", "fit_gain", "gain_under_misfit", "interval"]

Array = NDArray[np.float64]

N_BOOT = 500


def fit_gain(w: Windows, rows: NDArray[np.intp]) -> tuple[float, float]:
    """gyro = a odo + bias dt on ``rows``: returns (G = 1/a, bias)."""
    X = np.column_stack([w.odo[rows], w.dt[rows]])
    (a, bias), *_ = np.linalg.lstsq(X, w.gyro[rows], rcond=None)
    return (1.0 / a if a != 0 else math.nan), float(bias)


def gain_under_misfit(gain: Estimate, adequacy: Adequacy, pieces: Sequence[float]) -> Estimate:
    """:func:`calib.adequacy.under_misfit` of the yaw-rate gain G = 1 / a taken on a, the
    slope the regression fits (gyro = a odometry + bias): a piece that barely turns gives an a
    near its error and a G that blows up, so the pieces' spread is taken on a (well behaved,
    errors symmetric) and the widened interval mapped back through 1 / a (open above when it
    reaches a = 0)."""
    if not (math.isfinite(gain.value) and gain.value != 0 and math.isfinite(gain.std)):
        return under_misfit(gain, adequacy)
    a = 1.0 / gain.value
    a_est = Estimate(
        "odometry_to_gyro_slope",
        a,
        gain.std * a * a,
        (a - Z95 * gain.std * a * a, a + Z95 * gain.std * a * a),
        gain.identifiable,
        "1",
    )
    a_pieces = [1.0 / g for g in pieces if math.isfinite(g) and g != 0]
    wa = under_misfit(a_est, adequacy, pieces=a_pieces)
    if wa is a_est:
        return gain
    lo_a, hi_a = wa.ci95
    if not (math.isfinite(lo_a) and math.isfinite(hi_a)):
        return Estimate(
            gain.name, gain.value, math.nan, (-math.inf, math.inf), False, gain.unit, wa.note
        )
    if lo_a * hi_a <= 0:  # the interval of a reaches zero: G unbounded on one side
        ci = (1.0 / hi_a, math.inf) if a > 0 else (-math.inf, 1.0 / lo_a)
    else:
        ci = (min(1.0 / lo_a, 1.0 / hi_a), max(1.0 / lo_a, 1.0 / hi_a))
    std = wa.std / (a * a)
    return Estimate(
        gain.name,
        gain.value,
        std,
        ci,
        False,
        gain.unit,
        wa.note + "; spread taken on the slope 1 / G and mapped",
    )


def block_boot(n: int, rng: np.random.Generator, reps: int) -> list[NDArray[np.intp]]:
    """Row indices of ``reps`` moving-block bootstrap resamples of ``n`` rows (blocks of
    n^(1/3))."""
    blk = max(1, round(n ** (1 / 3)))
    out = []
    for _ in range(reps):
        starts = rng.integers(0, n - blk + 1, size=int(np.ceil(n / blk)))
        out.append((starts[:, None] + np.arange(blk)).ravel()[:n].astype(np.intp))
    return out


def interval(
    name: str, value: float, boot: Array, dof: int, unit: str, note: str, ok: bool = True
) -> Estimate:
    """``value`` ± t std of the finite bootstrap replicates ``boot``, t on ``dof``."""
    boot = boot[np.isfinite(boot)]
    std = float(np.std(boot, ddof=1)) if boot.size > 1 else math.nan
    q = float(student_t.ppf(0.975, max(1, dof)))
    ci = (value - q * std, value + q * std) if math.isfinite(std) else (math.nan, math.nan)
    return Estimate(name, value, std, ci, ok and math.isfinite(std), unit, note)


def binned(
    w: Windows,
    key: Array,
    edges: Sequence[float],
    use: NDArray[np.bool_],
    rng: np.random.Generator,
) -> list[dict[str, float]]:
    """The gain fitted on the windows of each bin of ``key`` (bins of at least 8 windows that
    turn 0.5 rad in all), with a bootstrap std."""
    out = []
    for lo, hi in itertools.pairwise(edges):
        rows = np.flatnonzero(use & (key >= lo) & (key < hi)).astype(np.intp)
        if rows.size < 8 or float(np.sum(np.abs(w.odo[rows]))) < 0.5:
            continue
        g, _ = fit_gain(w, rows)
        boot = []
        for _ in range(200):
            r = rng.choice(rows, rows.size)
            boot.append(fit_gain(w, r)[0])
        out.append(
            {
                "lo": float(lo),
                "hi": float(hi),
                "gain": g,
                "std": float(np.nanstd(boot, ddof=1)),
                "windows": int(rows.size),
            }
        )
    return out
