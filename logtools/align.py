"""Put logical signals on one uniform time base.

Method (documented choice):

* The grid is uniform, ``t0 + round(k * 1e9 / rate_hz)`` ns, over the common span of the
  signals (latest first sample to earliest last sample). ``rate_hz=None`` takes the typical
  sample rate of the fastest signal, so already-uniform signals at that rate map onto themselves.
  The typical period (:func:`median_rate_hz`) is the median of the sample intervals longer than
  a tenth of the mean interval: a duplicate of every message 1 us (or 1 ns) after the original
  halves the mean but does not make the period 1 us, so the grid stays at the log's own rate
  (such a log once asked for 446 GiB). The grid never has more than
  :data:`MAX_GRID_FACTOR` times the rows of the most-sampled signal (or
  :data:`MAX_GRID_FLOOR` rows); a ``rate_hz`` that asks for more is refused.
* Continuous signals are **linearly interpolated** (``AlignMethod.INTERPOLATE``) or take the
  **nearest** sample (``AlignMethod.ASOF``, an as-of join with strategy "nearest").
* Angles in ``wrap`` (the headings, ``SignalSpec.heading``, as :mod:`logtools.load` passes
  them) are unwrapped before interpolation and wrapped back to [-pi, pi) afterwards; a bounded
  angle is interpolated as is.
* Commands in ``hold`` (``SignalSpec.command``, as :mod:`logtools.load` passes them) use a
  **zero-order hold**:
  the latest sample at or before the grid time (as-of backward), whatever the method.
* Tolerance: a grid row farther than ``tolerance_s`` from the source samples it uses (for
  interpolation: from the nearer of the two bracketing samples; for the hold: from the latest
  earlier sample) is null for that signal. Default: 2.5 median sample periods of that signal,
  so dropouts become nulls instead of straight lines across the gap. Interpolation never
  extrapolates: rows outside a signal's own span are null for it.

Source rows whose value is null or not finite are dropped; duplicate time stamps keep the last.

Gaps (:func:`find_gaps`): a signal has a gap where the time between two of its samples exceeds
``max(periods * its median period, min_gap_s)`` (defaults 5 and 0.5 s). Gaps of different
signals that overlap in time are one :class:`Gap` (a recorder stall on every topic at once is
one record naming all signals, not one per signal).
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
import polars as pl

from calib.results import JsonRecord
from logtools.errors import LogcalInputError, TimestampError

__all__ = [
    "AlignMethod",
    "Gap",
    "align_signals",
    "common_times",
    "find_gaps",
    "median_rate_hz",
    "resample_at",
]

GAP_PERIODS = 5.0
GAP_MIN_S = 0.5
MAX_GRID_FACTOR = 10
"""The aligned grid has at most this many times the samples of the most-sampled signal..."""
MAX_GRID_FLOOR = 1_000_000
"""...or this many rows, whichever is more (a few MB per column)."""


class AlignMethod(StrEnum):
    """How continuous signals are sampled on the grid."""

    INTERPOLATE = "interpolate"
    ASOF = "asof"


def _columns_of(name: str, frame: pl.DataFrame) -> dict[str, str]:
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
    if t_ns.size >= 2 and np.isfinite(v).all() and (t_ns[1:] > t_ns[:-1]).all():
        return t_ns, v  # already clean (the usual case): no copies of long signals
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
    """Typical sample rate (Hz) of sorted, distinct time stamps ``t_ns`` (ns): one over the
    median of the intervals longer than a tenth of the mean interval (near-duplicate stamps do
    not count as periods; see the module docstring)."""
    t = np.asarray(t_ns, dtype=np.int64)
    dt = np.diff(t).astype(float)
    if dt.size == 0:
        raise TimestampError("median_rate_hz: fewer than 2 time stamps")
    mean = (float(t[-1]) - float(t[0])) / dt.size
    periods = dt[dt > 0.1 * mean]
    return 1e9 / float(np.median(periods if periods.size else dt))


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
    hold: Iterable[str] = (),
    wrap: Iterable[str] = (),
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
    most = max(t.size for _, t, _ in series.values())
    rows = (float(end) - float(start)) * 1e-9 * rate_hz + 1
    if rows > max(MAX_GRID_FACTOR * most, MAX_GRID_FLOOR):
        raise LogcalInputError(
            f"align_signals: a grid at {rate_hz:.6g} Hz over {(end - start) * 1e-9:.6g} s has "
            f"{rows:.3g} rows, more than {MAX_GRID_FACTOR} times the {most} samples of the "
            "most-sampled signal; choose a rate near the log's own sample rates"
        )
    grid = _grid(int(start), int(end), rate_hz)
    cols: list[pl.Series] = []  # each column goes to polars as soon as it is sampled
    for key, (name, t, v) in series.items():
        period_ns = 1e9 / median_rate_hz(t)
        tol_ns = 2.5 * period_ns if tolerance_s is None else tolerance_s * 1e9
        if name in hold_set:
            sampled = _sample_hold(t, v, grid, tol_ns)
        elif name in wrap_set:
            u = _sample_continuous(t, np.unwrap(v), grid, tol_ns, method)
            sampled = (u + np.pi) % (2 * np.pi) - np.pi
        else:
            sampled = _sample_continuous(t, v, grid, tol_ns, method)
        cols.append(pl.Series(key, sampled, dtype=pl.Float64).fill_nan(None))
    frame = pl.DataFrame({"t_ns": pl.Series(grid, dtype=pl.Int64)})
    return frame.with_columns(cols)


def resample_at(
    t_src: np.ndarray,
    v: np.ndarray,
    t_ns: np.ndarray,
    *,
    hold: bool = False,
    tolerance_s: float | None = None,
) -> np.ndarray:
    """Sample one signal at the times ``t_ns`` (int64 ns): linear interpolation, or the latest
    earlier sample with ``hold``; NaN beyond ``tolerance_s`` (default 2.5 median periods) from
    the samples used and outside the signal's span.

    Args:
        t_src: the signal's sample times (int64 ns, increasing, distinct).
        v: its values.
        t_ns: the query times (int64 ns).
        hold: zero-order hold (commands) instead of interpolation.
        tolerance_s: largest distance (s) from a source sample.
    """
    t_src = np.asarray(t_src, dtype=np.int64)
    v = np.asarray(v, dtype=float)
    grid = np.asarray(t_ns, dtype=np.int64)
    if t_src.size == 0:
        return np.full(grid.shape, np.nan)
    if t_src.size == 1:
        out = np.where(grid == t_src[0], v[0], np.nan)
        return out.astype(float)
    tol_ns = 2.5 * 1e9 / median_rate_hz(t_src) if tolerance_s is None else tolerance_s * 1e9
    if hold:
        return _sample_hold(t_src, v, grid, tol_ns)
    return _sample_continuous(t_src, v, grid, tol_ns, AlignMethod.INTERPOLATE)


def common_times(
    frames: Mapping[str, pl.DataFrame], *, hold: bool = False, held: Collection[str] = ()
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Put signals (frames ``t_ns``, ``value``) on the sample times of the one with the most
    samples (the others by :func:`resample_at`: interpolated, or held for the commands of
    ``held``, the commands, and for all with ``hold``); NaN where an input has no sample near
    enough. Returns the times (int64 ns) and each signal's values there."""
    if not frames:
        return np.zeros(0, dtype=np.int64), {}
    base = max(frames, key=lambda n: frames[n].height)
    t_ns = frames[base]["t_ns"].to_numpy()
    out: dict[str, np.ndarray] = {}
    for name, frame in frames.items():
        t, v = frame["t_ns"].to_numpy(), frame["value"].to_numpy()
        if name == base or (t.size == t_ns.size and np.array_equal(t, t_ns)):
            out[name] = v.astype(float)
        else:
            out[name] = resample_at(t, v, t_ns, hold=hold or name in held)
    return t_ns, out


@dataclass(frozen=True)
class Gap(JsonRecord):
    """A stretch of time in which the named signals have no samples (dropout, recorder stall).

    Attributes:
        t0_ns: start (ns): the latest sample before the gap among ``signals`` (the earliest,
            when their gaps only chain together without a common stretch).
        t1_ns: end (ns): the earliest sample after the gap among ``signals`` (or the latest).
            No signal listed has a sample strictly between ``t0_ns`` and ``t1_ns``.
        signals: the signals without samples there, sorted.
        span_ns: (earliest last sample before, latest first sample after) over ``signals``: the
            whole stretch in which some listed signal is without samples.
    """

    json_properties = ("duration_s",)

    t0_ns: int
    t1_ns: int
    signals: tuple[str, ...]
    span_ns: tuple[int, int] = (0, 0)

    @property
    def duration_s(self) -> float:
        """Length of the gap (s), ``t1_ns - t0_ns``."""
        return (self.t1_ns - self.t0_ns) * 1e-9

    def covers(self, t_ns: np.ndarray) -> np.ndarray:
        """Mask of the times ``t_ns`` (ns) strictly inside ``span_ns``."""
        t = np.asarray(t_ns)
        lo, hi = self.span_ns if self.span_ns != (0, 0) else (self.t0_ns, self.t1_ns)
        return (t > lo) & (t < hi)


def find_gaps(
    times: Mapping[str, np.ndarray | pl.Series | pl.DataFrame],
    *,
    periods: float = GAP_PERIODS,
    min_gap_s: float = GAP_MIN_S,
) -> list[Gap]:
    """Recorder stalls and dropouts across signals, each reported once.

    A signal has a gap between two consecutive samples more than
    ``max(periods * median period, min_gap_s)`` apart. Gaps of different signals that overlap
    in time are merged into one :class:`Gap` listing all of them, so a stall of the recorder on
    every topic at once gives one record.

    Args:
        times: signal name -> its sample times (int64 ns): an array, a Series, or a frame with
            ``t_ns``.
        periods: gap threshold in median sample periods of the signal.
        min_gap_s: the threshold is never below this (s).

    Returns:
        The gaps, sorted by start time.
    """
    spans: list[tuple[int, int, str]] = []
    for name, obj in times.items():
        if isinstance(obj, pl.DataFrame):
            obj = obj["t_ns"]
        t = _sorted_distinct(np.asarray(obj.to_numpy() if isinstance(obj, pl.Series) else obj))
        t = t.astype(np.int64)
        if t.size < 3:
            continue
        dt = np.diff(t)
        limit = max(periods * float(np.median(dt)), min_gap_s * 1e9)
        for i in np.flatnonzero(dt > limit):
            spans.append((int(t[i]), int(t[i + 1]), name))
    spans.sort()
    gaps: list[Gap] = []
    cur: list[tuple[int, int, str]] = []
    for span in spans:
        if cur and span[0] >= max(e for _, e, _ in cur):
            gaps.append(_merge(cur))
            cur = []
        cur.append(span)
    if cur:
        gaps.append(_merge(cur))
    return gaps


def _sorted_distinct(t: np.ndarray) -> np.ndarray:
    """``np.unique(t)``; time stamps usually arrive sorted, and then dropping repeats is one
    linear pass instead of unique's hashing and sorting."""
    if t.ndim == 1 and t.size > 1:
        step = t[1:] >= t[:-1]
        if step.all():
            return t[np.append(True, t[1:] != t[:-1])]
    return np.unique(t)


def _merge(spans: list[tuple[int, int, str]]) -> Gap:
    lo, hi = min(s for s, _, _ in spans), max(e for _, e, _ in spans)
    t0, t1 = max(s for s, _, _ in spans), min(e for _, e, _ in spans)
    if t1 <= t0:  # the gaps chain together without a stretch common to all
        t0, t1 = lo, hi
    return Gap(t0, t1, tuple(sorted({n for _, _, n in spans})), (lo, hi))
