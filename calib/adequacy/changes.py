"""Parameters that change mid-log (a trailer swapped, a payload picked up, a tyre changed).

The robot fits its parameters on consecutive pieces of the log (each with its own standard
errors); one constant set is tested against two sets with a change between two pieces. The
change is reported when the two-set model lowers the chi-square by more than the 99.9 %
point of its degrees of freedom *and* by a large factor relative to the piece-to-piece scatter
that remains (pieces' standard errors are model-conditional, so the scatter left within each
side scales them). Two size gates keep a misfit or a drift from passing for a change: some
parameter must move by at least ``min_relative`` of its size, and the split must remove at least
``min_removed`` of the scatter one constant set leaves above its degrees of freedom; and a
straight line in time (a drift) must not fit the pieces as well as the step. The robot
then splits the log there and estimates each piece.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.special import chdtri

from calib.adequacy.verdict import ParameterChange

__all__ = ["PieceFit", "parameter_change"]

MIN_PIECES = 4


@dataclass(frozen=True)
class PieceFit:
    """The robot's parameters fitted on one piece of the log, ``t0_s``-``t1_s``."""

    t0_s: float
    t1_s: float
    values: Mapping[str, float]
    std: Mapping[str, float]


def _chi2(vals: np.ndarray, var: np.ndarray) -> float:
    w = 1.0 / var
    mean = (w * vals).sum(axis=0) / w.sum(axis=0)
    return float(((vals - mean) ** 2 * w).sum())


def _chi2_trend(tm: np.ndarray, vals: np.ndarray, var: np.ndarray) -> float:
    """Chi-square of a weighted straight line in time through each parameter's pieces."""
    total = 0.0
    for j in range(vals.shape[1]):
        w = 1.0 / var[:, j]
        A = np.column_stack([np.ones_like(tm), tm]) * np.sqrt(w)[:, None]
        coef = np.linalg.lstsq(A, vals[:, j] * np.sqrt(w), rcond=None)[0]
        total += float(((vals[:, j] * np.sqrt(w) - A @ coef) ** 2).sum())
    return total


def parameter_change(
    pieces: Sequence[PieceFit],
    names: Sequence[str],
    *,
    p_value: float = 1e-3,
    min_factor: float = 4.0,
    min_relative: float = 0.01,
    min_removed: float = 0.5,
    scale: Mapping[str, float] | None = None,
) -> ParameterChange | None:
    """The most likely single change of ``names`` between consecutive ``pieces``, or None when
    one constant set describes them (or there are fewer than ``MIN_PIECES`` usable pieces).
    ``scale``: per name, a size below which the relative gate would be unfair (a value near
    zero)."""
    use = [
        p
        for p in pieces
        if all(
            math.isfinite(p.values.get(n, math.nan))
            and p.std.get(n, 0.0) > 0
            and math.isfinite(p.std.get(n, math.nan))
            for n in names
        )
    ]
    if len(use) < MIN_PIECES:
        return None
    vals = np.array([[p.values[n] for n in names] for p in use])
    var = np.array([[p.std[n] ** 2 for n in names] for p in use])
    null = _chi2(vals, var)
    best, at = math.inf, -1
    for s in range(2, len(use) - 1):  # at least two pieces each side
        c = _chi2(vals[:s], var[:s]) + _chi2(vals[s:], var[s:])
        if c < best:
            best, at = c, s
    if at < 0:
        return None
    k = len(names)
    dof_split = max(1, k * (len(use) - 2))
    overdispersion = max(1.0, best / dof_split)
    drop = (null - best) / overdispersion
    if drop < max(float(chdtri(k, p_value)), min_factor * k):
        return None
    tm = np.array([0.5 * (p.t0_s + p.t1_s) for p in use])
    if _chi2_trend(tm, vals, var) <= best:
        return None  # a drift fits as well as one step: not a change
    dof_null = k * (len(use) - 1)
    if null > dof_null and (null - best) < min_removed * (null - dof_null):
        return None
    w = 1.0 / var
    before = (w[:at] * vals[:at]).sum(axis=0) / w[:at].sum(axis=0)
    after = (w[at:] * vals[at:]).sum(axis=0) / w[at:].sum(axis=0)
    size = np.array(
        [max(abs(b), (scale or {}).get(n, 0.0)) for n, b in zip(names, before, strict=True)]
    )
    if not np.any(np.abs(after - before) >= min_relative * size):
        return None
    t = 0.5 * (use[at - 1].t1_s + use[at].t0_s)
    names_t = tuple(names)
    desc = ", ".join(
        f"{n} {b:.4g} -> {a:.4g}" for n, b, a in zip(names_t, before, after, strict=True)
    )
    return ParameterChange(
        t,
        (use[at - 1].t0_s, use[at].t1_s),
        names_t,
        dict(zip(names_t, map(float, before), strict=True)),
        dict(zip(names_t, map(float, after), strict=True)),
        float(null - best),
        f"the parameters change near t = {t:.1f} s ({desc})",
    )
