"""Put logical signals on one uniform time base.

Method (documented choice):

* The grid is uniform, ``t0 + round(k * 1e9 / rate_hz)`` ns, over the common span of the
  signals (latest first sample to earliest last sample). ``rate_hz=None`` takes the median
  sample rate of the fastest signal, so already-uniform signals at that rate map onto themselves.
* Continuous signals are **linearly interpolated** (``AlignMethod.INTERPOLATE``) or take the
  **nearest** sample (``AlignMethod.ASOF``, an as-of join with strategy "nearest").
* Angles in ``wrap`` (default ``yaw``) are unwrapped before interpolation and wrapped back to
  [-pi, pi) afterwards; the joint angle ``psi`` is bounded and interpolated as is.
* Commands in ``hold`` (``kappa_cmd``, ``v_cmd``, ``omega_cmd``) use a **zero-order hold**:
  the latest sample at or before the grid time (as-of backward), whatever the method.
* Tolerance: a grid row farther than ``tolerance_s`` from the source samples it uses (for
  interpolation: from the nearer of the two bracketing samples; for the hold: from the latest
  earlier sample) is null for that signal. Default: 2.5 median sample periods of that signal,
  so dropouts become nulls instead of straight lines across the gap. Interpolation never
  extrapolates: rows outside a signal's own span are null for it.

Source rows whose value is null or not finite are dropped; duplicate time stamps keep the last.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from enum import StrEnum

import numpy as np
import polars as pl

from logtools.errors import LogcalInputError, TimestampError

__all__ = ["AlignMethod", "align_signals", "median_rate_hz"]

DEFAULT_HOLD = ("kappa_cmd", "v_cmd", "omega_cmd")
DEFAULT_WRAP = ("yaw",)


class AlignMethod(StrEnum):
    """How continuous signals are sampled on the grid."""

    INTERPOLATE = "interpolate"
    ASOF = "asof"


def _columns_of(name: str, frame: pl.DataFrame) -> dict[str, np.ndarray]:
    """Value columns of one signal frame, keyed by output column name."""
    if "t_ns" not in frame.columns:
        raise LogcalInputError(f"signal {name!r}: frame has no 't_ns' column ({frame.columns})")
    cols = [c for c in frame.columns if c != "t_ns"]
    if not cols:
        raise LogcalInputError(f"signal {name!r}: frame has no value column besides 't_ns'")
    out = {}
    for c in cols:
        key = name if (c == "value" or len(cols) == 1) else f"{name}.{c}"
        out[key] = c
    return out


def _clean(name: str, t_ns: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop non-finite values, sort by time and keep the last of duplicate stamps."""
    ok = np.isfinite(v)
    t_ns, v = t_ns[ok], v[ok]
    order = np.argsort(t_ns, kind="stable")
    t_ns, v = t_ns[order], v[order]
    if t_ns.size:
        keep = np.append(t_ns[1:] != t_ns[:-1], True)
        t_ns, v = t_ns[keep], v[keep]
    if t_ns.size < 2:
        raise TimestampError(
            f"signal {name!r}: {t_ns.size} usable sample(s); at least 2 with distinct time "
            "stamps and finite values are needed to align it"
        )
    return t_ns, v


def median_rate_hz(t_ns: np.ndarray) -> float:
    """Median sample rate (Hz) of sorted, distinct time stamps ``t_ns`` (ns)."""
    dt = np.diff(np.asarray(t_ns, dtype=np.int64))
    return 1e9 / float(np.median(dt))


def _grid(start_ns: int, end_ns: int, rate_hz: float) -> np.ndarray:
    period_ns = 1e9 / rate_hz
    n = int(np.floor((end_ns - start_ns) / period_ns + 1e-9)) + 1
    grid = start_ns + np.round(np.arange(n) * period_ns).astype(np.int64)
    return grid[grid <= end_ns]


def _sample_hold(t_src: np.ndarray, v: np.ndarray, grid: np.ndarray, tol_ns: float) -> np.ndarray:
    idx = np.searchsorted(t_src, grid, side="right") - 1
    ok = idx >= 0
    idx_c = np.clip(idx, 0, t_src.size - 1)
    out = v[idx_c].astype(float)
    ok &= (grid - t_src[idx_c]) <= tol_ns
    out[~ok] = np.nan
    return out


def _sample_continuous(
    t_src: np.ndarray, v: np.ndarray, grid: np.ndarray, tol_ns: float, method: AlignMethod
) -> np.ndarray:
    hi = np.clip(np.searchsorted(t_src, grid, side="left"), 0, t_src.size - 1)
    lo = np.clip(hi - 1, 0, t_src.size - 1)
    d_lo = np.abs(grid - t_src[lo])
    d_hi = np.abs(t_src[hi] - grid)
    near = np.where(d_lo <= d_hi, lo, hi)
    dist = np.minimum(d_lo, d_hi)
    if method is AlignMethod.ASOF:
        out = v[near].astype(float)
    else:
        base = t_src[0]
        out = np.interp((grid - base).astype(float), (t_src - base).astype(float), v)
        out[(grid < t_src[0]) | (grid > t_src[-1])] = np.nan  # no extrapolation
    out[dist > tol_ns] = np.nan
    return out


def align_signals(
    signals: Mapping[str, pl.DataFrame],
    *,
    rate_hz: float | None = None,
    method: AlignMethod = AlignMethod.INTERPOLATE,
    tolerance_s: float | None = None,
    hold: Iterable[str] = DEFAULT_HOLD,
    wrap: Iterable[str] = DEFAULT_WRAP,
    required: Iterable[str] | None = None,
) -> pl.DataFrame:
    """Resample signals onto one uniform grid over their common span.

    Args:
        signals: logical name -> frame with ``t_ns`` (int64 ns) and ``value`` (float); a frame
            with several value columns gives columns ``name.column``.
        rate_hz: grid rate (Hz); None: median rate of the fastest signal.
        method: interpolation or nearest-sample (as-of) for continuous signals.
        tolerance_s: largest distance (s) from a source sample; None: 2.5 median periods of
            each signal.
        hold: signals sampled by zero-order hold (commands).
        wrap: angle signals (rad) unwrapped before and wrapped to [-pi, pi) after sampling.
        required: signals whose common span sets the grid; None: all of them.

    Returns:
        Frame with ``t_ns`` (int64, strictly increasing) and one float64 column per signal,
        null where no source sample is within tolerance.

    Raises:
        LogcalInputError: no signals, or a frame without ``t_ns``/value columns.
        TimestampError: a signal with fewer than 2 samples, or spans that do not overlap.
    """
    if not signals:
        raise LogcalInputError("align_signals: no signals to align")
    method = AlignMethod(method)
    hold_set, wrap_set = set(hold), set(wrap)
    if rate_hz is not None and not (np.isfinite(rate_hz) and rate_hz > 0):
        raise LogcalInputError(f"align_signals: rate_hz must be a positive number, got {rate_hz}")
    series: dict[str, tuple[str, np.ndarray, np.ndarray]] = {}
    for name, frame in signals.items():
        t_all = frame["t_ns"].cast(pl.Int64).to_numpy()
        for key, col in _columns_of(name, frame).items():
            v = frame[col].cast(pl.Float64).fill_null(np.nan).to_numpy()
            t, v = _clean(key, t_all, v)
            series[key] = (name, t, v)
    req = set(signals) if required is None else set(required)
    spans = [(t[0], t[-1]) for n, t, _ in series.values() if n in req]
    if not spans:
        raise LogcalInputError(f"align_signals: none of the required signals {sorted(req)} given")
    start, end = max(s for s, _ in spans), min(e for _, e in spans)
    if end <= start:
        raise TimestampError(
            "align_signals: the signals do not overlap in time (latest start "
            f"{start} ns is after earliest end {end} ns); check clock offsets between topics"
        )
    if rate_hz is None:
        rate_hz = max(median_rate_hz(t) for _, t, _ in series.values())
    grid = _grid(int(start), int(end), rate_hz)
    out: dict[str, np.ndarray] = {"t_ns": grid}
    for key, (name, t, v) in series.items():
        period_ns = 1e9 / median_rate_hz(t)
        tol_ns = 2.5 * period_ns if tolerance_s is None else tolerance_s * 1e9
        if name in hold_set:
            out[key] = _sample_hold(t, v, grid, tol_ns)
        elif name in wrap_set:
            u = _sample_continuous(t, np.unwrap(v), grid, tol_ns, method)
            out[key] = (u + np.pi) % (2 * np.pi) - np.pi
        else:
            out[key] = _sample_continuous(t, v, grid, tol_ns, method)
    frame = pl.DataFrame({"t_ns": pl.Series(grid, dtype=pl.Int64)})
    cols = [pl.Series(k, a, dtype=pl.Float64).fill_nan(None) for k, a in out.items() if k != "t_ns"]
    return frame.with_columns(cols)
