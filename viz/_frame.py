"""Small helpers reading the aligned log frame for the recording and the plots."""

from __future__ import annotations

import numpy as np
import polars as pl
from numpy.typing import NDArray

__all__ = [
    "column",
    "has",
    "robust_limits",
    "times_ns",
]


def has(frame: pl.DataFrame, *names: str) -> bool:
    """True when every column in ``names`` exists in ``frame``."""
    return all(n in frame.columns for n in names)


def column(frame: pl.DataFrame, name: str) -> NDArray[np.float64]:
    """Column ``name`` as float64 with nulls as NaN."""
    return frame[name].cast(pl.Float64).fill_null(np.nan).to_numpy().astype(np.float64)


def times_ns(frame: pl.DataFrame) -> NDArray[np.int64]:
    """The ``t_ns`` column (int64, absolute ns)."""
    return frame["t_ns"].cast(pl.Int64).to_numpy().astype(np.int64)


def robust_limits(*series: NDArray[np.float64]) -> tuple[float, float] | None:
    """Plot limits from the 1-99 % quantiles of the finite values, widened 20 %: a spike
    (kappa = omega / v near standstill) must not flatten a plot. None with < 2 values."""
    v = np.concatenate([np.asarray(x, dtype=float).ravel() for x in series]) if series else None
    if v is None:
        return None
    v = v[np.isfinite(v)]
    if v.size < 2:
        return None
    lo, hi = np.quantile(v, [0.01, 0.99])
    pad = 0.2 * max(float(hi - lo), 1e-6)
    return float(lo - pad), float(hi + pad)
